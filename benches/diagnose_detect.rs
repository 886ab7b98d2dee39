//! Whether the detection thresholds a diagnosis reports are true: per
//! seed, a clean run states the smallest size of each quantity it would
//! have named ("a delay ≥ … ms"); the same run (same motion, same noise)
//! carrying that quantity along its most visible direction at 1.5× the
//! threshold should name it, at 0.5× should not. Counts over the seeds
//! per quantity. Runs: the 9+9 scheme, paper truth, navigation-grade
//! noise; table turns at 20 Hz, or with `--manual` turned by hand (SPEC §4
//! flips drawn from the seed) at 100 Hz. Run: `cargo bench --bench
//! diagnose_detect` (`-- --seeds N`, default 10, from `-- --first F`,
//! default 1; `-- --dwell S`, default 300; `-- --manual`).
//!
//! `-- --real` gives every run a real unit's noise (SPEC §2a, drawn per
//! seed: pulses, wandering biases, floor vibration), which the diagnosis
//! measures and fits as the calibration does; each quantity is then run
//! once, at 2× its threshold (`--factor K` for another multiple), and the
//! table counts the runs that name it first and those whose model check
//! flags it; the clean runs that name something are counted too.
//! `--clean-only` diagnoses the clean runs alone.

mod common;
#[path = "../tests/suite/diagnosis_support/mod.rs"]
mod diagnosis_support;
#[path = "../tests/suite/model_check_support/mod.rs"]
mod model_check_support;

use std::collections::BTreeMap;

use diagnosis_support::{by_hand, config, nine_plus_nine, run_quiet};
use sinscal_core::diagnose::candidates::{add_effect, library};
use sinscal_core::diagnose::detect::DetectionThreshold;
use sinscal_core::model::Effects;

/// The wander a calibration fitted: B and K of each triad, per axis.
fn wander_of(rep: &sinscal_core::diagnose::DiagnoseReport) -> String {
    rep.base_calibration
        .noise_model
        .as_ref()
        .map_or("no model".into(), |n| {
            let m = &n.model;
            format!(
                "ARW {:.5?} VRW {:.2?}, gyro B {:.4?} K {:.5?}, accel B {:.2?} K {:.2?}",
                m.gyro_arw_deg_rt_h,
                m.accel_vrw_ug_rt_hz,
                m.gyro_bias_instability_deg_h,
                m.gyro_rrw_deg_h_rt_h,
                m.accel_bias_instability_ug,
                m.accel_rw_ug_rt_h
            )
        })
}

/// The effects of `t`'s quantity at `factor` times its threshold, along
/// its most visible direction.
fn at_threshold(t: &DetectionThreshold, factor: f64) -> Effects {
    let cand = library()
        .into_iter()
        .find(|c| c.name == t.candidate)
        .expect("a library candidate");
    let mut values = vec![0.0; cand.params.len()];
    for (name, d) in t.params.iter().zip(&t.direction) {
        let i = cand
            .params
            .iter()
            .position(|p| &p.name == name)
            .expect("a parameter of the candidate");
        values[i] = factor * t.size * d;
    }
    let mut effects = Effects::none();
    add_effect(&mut effects, cand.name, &values);
    effects
}

#[derive(Default)]
struct Tally {
    seeds: usize,
    named_above: usize,
    named_below: usize,
    named_at_factor: usize,
    flagged_at_factor: usize,
}

fn main() {
    let args = common::BenchArgs::from_env();
    let flag = |name: &str| args.number(name);
    let seeds = flag("--seeds").map_or(10, |n| n as u64);
    let first = flag("--first").map_or(1, |n| n as u64);
    let dwell_s = flag("--dwell").unwrap_or(300.0);
    let manual = args.switch("--manual");
    let real = args.switch("--real");
    let factor = flag("--factor").unwrap_or(2.0);
    let mut tally: BTreeMap<String, Tally> = BTreeMap::new();
    let mut clean_named = 0;
    for seed in first..first + seeds {
        let run_with = |effects: Effects| {
            let nominal = nine_plus_nine(dwell_s);
            let mut cfg = if manual {
                by_hand(&nominal, effects, seed)
            } else {
                config(nominal, effects, seed)
            };
            if real {
                cfg.noise = model_check_support::real_navigation_grade(seed);
            }
            let t0 = std::time::Instant::now();
            let rep = run_quiet(&cfg);
            (rep, t0.elapsed().as_secs_f64())
        };
        let (clean, seconds) = run_with(Effects::none());
        let check = clean.base_calibration.model_check.as_ref();
        println!(
            "seed {seed}: clean run {} (gap z {:.2}, model check {}; {seconds:.1} s)",
            clean.verdict,
            clean.z_before,
            check.map_or("none".into(), |c| c.summary.clone())
        );
        if args.switch("--show-model") {
            println!("  fitted {}", wander_of(&clean));
        }
        if !clean.named.is_empty() {
            clean_named += 1;
        }
        if args.switch("--clean-only") {
            continue;
        }
        for t in &clean.detectable {
            let key = format!("{} ({})", t.quantity, t.unit);
            let entry = tally.entry(key.clone()).or_default();
            entry.seeds += 1;
            if real || args.switch("--at-factor") {
                let (at, seconds) = run_with(at_threshold(t, factor));
                let check = at.base_calibration.model_check.as_ref();
                let flagged = check.is_some_and(|c| !c.adequate);
                entry.flagged_at_factor += usize::from(flagged);
                let named = at.named.first() == Some(&t.effect);
                entry.named_at_factor += usize::from(named);
                println!(
                    "seed {seed} {key} at {factor}x {:.4}: {}; check {} ({seconds:.1} s)",
                    t.size,
                    at.verdict,
                    check.map_or("none".into(), |c| format!(
                        "{} (χ² {:.0}/{:.0}, |z| {:.1}/{:.1})",
                        if c.adequate { "adequate" } else { "FLAGS" },
                        c.statistic,
                        c.threshold,
                        c.largest_z,
                        c.largest_z_threshold
                    ))
                );
                if args.switch("--show-model") {
                    println!("  fitted {}", wander_of(&at));
                    let mut c = at.steps[0].candidates.clone();
                    c.sort_by(|a, b| b.delta_bic.total_cmp(&a.delta_bic));
                    for s in c.iter().take(3) {
                        println!(
                            "  {}: Δχ² {:.1}, dispersion {:.2}, ΔBIC {:.1}",
                            s.candidate, s.delta_chi2, s.dispersion, s.delta_bic
                        );
                    }
                }
                continue;
            }
            let above = run_with(at_threshold(t, 1.5)).0;
            let below = run_with(at_threshold(t, 0.5)).0;
            if above.named.first() == Some(&t.effect) {
                entry.named_above += 1;
            } else {
                eprintln!("seed {seed} {key} at 1.5x {:.4}: {}", t.size, above.verdict);
            }
            if below.named.contains(&t.effect) {
                entry.named_below += 1;
                eprintln!("seed {seed} {key} at 0.5x {:.4}: {}", t.size, below.verdict);
            }
        }
    }
    println!("clean runs naming an effect: {clean_named}/{seeds}");
    if real || args.switch("--at-factor") {
        println!(
            "| quantity | named first at {factor}× threshold | model check flags at {factor}× |"
        );
        println!("|---|---|---|");
        for (key, t) in &tally {
            println!(
                "| {key} | {}/{} | {}/{} |",
                t.named_at_factor, t.seeds, t.flagged_at_factor, t.seeds
            );
        }
        return;
    }
    println!("| quantity | named first at 1.5× threshold | named at 0.5× threshold |");
    println!("|---|---|---|");
    for (key, t) in &tally {
        println!(
            "| {key} | {}/{} | {}/{} |",
            t.named_above, t.seeds, t.named_below, t.seeds
        );
    }
}
