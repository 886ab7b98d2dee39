//! The model check on every calibration (SPEC §5 `model_check`): clean
//! runs pass at navigation and tactical grade and on real units (SPEC §2a
//! noise, under the model fitted to each run), and every SPEC §3 effect at
//! the low end of its realistic size is flagged in most runs, at twice
//! that size in every run.
//!
//! Runs: `tests/suite/model_check_support` (the paper's 9+9 scheme, both ways
//! for the asymmetry; 600 s dwells at 20 Hz: the noise densities, not the
//! rate, set what a run can see). Each statistic here is over a few seeds
//! (five clean runs a grade, three effect runs a size); the same statistics
//! over more seeds are `cargo bench --bench model_check` (twenty clean
//! runs, ten a size of every effect; `-- --tactical`, `-- --by-hand`), and
//! the false-alarm rate over many more clean runs `cargo bench --bench
//! model_check -- --clean 1000 --effects 0`.

use crate::model_check_support;

use std::thread;

use model_check_support::*;
use sinscal_core::calib::sources::calibrate_in_memory;
use sinscal_core::calib::{EstimateOptions, ModelCheck};
use sinscal_core::model::Effects;
use sinscal_core::sim::SimConfig;

/// The model check of `cfg`'s run, calibrated as `model_check_support`'s
/// `check` does (without the cross-check), from its records simulated
/// once and held in memory rather than afresh for every pass (the same
/// records).
fn check(cfg: &SimConfig) -> ModelCheck {
    let opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    calibrate_in_memory(cfg, &opts)
        .unwrap()
        .model_check
        .expect("the filter makes a model check")
}

/// Checks of `cfgs` on both cores.
fn checks(cfgs: Vec<sinscal_core::sim::SimConfig>) -> Vec<ModelCheck> {
    let half = cfgs.len().div_ceil(2);
    let (a, b) = cfgs.split_at(half);
    thread::scope(|s| {
        let other = s.spawn(|| b.iter().map(check).collect::<Vec<_>>());
        let mut out: Vec<ModelCheck> = a.iter().map(check).collect();
        out.extend(other.join().unwrap());
        out
    })
}

/// Clean runs of `seeds`, each with its seed's unit (`noise`) and scheme,
/// at `rate` Hz: every one adequate, with nothing found.
fn clean_runs_pass(
    noise: impl Fn(u64) -> sinscal_core::sim::Noise,
    seeds: std::ops::RangeInclusive<u64>,
    scheme: impl Fn(u64) -> sinscal_core::sim::Scheme,
    rate: f64,
) {
    let cfgs = seeds
        .clone()
        .map(|seed| config(scheme(seed), Effects::none(), noise(seed), rate, seed))
        .collect();
    for (seed, c) in seeds.zip(checks(cfgs)) {
        eprintln!(
            "seed {seed}: χ² {:.0}/{} (threshold {:.0}), largest |z| {:.2} (threshold {:.2})",
            c.statistic, c.dof, c.threshold, c.largest_z, c.largest_z_threshold
        );
        assert!(c.adequate, "clean seed {seed}: {}", c.summary);
        assert!(c.summary.starts_with("adequate"));
        assert!(c.findings.is_empty());
    }
}

/// Five clean runs (seeds 1–5); twenty: `cargo bench --bench model_check
/// -- --effects 0`.
#[test]
fn clean_runs_are_adequate_at_navigation_grade() {
    clean_runs_pass(
        |_| navigation_grade(),
        1..=5,
        |_| nine_plus_nine(600.0),
        20.0,
    );
}

/// Five clean runs (seeds 101–105); twenty: `cargo bench --bench
/// model_check -- --tactical --effects 0`.
#[test]
fn clean_runs_are_adequate_at_tactical_grade() {
    clean_runs_pass(
        |_| tactical_grade(),
        101..=105,
        |_| nine_plus_nine(600.0),
        20.0,
    );
}

/// Twenty clean real units (SPEC §2a), each drawn from its seed as
/// `real_navigation_grade` draws it (1″ and 1e-4 m/s pulses, bias
/// instability and random walk across their navigation-grade ranges,
/// floor vibration), each calibrated under the noise model measured and
/// fitted from its own run: none flagged. At reduced size (60 s dwells,
/// 10 Hz: the fit's cost is the run's length, the simulation's its
/// records); the rate over 500 seeds at full size is `cargo bench --bench
/// model_check -- --real --clean 250 --first 1 --effects 0` (and
/// `--first 251`).
#[test]
fn clean_real_units_are_adequate() {
    clean_runs_pass(
        real_navigation_grade,
        1..=20,
        |_| nine_plus_nine(60.0),
        10.0,
    );
}

/// Hand-turned runs (flips of 30–120 °/s, the unit lifted and moved): the
/// reference point moves in every turn and rests in every dwell, which
/// the check must not take for a misfit. 50 Hz, so a fast flip is still
/// a few degrees a record. Five runs a grade (seeds 201–205, 221–225);
/// twenty: `cargo bench --bench model_check -- --by-hand --dwell 300
/// --rate 50 --effects 0` (and `--tactical`).
#[test]
fn clean_hand_turned_runs_are_adequate() {
    clean_runs_pass(
        |_| navigation_grade(),
        201..=205,
        |seed| nine_plus_nine_by_hand(300.0, seed),
        50.0,
    );
    clean_runs_pass(
        |_| tactical_grade(),
        221..=225,
        |seed| nine_plus_nine_by_hand(300.0, seed),
        50.0,
    );
}

/// Seeds of the effect runs; `cargo bench --bench model_check` runs ten
/// (`-- --seeds N` more).
const EFFECT_SEEDS: u64 = 3;

fn flagged(k: f64) -> Vec<(&'static str, usize, String)> {
    let cases = low_end_effects(k, 600.0);
    let mut out = Vec::new();
    for case in cases {
        let cfgs = (1..=EFFECT_SEEDS)
            .map(|seed| {
                config(
                    case.scheme.clone(),
                    case.effects,
                    navigation_grade(),
                    20.0,
                    seed,
                )
            })
            .collect();
        let results = checks(cfgs);
        let hits = results.iter().filter(|c| !c.adequate).count();
        let example = results
            .iter()
            .find(|c| !c.adequate)
            .map_or(String::new(), |c| c.summary.clone());
        eprintln!(
            "{} {}: {hits}/{EFFECT_SEEDS} flagged; e.g. {example}",
            case.name, case.size
        );
        out.push((case.name, hits, example));
    }
    out
}

/// Flagged in each of the three seeds (1–3), the summary pointing to the
/// discrepancy workflow. The low end itself (flagged in 10 of 10 seeds
/// each) is a rate over seeds, measured by the bench (`cargo bench
/// --bench model_check`; docs/FIGURES.md): at three seeds a test of it
/// only repeated this one's runs at half the size.
#[test]
fn every_effect_at_twice_the_low_end_is_flagged_in_every_run() {
    for (name, hits, example) in flagged(2.0) {
        assert_eq!(
            hits, EFFECT_SEEDS as usize,
            "{name}: flagged in {hits} of {EFFECT_SEEDS}"
        );
        assert!(example.contains("sinscal diagnose"), "{example}");
    }
}

/// Where the misfit lies: a lever arm shows as steps across turns, a bias
/// drift as drifts at rest, largest there, that grow over the run.
#[test]
fn findings_say_where_the_misfit_lies() {
    use sinscal_core::calib::model_check::Shape;
    let cases = low_end_effects(2.0, 600.0);
    let lever = cases.iter().find(|c| c.name == "accel_lever_arm").unwrap();
    let c = check(&config(
        lever.scheme.clone(),
        lever.effects,
        navigation_grade(),
        20.0,
        3,
    ));
    assert_eq!(c.findings[0].shape, Shape::TurnStep, "{}", c.summary);
    assert!(c.summary.contains("in motion"), "{}", c.summary);
    let drift = cases
        .iter()
        .find(|c| c.name == "bias_drift (accel)")
        .unwrap();
    let c = check(&config(
        drift.scheme.clone(),
        drift.effects,
        navigation_grade(),
        20.0,
        3,
    ));
    // A drifting bias also acts through the turns (it integrates over them
    // too), but the misfit is largest at rest.
    assert_eq!(c.findings[0].shape, Shape::Drift, "{}", c.summary);
    assert!(
        c.summary.contains("velocity drift at rest"),
        "{}",
        c.summary
    );
    assert!(c.summary.contains("grows with time"), "{}", c.summary);
}
