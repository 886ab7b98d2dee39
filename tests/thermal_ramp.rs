//! In-run thermal calibration (SPEC §3a): one run of `ten-position-9+9`
//! three times over (300 s dwells, 4.8 h) while the chamber ramps 10 → 50
//! °C at 0.2 °C/min and then holds, of a unit whose biases, scale factors
//! and mountings move linearly with temperature and whose gyro biases
//! follow Ṫ. With the thermal states the linear coefficients of the
//! biases, scale factors and mountings and the three k come out within 3σ
//! of the truth and the 25 °C values within Table 1; the model check
//! passes. Without them the result proposes them, and the 25 °C values
//! are off. Over 20 seeds: `cargo bench --bench thermal`.

#[path = "table1_support/mod.rs"]
mod table1_support;
mod thermal_support;

use sinscal::calib::sources::calibrate_simulated;
use sinscal::calib::{Effect, ErrorModel, EstimateOptions};
use sinscal::model::ErrorParameters;
use thermal_support::*;

#[test]
fn a_ramped_run_gives_its_thermal_coefficients_and_25_c_values() {
    let cfg = ramp_config(1);
    let opts = EstimateOptions {
        model: ErrorModel::base().and(Effect::Thermal),
        ..EstimateOptions::default()
    };
    let r = calibrate_simulated(&cfg, &opts).unwrap();
    assert_eq!(r.model, "base-24+thermal");
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

#[test]
fn without_thermal_states_the_run_proposes_them() {
    let r = calibrate_simulated(&ramp_config(1), &EstimateOptions::default()).unwrap();
    assert_eq!(r.model, "base-24");
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
    assert_eq!(r.model, "base-24+thermal");
}
