//! The model check over many seeds: how often it flags clean runs (the
//! false-alarm rate) and runs carrying each SPEC §3 effect at the low end
//! of its realistic size and at twice it.
//!
//! `cargo bench --bench model_check` (reference scheme, 600 s dwells,
//! 20 Hz, seeds 1–10 for effects, 1–20 for clean runs);
//! `-- --seeds N --clean N --rate HZ --dwell S --tactical`;
//! `--real` gives every run a real unit's noise (SPEC §2a, drawn per seed:
//! `real_navigation_grade`), under the noise model the calibration
//! measures and fits; `--first K` starts the clean seeds at K (to split
//! a long count between processes); `--each` prints every clean seed's
//! statistics as it ends (a long count killed early keeps what it did); `--size K` runs the effects at K
//! times their low end only;
//! `-- --clean 1000 --effects 0` estimates the false-alarm rate alone;
//! `--by-hand` turns every scheme by hand (SPEC §4 flips drawn from the
//! seed), e.g. `-- --by-hand --dwell 300 --rate 50 --effects 0` for the
//! clean hand-turned runs of `tests/suite/model_check.rs` over more seeds.

mod common;
#[path = "../tests/suite/diagnosis_support/mod.rs"]
mod diagnosis_support;
#[path = "../tests/suite/model_check_support/mod.rs"]
mod support;

use std::time::Instant;

use sinscal_core::model::Effects;
use support::*;

fn main() {
    let args = common::BenchArgs::from_env();
    let flag = |name: &str| args.number(name);
    let seeds = flag("--seeds").map_or(10, |n| n as u64);
    let clean = flag("--clean").map_or(20, |n| n as u64);
    let with_effects = flag("--effects") != Some(0.0);
    let rate = flag("--rate").unwrap_or(20.0);
    let dwell = flag("--dwell").unwrap_or(600.0);
    let by_hand = args.switch("--by-hand");
    // The scheme as run: `nominal` turned by hand with `--by-hand`.
    let as_run = |nominal: &sinscal_core::sim::Scheme, seed: u64| {
        if by_hand {
            sinscal_core::sim::Scheme::by_hand(
                nominal,
                seed,
                &sinscal_core::sim::HandTurns::default(),
            )
            .unwrap()
        } else {
            nominal.clone()
        }
    };
    let real = args.switch("--real");
    let first = flag("--first").map_or(1, |n| n as u64);
    let noise_of = |seed: u64| {
        if real {
            real_navigation_grade(seed)
        } else if args.switch("--tactical") {
            tactical_grade()
        } else {
            navigation_grade()
        }
    };
    let noise = noise_of(first);
    println!(
        "model check: ten-position-9+9 (both ways for asymmetry){}, {dwell} s dwells, {rate} Hz, \
         ARW {} deg/√h, VRW {} µg/√Hz{}",
        if by_hand { ", turned by hand" } else { "" },
        noise.gyro_arw_deg_rt_h,
        noise.accel_vrw_ug_rt_hz,
        if real {
            " + SPEC §2a per seed (pulses, wander, vibration; see real_navigation_grade)"
        } else {
            ""
        }
    );
    let t0 = Instant::now();
    // Clean runs: the statistic's spread against its χ² law.
    let mut flagged = 0;
    let (mut sum_ratio, mut sum_ratio2, mut worst_z) = (0.0, 0.0, 0.0f64);
    let mut worst_ratio = 0.0f64;
    for seed in first..first + clean {
        let noise = noise_of(seed);
        let r = calibrate(&config(
            as_run(&nine_plus_nine(dwell), seed),
            Effects::none(),
            noise.clone(),
            rate,
            seed,
        ));
        let c = r.model_check.expect("the filter makes a model check");
        if !c.adequate {
            flagged += 1;
            println!("  clean seed {seed} flagged: {}", c.summary);
            if real {
                println!(
                    "    truth B {:.4} deg/h {:.2} µg, K {:.5} deg/h/√h {:.2} µg/√h; fitted {:?}",
                    noise.gyro_bias_instability_deg_h,
                    noise.accel_bias_instability_ug,
                    noise.gyro_rrw_deg_h_rt_h,
                    noise.accel_rw_ug_rt_h,
                    r.noise_model.map(|m| m.model)
                );
            }
        }
        if args.switch("--each") {
            println!(
                "  clean seed {seed}: χ² {:.0}/{:.0}, largest |z| {:.2}/{:.2}",
                c.statistic, c.threshold, c.largest_z, c.largest_z_threshold
            );
        }
        // (χ² − dof)/√(2 dof) is N(0, 1) under the model.
        let r = (c.statistic - c.dof as f64) / (2.0 * c.dof as f64).sqrt();
        sum_ratio += r;
        sum_ratio2 += r * r;
        worst_ratio = worst_ratio.max(c.statistic / c.threshold);
        worst_z = worst_z.max(c.largest_z / c.largest_z_threshold);
    }
    let n = clean.max(1) as f64;
    println!(
        "clean: {flagged} of {clean} flagged; (χ²−dof)/√(2 dof) mean {:.2} rms {:.2}; \
         largest χ²/threshold {:.2}, largest |z|/threshold {:.2} ({:.0} s)",
        sum_ratio / n,
        (sum_ratio2 / n).sqrt(),
        worst_ratio,
        worst_z,
        t0.elapsed().as_secs_f64()
    );
    if !with_effects {
        return;
    }
    println!("| effect | size | flagged | min χ²/threshold | min largest |z| |");
    println!("|---|---|---|---|---|");
    let sizes = match flag("--size") {
        Some(k) => vec![k],
        None => vec![1.0, 2.0],
    };
    for k in sizes {
        for case in low_end_effects(k, dwell) {
            let mut hits = 0;
            let (mut min_ratio, mut min_z) = (f64::INFINITY, f64::INFINITY);
            let mut example = String::new();
            for seed in 1..=seeds {
                let c = check(&config(
                    as_run(&case.scheme, seed),
                    case.effects,
                    noise_of(seed),
                    rate,
                    seed,
                ));
                if !c.adequate {
                    hits += 1;
                }
                if example.is_empty() {
                    example = c.summary.clone();
                }
                min_ratio = min_ratio.min(c.statistic / c.threshold);
                min_z = min_z.min(c.largest_z);
            }
            println!(
                "| {} | {} | {hits}/{seeds} | {min_ratio:.2} | {min_z:.1} |",
                case.name, case.size
            );
            eprintln!("    e.g. {example}");
        }
    }
    println!("({:.0} s)", t0.elapsed().as_secs_f64());
}
