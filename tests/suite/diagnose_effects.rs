//! Each SPEC §3 effect at a realistic size is named
//! first, fitted within 3σ, the gap's excess over the noise shrinks by
//! ≥ 90 % and ends within 1.2× the noise floor, and the 24 base
//! parameters come back inside the paper's Table 1 bounds.

use crate::diagnosis_support;

use diagnosis_support::*;
use sinscal_core::model::effects::{BiasDrift, LeverArms};
use sinscal_core::model::Effects;

#[test]
fn accel_delay_is_named() {
    let effects = Effects {
        accel_delay: Some(2.0),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(600.0), effects, 3);
    assert_found(&run(&cfg), &cfg, &["accel_delay"]);
}

#[test]
fn accel_lever_arm_is_named() {
    // Each accelerometer 2–10 cm along its own axis.
    let effects = Effects {
        accel_lever_arm: Some(LeverArms {
            x: [50.0, 0.0, 0.0],
            y: [0.0, -30.0, 0.0],
            z: [0.0, 0.0, 80.0],
        }),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(600.0), effects, 4);
    assert_found(&run(&cfg), &cfg, &["accel_lever_arm"]);
}

#[test]
fn gyro_g_sensitivity_is_named() {
    let effects = Effects {
        gyro_g_sensitivity: Some([0.01, 0.0, 0.005, 0.0, -0.015, 0.0, 0.008, 0.0, 0.02]),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(600.0), effects, 5);
    assert_found(&run(&cfg), &cfg, &["gyro_g_sensitivity"]);
}

#[test]
fn bias_drift_is_named() {
    let effects = Effects {
        bias_drift: Some(BiasDrift {
            gyro: [0.01, -0.005, 0.02],
            accel: [10.0, -5.0, 20.0],
        }),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(300.0), effects, 6);
    assert_found(&run(&cfg), &cfg, &["bias_drift"]);
}

#[test]
fn gyro_scale_asymmetry_is_named() {
    let effects = Effects {
        gyro_scale_asymmetry: Some([60.0, -40.0, 90.0]),
        ..Effects::none()
    };
    let cfg = config(both_ways(600.0), effects, 7);
    assert_found(&run(&cfg), &cfg, &["gyro_scale_asymmetry"]);
}

#[test]
fn two_effects_are_both_named() {
    let effects = Effects {
        accel_delay: Some(1.0),
        bias_drift: Some(BiasDrift {
            gyro: [0.0, 0.0, 0.0],
            accel: [15.0, 0.0, -10.0],
        }),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(600.0), effects, 8);
    let rep = run(&cfg);
    let mut named = rep.named.clone();
    named.sort();
    assert_eq!(named, ["accel_delay", "bias_drift"], "{}", rep.verdict);
    let order: Vec<&str> = rep.named.iter().map(String::as_str).collect();
    assert_found(&rep, &cfg, &order);
}
