//! The file's forms agree with each other and with the parameters.

use std::collections::BTreeMap;

use super::*;
use crate::calib::{CalibrationResult, Effect, ErrorModel, ParameterEstimate, ResultEstimator};
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
        estimator: ResultEstimator::Kf,
        model: ErrorModel::base(),
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

/// A result with in-run thermal states gives a file whose terms at any
/// temperature are the result's linear model (and k in SI); the terms
/// survive JSON and appear as CSV rows. A unit's model across soaks gives
/// its 25 °C values and its linear and quadratic terms.
#[test]
fn thermal_terms_come_from_a_run_or_a_unit_model() {
    use crate::calib::thermal_states::{RunThermal, RunThermalParameter, Term};
    use crate::thermal::{fit_thermal_model, SoakedRun};
    let p = ErrorParameters::paper();
    let mut res = result(&p);
    let parameters = res
        .parameters
        .iter()
        .map(|(name, e)| {
            let linear = (name == "accel_bias_y").then_some(Term {
                value: 2.5,
                sigma: 0.1,
            });
            let q = RunThermalParameter {
                value: e.value,
                sigma: e.sigma,
                unit: e.unit.clone(),
                linear,
                covariance: Vec::new(),
            };
            (name.clone(), q)
        })
        .collect();
    let k = Term {
        value: 0.02,
        sigma: 0.003,
    };
    res.model = ErrorModel::base().and(Effect::Thermal);
    res.thermal = Some(RunThermal {
        parameters,
        gyro_bias_rate: [("z".to_string(), k)].into_iter().collect(),
        range_c: [10.0, 50.0],
    });
    let file = CompensationFile::from_result(&res, Provenance::default()).unwrap();
    let back = CompensationFile::from_json(file.to_json().as_bytes()).unwrap();
    let t = back.thermal.as_ref().unwrap();
    assert_eq!(t.source, thermal::ThermalSource::Run);
    let i = crate::model::params::index_of("accel_bias_y").unwrap();
    let at_45 = back.parameters_at(45.0);
    let expect = p.si[i] + 2.5 * PARAMETERS[i].si_per_unit * 20.0;
    assert!(
        (at_45.si[i] - expect).abs() < 1e-15,
        "{} {expect}",
        at_45.si[i]
    );
    assert_eq!(back.parameters_at(45.0).si[0], p.si[0]);
    // 0.02 deg/h per °C/min, in rad/s per °C/s.
    let k_si = 0.02 * crate::model::units::DEG_PER_H * 60.0;
    assert!(same(t.gyro_bias_rad_per_s_per_c_per_s[2], k_si));
    let csv = back.to_csv();
    assert!(csv.contains("# thermal (run)"), "{csv}");
    assert!(csv.contains("accel_bias_y.linear,b_a[1]/degC,"), "{csv}");
    assert!(csv.contains("gyro_bias_rate_z,k[2],"), "{csv}");

    // Three soaks of a unit whose accel_bias_x moves 2 µg/°C.
    let runs: Vec<SoakedRun> = [-10.0, 25.0, 60.0]
        .into_iter()
        .map(|temperature_c| {
            let mut r = result(&p);
            r.parameters.get_mut("accel_bias_x").unwrap().value += 2.0 * (temperature_c - 25.0);
            SoakedRun {
                label: format!("{temperature_c}"),
                temperature_c,
                parameters: r.parameters,
            }
        })
        .collect();
    let model = fit_thermal_model(&runs).unwrap();
    let file = CompensationFile::from_thermal_model(&model, Provenance::default()).unwrap();
    let t = file.thermal.as_ref().unwrap();
    assert_eq!(
        (t.source, t.range_c),
        (thermal::ThermalSource::Unit, [-10.0, 60.0])
    );
    let j = crate::model::params::index_of("accel_bias_x").unwrap();
    let slope = t.linear_per_c.si()[j] / PARAMETERS[j].si_per_unit;
    assert!((slope - 2.0).abs() < 1e-9, "{slope}");
    assert!((file.parameters().si[j] - p.si[j]).abs() < 1e-12);
}
