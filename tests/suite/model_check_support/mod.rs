//! Shared set-up of the model-check test and benchmark: SPEC runs with
//! and without effects the base model lacks, calibrated through the
//! library entry point, and the check's verdict on each.

#![allow(dead_code)]

// The test runs' site and schemes are the discrepancy workflow's (the
// crate that includes this module declares `diagnosis_support` beside it).
pub use super::diagnosis_support::{both_ways, nine_plus_nine};

use sinscal_core::calib::sources::calibrate_simulated;
use sinscal_core::calib::{CalibrationResult, EstimateOptions, ModelCheck};
use sinscal_core::model::effects::{BiasDrift, LeverArms};
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::Site;
use sinscal_core::sim::{Noise, Scheme, SimConfig};

/// Navigation grade (the reference scenario's noise).
pub fn navigation_grade() -> Noise {
    Noise::default_navigation_grade()
}

/// Tactical grade at the noisy end of the range: ARW 0.003 deg/√h, VRW
/// 50 µg/√Hz.
pub fn tactical_grade() -> Noise {
    Noise {
        gyro_arw_deg_rt_h: 0.003,
        accel_vrw_ug_rt_hz: 50.0,
        ..Noise::default()
    }
}

/// A real navigation-grade unit (SPEC §2a) drawn from `seed`: 1″ and
/// 1e-4 m/s pulses, bias instability 0.0005–0.003 deg/h and 1–5 µg, rate
/// random walk 0.0001–0.0005 deg/h/√h and 1–3 µg/√h (each log-uniform),
/// 30 µg of floor vibration over 2–9 Hz, on the white noise of
/// [`navigation_grade`].
pub fn real_navigation_grade(seed: u64) -> Noise {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7000 + seed);
    let mut log_uniform = |lo: f64, hi: f64| (lo.ln() + rng.gen::<f64>() * (hi / lo).ln()).exp();
    let mut n = navigation_grade();
    n.gyro_quantum_arcsec = 1.0;
    n.accel_quantum_mps = 1e-4;
    n.gyro_bias_instability_deg_h = log_uniform(0.0005, 0.003);
    n.accel_bias_instability_ug = log_uniform(1.0, 5.0);
    n.gyro_rrw_deg_h_rt_h = log_uniform(0.0001, 0.0005);
    n.accel_rw_ug_rt_h = log_uniform(1.0, 3.0);
    n.vibration = Some(sinscal_core::sim::Vibration {
        rms_ug: 30.0,
        band_hz: [2.0, 9.0],
    });
    n
}

/// The 9+9 scheme turned by hand (SPEC §4): fast S-shaped flips about
/// axes a few degrees off, the unit lifted and set down elsewhere.
pub fn nine_plus_nine_by_hand(dwell_s: f64, seed: u64) -> Scheme {
    Scheme::by_hand(
        &nine_plus_nine(dwell_s),
        seed,
        &sinscal_core::sim::HandTurns::default(),
    )
    .unwrap()
}

/// A run of the paper's truth: `rate` Hz, a start a few tenths of a
/// degree off nominal.
pub fn config(scheme: Scheme, effects: Effects, noise: Noise, rate: f64, seed: u64) -> SimConfig {
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: rate,
        scheme,
        params: ErrorParameters::paper(),
        effects,
        noise,
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed,
        thermal: None,
        temperature: None,
    }
}

/// Calibrates without the cross-check (it does not change the filter's
/// last pass, where the check is made).
pub fn calibrate(cfg: &SimConfig) -> CalibrationResult {
    let opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    calibrate_simulated(cfg, &opts).unwrap()
}

pub fn check(cfg: &SimConfig) -> ModelCheck {
    calibrate(cfg)
        .model_check
        .expect("the filter makes a model check")
}

/// One SPEC §3 effect at the low end of its realistic size × `k`, with the
/// scheme that can show it.
pub struct EffectCase {
    pub name: &'static str,
    pub size: String,
    pub effects: Effects,
    pub scheme: Scheme,
}

/// Every SPEC §3 effect at `k` times the low end of its realistic size:
/// lever arms 2 cm (own axes), delay 0.5 ms, drift 0.005 deg/h/h and
/// 5 µg/h, off-diagonal g-sensitivity 0.005 deg/h/g, asymmetry 20 ppm
/// (on a scheme that turns both ways).
pub fn low_end_effects(k: f64, dwell_s: f64) -> Vec<EffectCase> {
    let arm = 20.0 * k;
    let g = 0.005 * k;
    vec![
        EffectCase {
            name: "accel_lever_arm",
            size: format!("{:.0} cm", arm / 10.0),
            effects: Effects {
                accel_lever_arm: Some(LeverArms {
                    x: [arm, 0.0, 0.0],
                    y: [0.0, -arm, 0.0],
                    z: [0.0, 0.0, arm],
                }),
                ..Effects::none()
            },
            scheme: nine_plus_nine(dwell_s),
        },
        EffectCase {
            name: "accel_delay",
            size: format!("{} ms", 0.5 * k),
            effects: Effects {
                accel_delay: Some(0.5 * k),
                ..Effects::none()
            },
            scheme: nine_plus_nine(dwell_s),
        },
        EffectCase {
            name: "bias_drift (gyro)",
            size: format!("{g} deg/h/h"),
            effects: Effects {
                bias_drift: Some(BiasDrift {
                    gyro: [g, -g, g],
                    accel: [0.0; 3],
                }),
                ..Effects::none()
            },
            scheme: nine_plus_nine(dwell_s),
        },
        EffectCase {
            name: "bias_drift (accel)",
            size: format!("{} ug/h", 1e3 * g),
            effects: Effects {
                bias_drift: Some(BiasDrift {
                    gyro: [0.0; 3],
                    accel: [1e3 * g, -1e3 * g, 1e3 * g],
                }),
                ..Effects::none()
            },
            scheme: nine_plus_nine(dwell_s),
        },
        EffectCase {
            name: "gyro_g_sensitivity (off-diagonal)",
            size: format!("{g} deg/h/g"),
            effects: Effects {
                gyro_g_sensitivity: Some([0.0, g, -g, g, 0.0, g, -g, -g, 0.0]),
                ..Effects::none()
            },
            scheme: nine_plus_nine(dwell_s),
        },
        EffectCase {
            name: "gyro_scale_asymmetry",
            size: format!("{} ppm", 20.0 * k),
            effects: Effects {
                gyro_scale_asymmetry: Some([20.0 * k, -20.0 * k, 20.0 * k]),
                ..Effects::none()
            },
            scheme: both_ways(dwell_s),
        },
    ]
}
