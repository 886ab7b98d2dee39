//! In-run thermal calibration (SPEC §3a): one run of `ten-position-9+9`
//! three times over (300 s dwells, 4.8 h) while the chamber ramps 10 → 50
//! °C at 0.2 °C/min and then holds, of a unit whose biases, scale factors
//! and mountings move linearly with temperature and whose gyro biases
//! follow Ṫ. With the thermal states the linear coefficients of the
//! biases, scale factors and mountings and the three k come out within 3σ
//! of the truth and the 25 °C values within Table 1; the model check
//! passes. Without them the result proposes them, and the 25 °C values
//! are off. Over 20 seeds: `cargo bench --bench thermal`.

use crate::table1_support;
use crate::thermal_support;

use std::sync::atomic::AtomicBool;

use sinscal_core::calib::result::NoiseSource;
use sinscal_core::calib::sources::calibrate_simulated;
use sinscal_core::calib::{CalibrationResult, Effect, ErrorModel, EstimateOptions, NoiseDensity};
use sinscal_core::compensation::thermal::ThermalTerms;
use sinscal_core::compensation::CompensationFile;
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::model::ErrorParameters;
use sinscal_core::pipeline::{calibrate_file, compensate_file, CompensateTarget};
use sinscal_core::sim::{Noise, SimConfig};
use thermal_support::*;

#[test]
fn a_ramped_run_gives_its_thermal_coefficients_and_25_c_values() {
    let cfg = ramp_config(1);
    let opts = EstimateOptions {
        model: ErrorModel::base().and(Effect::Thermal),
        ..EstimateOptions::default()
    };
    let r = calibrate_simulated(&cfg, &opts).unwrap();
    assert_eq!(r.model.to_string(), "base-24+thermal");
    let thermal = r.thermal.as_ref().expect("a thermal object");
    let range = thermal.range_c;
    assert!(
        (range[0] - 10.0).abs() < 0.1 && (range[1] - 50.0).abs() < 1e-9,
        "{range:?}"
    );
    let z = ramp_coefficient_z(thermal);
    assert_eq!(z.len(), 24);
    for (name, z) in &z {
        assert!(z.abs() < 3.0, "{name}: {z:.2} σ from the truth");
    }
    table1_support::assert_within_table1(&r, &ErrorParameters::paper(), "ramped run at 25 °C");
    let check = r.model_check.as_ref().unwrap();
    assert!(check.adequate, "{}", check.summary);
    // The run's temperature as the column gave it, and no proposal of what
    // was done.
    let t = r.temperature.unwrap();
    assert!((t.max_rate_c_per_min - 0.2).abs() < 0.01, "{t:?}");
    assert!(
        r.warnings.iter().all(|w| !w.contains("--thermal")),
        "{:?}",
        r.warnings
    );
}

/// The in-run thermal states on a chamber ramp at a line's rate, noise
/// free: every linear coefficient and k within 1e-4 of its truth or 1σ
/// of the same run with navigation-grade noise, whichever is larger. The
/// noisy run's σ is the filter's under that noise model, which the data
/// do not change: the noise-free run calibrated under the stated model
/// gives the noise-free estimate with the noisy run's σ. Rising and held
/// at 100 Hz; falling at 20 Hz. Before the effect columns passed through
/// the compensator's J⁻¹ the accelerometer coefficients were 0.15–0.3 %
/// off, 0.8–1.2 of that σ for the scale factors and far beyond 1e-4.
#[test]
fn noise_free_chamber_ramps_return_their_thermal_coefficients() {
    let opts = EstimateOptions {
        model: ErrorModel::base().and(Effect::Thermal),
        noise: Some(NoiseDensity::white(0.0003, 5.0)),
        cross_check: false,
        ..EstimateOptions::default()
    };
    for (ramp, rate_hz) in [(ChamberRamp::Rising, 100.0), (ChamberRamp::Falling, 20.0)] {
        let cfg = chamber_config(ramp, rate_hz, Noise::default(), 1);
        let r = calibrate_simulated(&cfg, &opts).unwrap();
        let errors = chamber_errors(r.thermal.as_ref().unwrap(), &chamber_truth(&[]));
        assert_eq!(errors.len(), 24);
        for (name, err, sigma, truth) in errors {
            let bound = (1e-4 * truth.abs()).max(sigma);
            assert!(
                err.abs() <= bound,
                "{ramp:?} at {rate_hz} Hz, {name}: off by {err:e} ({:.2e} of {truth}), \
                 bound {bound:e}",
                err / truth
            );
        }
        assert!(r.model_check.as_ref().unwrap().adequate);
    }
}

/// A quadratic thermal term the in-run linear states lack fails the model
/// check of a real unit's run (pulses, bias instability) under the unit's
/// noise model; the same run without the term passes. The chamber's rising
/// ramp at 20 Hz. The noise model is given, as a line that has
/// characterised the unit gives it (`calibrate --noise`): fitting it to
/// each run costs some 260 likelihood evaluations of the thermal filter,
/// 80 s a run here. The same check with the model fitted to each run (the
/// fit carries quadratic states, so its wander does not take the curvature
/// up), and the size at which it starts to see the term:
/// `cargo bench --bench thermal -- 4 quadratic --real`.
#[test]
fn a_thermal_curvature_the_linear_states_lack_fails_a_real_unit_s_check() {
    let noise = Noise {
        gyro_quantum_arcsec: 1.0,
        accel_quantum_mps: 1e-4,
        gyro_bias_instability_deg_h: 0.001,
        accel_bias_instability_ug: 1.0,
        ..Noise::default_navigation_grade()
    };
    let opts = EstimateOptions {
        model: ErrorModel::base().and(Effect::Thermal),
        cross_check: false,
        noise: Some(NoiseDensity::from(&noise)),
        ..EstimateOptions::default()
    };
    for (quadratic_ug_per_c2, adequate) in [(0.0, true), (CURVATURE_SEEN_UG_PER_C2, false)] {
        let cfg = SimConfig {
            thermal: Some(chamber_truth(&[("accel_bias_x", quadratic_ug_per_c2)])),
            ..chamber_config(ChamberRamp::Rising, 20.0, noise.clone(), 3)
        };
        let r = calibrate_simulated(&cfg, &opts).unwrap();
        assert_eq!(r.noise_model.as_ref().unwrap().source, NoiseSource::Given);
        let check = r.model_check.as_ref().unwrap();
        assert_eq!(
            check.adequate, adequate,
            "accel_bias_x quadratic {quadratic_ug_per_c2} µg/°C²: {}",
            check.summary
        );
    }
}

/// The smallest curvature of the accelerometer bias the bench's real-noise
/// runs flag on every seed (FIGURES, Thermal; 0.02 is flagged on none):
/// q·L²/4 = 20 µg between the chord and the curve at the middle of the
/// 40 °C ramp.
const CURVATURE_SEEN_UG_PER_C2: f64 = 0.05;

#[test]
fn without_thermal_states_the_run_proposes_them() {
    let r = calibrate_simulated(&ramp_config(1), &EstimateOptions::default()).unwrap();
    assert_eq!(r.model.to_string(), "base-24");
    assert!(r.thermal.is_none());
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("spanned 40.0 °C") && w.contains("--thermal")),
        "{:?}",
        r.warnings
    );
    // What the states are for: the run's parameters without them are an
    // average over 10–50 °C, and the gyro biases carry k Ṫ.
    let (worst, name) = table1_support::worst_against_table1(&r, &ErrorParameters::paper());
    assert!(worst > 3.0, "{name}: {worst:.2} of its bound");
    let auto = EstimateOptions {
        thermal_auto: true,
        ..EstimateOptions::default()
    };
    let r = calibrate_simulated(&ramp_config(1), &auto).unwrap();
    assert_eq!(r.model.to_string(), "base-24+thermal");
}

/// `sinscal compensate` applies a file's thermal terms at the run's
/// temperature record by record: the ramped run compensated with its
/// truth (the 25 °C parameters and the SPEC §3a truth as thermal terms)
/// calibrates, without thermal states, to zero within 3.5σ with an
/// adequate model check; compensated with the 25 °C parameters alone it
/// does not.
#[test]
fn compensating_with_thermal_terms_follows_the_run_s_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = ramp_config(2);
    let run = write_simulated_run(&cfg, dir.path(), DataFormat::F64le, false, "RLG-R").unwrap();
    let meta = RunMetadata::from_json(&std::fs::read(&run.metadata).unwrap()).unwrap();
    let mut file = CompensationFile::from_truth(&cfg.params);
    let compensate = |file: &CompensationFile, name: &str| {
        let target = CompensateTarget {
            data: dir.path().join(name).join("run.bin"),
            format: DataFormat::F64le,
            gzip: false,
            any_unit: false,
        };
        std::fs::create_dir_all(dir.path().join(name)).unwrap();
        let out = compensate_file(&run.data, &meta, file, &target).unwrap();
        let meta = RunMetadata::from_json(&std::fs::read(&out.metadata).unwrap()).unwrap();
        let never = AtomicBool::new(false);
        let opts = EstimateOptions::default();
        calibrate_file(&out.data, &meta, &opts, &mut |_| {}, &never).unwrap()
    };
    let plain = compensate(&file, "plain");
    file.thermal = Some(ThermalTerms::of_truth(&ramp_truth(), [10.0, 50.0]));
    let thermal = compensate(&file, "thermal");
    let worst_z = |r: &CalibrationResult| {
        r.parameters
            .iter()
            .map(|(n, p)| (n.clone(), (p.value / p.sigma).abs()))
            .fold(
                (String::new(), 0.0f64),
                |a, b| if b.1 > a.1 { b } else { a },
            )
    };
    let (name, z) = worst_z(&thermal);
    eprintln!("with thermal terms: largest {name} at {z:.2}σ");
    assert!(
        z < 3.5,
        "{name}: {z:.2}σ from zero after thermal compensation"
    );
    assert!(thermal.model_check.as_ref().unwrap().adequate);
    let (name, z) = worst_z(&plain);
    eprintln!("25 °C terms alone: largest {name} at {z:.2}σ");
    assert!(z > 10.0, "without the thermal terms only {name} at {z:.2}σ");
}
