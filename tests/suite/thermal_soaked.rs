//! A thermal model from five soaked runs (SPEC §3a; `ten-position`, 600 s
//! dwells, at −20, 5, 25, 45 and 65 °C) of a unit with linear coefficients
//! on 16 parameters and quadratic ones on 3: every coefficient within 3σ
//! of the truth, the values at 25 °C within the seed paper's Table 1, no
//! quadratic term invented or missed; prediction inside the range and a
//! refusal outside it; and a run whose bias jumped flagged by the check.
//! Over 10 and 20 seeds: `cargo bench --bench thermal`.

use crate::table1_support;
use crate::thermal_support;

use sinscal_core::calib::{CalibrationResult, ParameterEstimate};
use sinscal_core::model::{ErrorParameters, PARAMETERS};
use sinscal_core::thermal::{fit_thermal_model, ThermalError};
use thermal_support::*;

#[test]
fn five_soaks_give_the_unit_s_thermal_model_and_a_jump_is_flagged() {
    let runs = soaked_runs(1);
    let model = fit_thermal_model(&runs).unwrap();
    assert!(model.check.adequate, "{}", model.check.summary);
    assert_eq!(model.range_c, [-20.0, 65.0]);
    for (name, term, z) in coefficient_z(&model) {
        assert!(z.abs() < 3.0, "{name} {term}: {z:.2} σ from the truth");
    }
    let (invented, missed) = quadratic_errors(&model);
    assert!(
        invented.is_empty(),
        "quadratic terms the unit lacks: {invented:?}"
    );
    assert!(missed.is_empty(), "quadratic terms missed: {missed:?}");
    // The 25 °C values within Table 1.
    let at_25 = CalibrationResult {
        parameters: model
            .parameters
            .iter()
            .map(|(n, p)| {
                let e = ParameterEstimate {
                    value: p.value,
                    sigma: p.sigma,
                    unit: p.unit.clone(),
                };
                (n.clone(), e)
            })
            .collect(),
        ..CalibrationResult::default()
    };
    table1_support::assert_within_table1(
        &at_25,
        &ErrorParameters::paper(),
        "thermal model at 25 °C",
    );
    // Prediction: the truth at 35 °C within 3σ; 80 °C refused unless
    // asked, and then marked.
    let truth_35 = parameters_at(35.0);
    for (i, p) in PARAMETERS.iter().enumerate() {
        let pr = model.predict(p.name, 35.0, false).unwrap();
        assert!(!pr.extrapolated);
        let z = (pr.value - truth_35.canonical(i)) / pr.sigma;
        assert!(z.abs() < 3.5, "{} at 35 °C: {z:.2} σ", p.name);
    }
    assert!(matches!(
        model.predict("gyro_bias_x", 80.0, false),
        Err(ThermalError::OutOfRange { .. })
    ));
    assert!(
        model
            .predict("gyro_bias_x", 80.0, true)
            .unwrap()
            .extrapolated
    );
    // One run's accelerometer bias jumped by 30 µg between runs: the check
    // names the run and the parameter.
    let mut jumped = runs.clone();
    jumped[2].parameters.get_mut("accel_bias_y").unwrap().value += 30.0;
    let bad = fit_thermal_model(&jumped).unwrap();
    assert!(!bad.check.adequate, "{}", bad.check.summary);
    let first = &bad.check.outliers[0];
    assert_eq!(first.parameter, "accel_bias_y");
    assert_eq!(first.run, runs[2].label);
    // One temperature is not a model.
    let one = vec![runs[2].clone(), runs[2].clone()];
    assert!(matches!(
        fit_thermal_model(&one),
        Err(ThermalError::Input(_))
    ));
}
