//! The file's forms agree with each other and with the parameters.

use std::collections::BTreeMap;

use super::*;
use crate::calib::{CalibrationResult, ParameterEstimate};
use crate::model::{ErrorParameters, N_PARAMS, PARAMETERS};

/// A result whose σ are 1 % of each value plus one canonical unit.
fn result(params: &ErrorParameters) -> CalibrationResult {
    let parameters: BTreeMap<String, ParameterEstimate> = PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, info)| {
            let v = params.canonical(i);
            let est = ParameterEstimate {
                value: v,
                sigma: 0.01 * v.abs() + 1.0,
                unit: info.unit.into(),
            };
            (info.name.to_string(), est)
        })
        .collect();
    CalibrationResult {
        estimator: "kf".into(),
        model: "base-24".into(),
        parameters,
        records: 1234,
        ..CalibrationResult::default()
    }
}

fn random_params() -> ErrorParameters {
    use rand::SeedableRng;
    ErrorParameters::random(&mut rand_chacha::ChaCha8Rng::seed_from_u64(3))
}

/// Equal to the last bit a JSON reader is held to (serde_json's default
/// parser may round the last bit differently from ryu's shortest form).
fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 2.0 * f64::EPSILON * a.abs().max(b.abs())
}

#[test]
fn json_round_trips_values_sigma_and_provenance() {
    let p = random_params();
    let prov = Provenance {
        unit_serial: Some("RLG-0042".into()),
        run_id: Some("0b8e-run".into()),
        ..Provenance::default()
    };
    let file = CompensationFile::from_result(&result(&p), prov).unwrap();
    assert_eq!(file.provenance.model, "base-24");
    assert_eq!(file.provenance.records, Some(1234));
    let back = CompensationFile::from_json(file.to_json().as_bytes()).unwrap();
    assert_eq!(back.provenance, file.provenance);
    assert_eq!(back.convention, file.convention);
    let (a, b) = (file.parameters(), back.parameters());
    let (sa, sb) = (file.sigma().unwrap(), back.sigma().unwrap());
    for i in 0..N_PARAMS {
        assert!(same(a.si[i], b.si[i]), "{}", PARAMETERS[i].name);
        assert!(same(sa[i], sb[i]), "σ {}", PARAMETERS[i].name);
        // And both are the result's, in SI.
        assert!(same(a.si[i], p.si[i]), "{}", PARAMETERS[i].name);
        let sigma_si = (0.01 * p.canonical(i).abs() + 1.0) * PARAMETERS[i].si_per_unit;
        assert!(same(sa[i], sigma_si), "σ {}", PARAMETERS[i].name);
    }
}

#[test]
fn matrices_hold_each_parameter_where_the_contract_places_it() {
    let p = random_params();
    let file = CompensationFile::from_truth(&p);
    let at = |name: &str| p.si[crate::model::params::index_of(name).unwrap()];
    assert_eq!(file.gyro.scale_misalignment[0][0], at("gyro_scale_x"));
    assert_eq!(file.gyro.scale_misalignment[1][2], at("gyro_misalign_yz"));
    assert_eq!(file.gyro.scale_misalignment[2][1], 0.0);
    assert_eq!(file.accel.scale_misalignment[1][0], at("accel_misalign_yx"));
    assert_eq!(file.accel.scale_misalignment[2][1], at("accel_misalign_zy"));
    assert_eq!(file.accel.bias_m_per_s2[2], at("accel_bias_z"));
    assert_eq!(file.accel.quadratic_s2_per_m[1], at("accel_quad_y"));
    assert!(file.sigma().is_none());
    assert_eq!(file.parameters(), p);
}

#[test]
fn csv_has_a_row_per_parameter_with_si_units() {
    let p = random_params();
    let file = CompensationFile::from_result(&result(&p), Provenance::default()).unwrap();
    let csv = file.to_csv();
    let rows: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows[0], table::CSV_HEADER);
    assert_eq!(rows.len(), 1 + N_PARAMS);
    for (i, row) in rows[1..].iter().enumerate() {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells.len(), 5, "{row}");
        assert_eq!(cells[0], PARAMETERS[i].name);
        assert_eq!(cells[3], table::si_unit(PARAMETERS[i].group));
        assert!(same(cells[2].parse::<f64>().unwrap(), p.si[i]), "{row}");
        assert!(cells[4].parse::<f64>().unwrap() > 0.0, "{row}");
    }
    assert!(csv.contains("accel_misalign_yx,K_a[1][0],"), "{csv}");
    assert!(csv.contains("accel_quad_z,D_a[2],"), "{csv}");
    assert!(csv.contains(",rad/s,") && csv.contains(",s^2/m,"));
    assert!(csv.contains("# measurement model: "));
}

#[test]
fn load_tells_a_result_from_a_file_and_refuses_others() {
    let p = random_params();
    let res = serde_json::to_vec(&result(&p)).unwrap();
    let from_result = CompensationFile::load(&res, Provenance::default()).unwrap();
    let from_file =
        CompensationFile::load(from_result.to_json().as_bytes(), Provenance::default()).unwrap();
    for i in 0..N_PARAMS {
        assert!(same(from_file.parameters().si[i], p.si[i]));
    }
    assert!(matches!(
        CompensationFile::load(b"{\"unit_serial\": \"A1\"}", Provenance::default()),
        Err(CompensationError::UnknownDocument)
    ));
}

#[test]
fn validation_refuses_what_a_loader_would_misread() {
    let file = CompensationFile::from_truth(&ErrorParameters::paper());
    let mut lower = file.clone();
    lower.gyro.scale_misalignment[2][0] = 1e-4;
    assert!(lower.validate().is_err());
    let mut stale = file.clone();
    stale.accel.scale_misalignment[0][1] += 1e-6;
    let err = stale.validate().unwrap_err().to_string();
    assert!(err.contains("inverse_i_plus_k"), "{err}");
    let mut tag = file.clone();
    tag.format = "other".into();
    assert!(CompensationFile::from_json(tag.to_json().as_bytes()).is_err());
    assert!(file.validate().is_ok());
}
