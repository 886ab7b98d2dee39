//! The discrepancy workflow across the realistic range of every SPEC §3
//! effect: each effect at the low and the high end of its range, several
//! seeds each, on the test runs of `tests/diagnose_effects.rs` (the 9+9
//! scheme with 600 s dwells at 20 Hz, the both-ways scheme for the scale
//! asymmetry; paper truth, navigation-grade noise). Per case: how often
//! the acceptance criteria all hold, how often the right effect is named
//! first, and the gap figures. Run: `cargo bench --bench diagnose_sweep`
//! (`-- --seeds N`, default 5).

#[path = "../tests/diagnosis_support/mod.rs"]
mod diagnosis_support;

use diagnosis_support::{acceptance, both_ways, config, nine_plus_nine, run_quiet};
use sinscal::model::effects::{BiasDrift, LeverArms};
use sinscal::model::Effects;

fn cases() -> Vec<(&'static str, &'static str, Effects)> {
    let none = Effects::none;
    let lever = |mm: f64| LeverArms {
        x: [mm, 0.0, 0.0],
        y: [0.0, -mm, 0.0],
        z: [0.0, 0.0, mm],
    };
    let drift = |g: f64, a: f64| BiasDrift {
        gyro: [g, -g, g],
        accel: [a, -a, a],
    };
    // Every coefficient of G at the size, signs mixed.
    let g_sens = |k: f64| [k, -k, k, k, k, -k, -k, k, k];
    vec![
        (
            "accel_delay",
            "0.5 ms",
            Effects {
                accel_delay: Some(0.5),
                ..none()
            },
        ),
        (
            "accel_delay",
            "5 ms",
            Effects {
                accel_delay: Some(5.0),
                ..none()
            },
        ),
        (
            "accel_lever_arm",
            "2 cm",
            Effects {
                accel_lever_arm: Some(lever(20.0)),
                ..none()
            },
        ),
        (
            "accel_lever_arm",
            "10 cm",
            Effects {
                accel_lever_arm: Some(lever(100.0)),
                ..none()
            },
        ),
        (
            "bias_drift",
            "0.005 deg/h/h, 5 ug/h",
            Effects {
                bias_drift: Some(drift(0.005, 5.0)),
                ..none()
            },
        ),
        (
            "bias_drift",
            "0.02 deg/h/h, 20 ug/h",
            Effects {
                bias_drift: Some(drift(0.02, 20.0)),
                ..none()
            },
        ),
        (
            "gyro_g_sensitivity",
            "0.005 deg/h/g",
            Effects {
                gyro_g_sensitivity: Some(g_sens(0.005)),
                ..none()
            },
        ),
        (
            "gyro_g_sensitivity",
            "0.02 deg/h/g",
            Effects {
                gyro_g_sensitivity: Some(g_sens(0.02)),
                ..none()
            },
        ),
        (
            "gyro_scale_asymmetry",
            "20 ppm",
            Effects {
                gyro_scale_asymmetry: Some([20.0, -20.0, 20.0]),
                ..none()
            },
        ),
        (
            "gyro_scale_asymmetry",
            "100 ppm",
            Effects {
                gyro_scale_asymmetry: Some([100.0, -100.0, 100.0]),
                ..none()
            },
        ),
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args
        .iter()
        .position(|a| a == "--seeds")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    println!(
        "| effect | size | all criteria | named first | raw shrink (min) | excess shrink (min) | after / floor (max) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (effect, size, effects) in cases() {
        let (mut all, mut first) = (0, 0);
        let (mut raw_min, mut excess_min, mut after_max) = (f64::INFINITY, f64::INFINITY, 0.0_f64);
        for seed in 1..=seeds {
            let scheme = if effect == "gyro_scale_asymmetry" {
                both_ways(600.0)
            } else {
                nine_plus_nine(600.0)
            };
            let cfg = config(scheme, effects, seed);
            let rep = run_quiet(&cfg);
            let check = acceptance(&rep, &cfg, &[effect]);
            if check.failed.is_empty() {
                all += 1;
            } else {
                eprintln!("{effect} {size} seed {seed}: {:?}", check.failed);
            }
            if rep.named.first().map(String::as_str) == Some(effect) {
                first += 1;
            }
            raw_min = raw_min.min(1.0 - rep.gap_rms_after / rep.gap_rms_before);
            excess_min = excess_min.min(1.0 - rep.gap_excess_after / rep.gap_excess_before);
            after_max = after_max.max(rep.gap_rms_after / rep.noise_floor_rms);
        }
        println!(
            "| {effect} | {size} | {all}/{seeds} | {first}/{seeds} | {:.1} % | {:.1} % | {:.2} |",
            100.0 * raw_min,
            100.0 * excess_min,
            after_max
        );
    }
}
