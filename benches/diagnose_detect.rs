//! Whether the detection thresholds a diagnosis reports are true: per
//! seed, a clean run states the smallest size of each quantity it would
//! have named ("a delay ≥ … ms"); the same run (same motion, same noise)
//! carrying that quantity along its most visible direction at 1.5× the
//! threshold should name it, at 0.5× should not. Counts over the seeds
//! per quantity. Runs: the 9+9 scheme, paper truth, navigation-grade
//! noise; table turns at 20 Hz, or with `--manual` turned by hand (SPEC §4
//! flips drawn from the seed) at 100 Hz. Run: `cargo bench --bench
//! diagnose_detect` (`-- --seeds N`, default 10; `-- --dwell S`, default
//! 300; `-- --manual`).

mod common;
#[path = "../tests/suite/diagnosis_support/mod.rs"]
mod diagnosis_support;

use std::collections::BTreeMap;

use diagnosis_support::{by_hand, config, nine_plus_nine, run_quiet};
use sinscal::diagnose::candidates::{add_effect, library};
use sinscal::diagnose::detect::DetectionThreshold;
use sinscal::model::Effects;

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
}

fn main() {
    let args = common::BenchArgs::from_env();
    let flag = |name: &str| args.number(name);
    let seeds = flag("--seeds").map_or(10, |n| n as u64);
    let dwell_s = flag("--dwell").unwrap_or(300.0);
    let manual = args.switch("--manual");
    let mut tally: BTreeMap<String, Tally> = BTreeMap::new();
    for seed in 1..=seeds {
        let run_with = |effects: Effects| {
            let nominal = nine_plus_nine(dwell_s);
            run_quiet(&if manual {
                by_hand(&nominal, effects, seed)
            } else {
                config(nominal, effects, seed)
            })
        };
        let clean = run_with(Effects::none());
        for t in &clean.detectable {
            let key = format!("{} ({})", t.quantity, t.unit);
            let above = run_with(at_threshold(t, 1.5));
            let below = run_with(at_threshold(t, 0.5));
            let entry = tally.entry(key.clone()).or_default();
            entry.seeds += 1;
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
    println!("| quantity | named first at 1.5× threshold | named at 0.5× threshold |");
    println!("|---|---|---|");
    for (key, t) in &tally {
        println!(
            "| {key} | {}/{} | {}/{} |",
            t.named_above, t.seeds, t.named_below, t.seeds
        );
    }
}
