//! The discrepancy workflow across the realistic range of every SPEC §3
//! effect: each effect at the low and the high end of its range, several
//! seeds each, on the test runs of `tests/suite/diagnose_effects.rs` (the 9+9
//! scheme with 600 s dwells at 20 Hz, the both-ways scheme for the scale
//! asymmetry; paper truth, navigation-grade noise). Per case: how often
//! the acceptance criteria all hold, how often the right effect is named
//! first, and the gap figures; and how many clean runs name nothing. Run:
//! `cargo bench --bench diagnose_sweep` (`-- --seeds N`, default 5, clean
//! runs twice that; `-- --arw A` sets the gyro angle random walk in
//! deg/√h, default the tests' 0.0003; `-- --dwell S`, default 600;
//! `-- --manual` turns every scheme by hand (SPEC §4 flips, the hand
//! turns drawn from the seed) and records at 100 Hz).

mod common;
#[path = "../tests/suite/diagnosis_support/mod.rs"]
mod diagnosis_support;

use diagnosis_support::{acceptance, both_ways, by_hand, config, nine_plus_nine, run_quiet};
use sinscal_core::model::effects::{BiasDrift, LeverArms};
use sinscal_core::model::Effects;
use sinscal_core::sim::{Scheme, SimConfig};

/// An effect's name, its run at a size, and the two ends of its range.
type Case = (&'static str, fn(f64) -> Effects, [(f64, &'static str); 2]);

fn cases() -> [Case; 5] {
    [
        (
            "accel_delay",
            |ms| Effects {
                accel_delay: Some(ms),
                ..Effects::none()
            },
            [(0.5, "0.5 ms"), (5.0, "5 ms")],
        ),
        (
            "accel_lever_arm",
            |mm| Effects {
                accel_lever_arm: Some(LeverArms {
                    x: [mm, 0.0, 0.0],
                    y: [0.0, -mm, 0.0],
                    z: [0.0, 0.0, mm],
                }),
                ..Effects::none()
            },
            [(20.0, "2 cm"), (100.0, "10 cm")],
        ),
        (
            // Gyro drift in deg/h per hour, the accelerometers' 1000× in µg/h.
            "bias_drift",
            |g| Effects {
                bias_drift: Some(BiasDrift {
                    gyro: [g, -g, g],
                    accel: [1e3 * g, -1e3 * g, 1e3 * g],
                }),
                ..Effects::none()
            },
            [
                (0.005, "0.005 deg/h/h, 5 µg/h"),
                (0.02, "0.02 deg/h/h, 20 µg/h"),
            ],
        ),
        (
            // Every coefficient of G at the size, signs mixed.
            "gyro_g_sensitivity",
            |k| Effects {
                gyro_g_sensitivity: Some([k, -k, k, k, k, -k, -k, k, k]),
                ..Effects::none()
            },
            [(0.005, "0.005 deg/h/g"), (0.02, "0.02 deg/h/g")],
        ),
        (
            "gyro_scale_asymmetry",
            |ppm| Effects {
                gyro_scale_asymmetry: Some([ppm, -ppm, ppm]),
                ..Effects::none()
            },
            [(20.0, "20 ppm"), (100.0, "100 ppm")],
        ),
    ]
}

fn main() {
    let args = common::BenchArgs::from_env();
    let flag = |name: &str| args.number(name);
    let seeds = flag("--seeds").map_or(5, |n| n as u64);
    let arw = flag("--arw");
    let dwell_s = flag("--dwell").unwrap_or(600.0);
    let manual = args.switch("--manual");
    let run_config = |nominal: Scheme, effects: Effects, seed: u64| -> SimConfig {
        let mut cfg = if manual {
            by_hand(&nominal, effects, seed)
        } else {
            config(nominal, effects, seed)
        };
        if let Some(arw) = arw {
            cfg.noise.gyro_arw_deg_rt_h = arw;
        }
        cfg
    };
    let clean_seeds = 2 * seeds;
    let named_nothing = (1..=clean_seeds)
        .filter(|&seed| {
            let rep = run_quiet(&run_config(nine_plus_nine(dwell_s), Effects::none(), seed));
            if !rep.named.is_empty() {
                eprintln!("clean seed {seed}: {}", rep.verdict);
            }
            rep.named.is_empty()
        })
        .count();
    println!("clean runs naming nothing: {named_nothing}/{clean_seeds}\n");
    println!(
        "| effect | size | all criteria | named first | raw shrink (min) | excess shrink (min) | after / floor (max) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (effect, size, effects) in cases()
        .into_iter()
        .flat_map(|(e, build, ends)| ends.map(|(v, label)| (e, label, build(v))))
    {
        let (mut all, mut first) = (0, 0);
        let (mut raw_min, mut excess_min, mut after_max) = (f64::INFINITY, f64::INFINITY, 0.0_f64);
        for seed in 1..=seeds {
            let scheme = if effect == "gyro_scale_asymmetry" {
                both_ways(dwell_s)
            } else {
                nine_plus_nine(dwell_s)
            };
            let cfg = run_config(scheme, effects, seed);
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
