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

use sinscal_core::calib::ModelCheck;
use sinscal_core::model::Effects;
use sinscal_core::sim::{HandTurns, Noise, Scheme};
use support::*;

/// The bench's command line, read once (see the file's doc).
struct Flags {
    /// Seeds 1…`seeds` per effect case.
    seeds: u64,
    /// Clean seeds `first`…`first + clean - 1`.
    clean: u64,
    first: u64,
    /// False with `--effects 0`.
    with_effects: bool,
    /// Hz.
    rate: f64,
    /// s.
    dwell: f64,
    by_hand: bool,
    real: bool,
    tactical: bool,
    each: bool,
    /// With `--size K`: the effects at K times their low end only.
    size: Option<f64>,
}

impl Flags {
    fn from_env() -> Self {
        let args = common::BenchArgs::from_env();
        let flag = |name: &str| args.number(name);
        Flags {
            seeds: flag("--seeds").map_or(10, |n| n as u64),
            clean: flag("--clean").map_or(20, |n| n as u64),
            first: flag("--first").map_or(1, |n| n as u64),
            with_effects: flag("--effects") != Some(0.0),
            rate: flag("--rate").unwrap_or(20.0),
            dwell: flag("--dwell").unwrap_or(600.0),
            by_hand: args.switch("--by-hand"),
            real: args.switch("--real"),
            tactical: args.switch("--tactical"),
            each: args.switch("--each"),
            size: flag("--size"),
        }
    }

    /// The scheme as run: `nominal` turned by hand with `--by-hand`.
    fn as_run(&self, nominal: &Scheme, seed: u64) -> Scheme {
        if self.by_hand {
            Scheme::by_hand(nominal, seed, &HandTurns::default()).unwrap()
        } else {
            nominal.clone()
        }
    }

    /// Seed k's sensor noise.
    fn noise(&self, seed: u64) -> Noise {
        if self.real {
            real_navigation_grade(seed)
        } else if self.tactical {
            tactical_grade()
        } else {
            navigation_grade()
        }
    }
}

fn print_header(flags: &Flags) {
    let noise = flags.noise(flags.first);
    println!(
        "model check: ten-position-9+9 (both ways for asymmetry){}, {} s dwells, {} Hz, \
         ARW {} deg/√h, VRW {} µg/√Hz{}",
        if flags.by_hand {
            ", turned by hand"
        } else {
            ""
        },
        flags.dwell,
        flags.rate,
        noise.gyro_arw_deg_rt_h,
        noise.accel_vrw_ug_rt_hz,
        if flags.real {
            " + SPEC §2a per seed (pulses, wander, vibration; see real_navigation_grade)"
        } else {
            ""
        }
    );
}

/// The clean runs' model checks: the statistic's spread against its χ²
/// law.
struct CleanTally {
    flagged: usize,
    sum_ratio: f64,
    sum_ratio2: f64,
    worst_ratio: f64,
    worst_z: f64,
}

impl CleanTally {
    fn add(&mut self, c: &ModelCheck) {
        if !c.adequate {
            self.flagged += 1;
        }
        // (χ² − dof)/√(2 dof) is N(0, 1) under the model.
        let r = (c.statistic - c.dof as f64) / (2.0 * c.dof as f64).sqrt();
        self.sum_ratio += r;
        self.sum_ratio2 += r * r;
        self.worst_ratio = self.worst_ratio.max(c.statistic / c.threshold);
        self.worst_z = self.worst_z.max(c.largest_z / c.largest_z_threshold);
    }

    fn print(&self, clean: u64, t0: Instant) {
        let n = clean.max(1) as f64;
        println!(
            "clean: {} of {clean} flagged; (χ²−dof)/√(2 dof) mean {:.2} rms {:.2}; \
             largest χ²/threshold {:.2}, largest |z|/threshold {:.2} ({:.0} s)",
            self.flagged,
            self.sum_ratio / n,
            (self.sum_ratio2 / n).sqrt(),
            self.worst_ratio,
            self.worst_z,
            t0.elapsed().as_secs_f64()
        );
    }
}

/// Calibrates clean seed k and returns its model check, printing it when
/// flagged (with `--real`, the noise's truth and the fitted model too)
/// and with `--each`.
fn clean_check(seed: u64, flags: &Flags) -> ModelCheck {
    let noise = flags.noise(seed);
    let r = calibrate(&config(
        flags.as_run(&nine_plus_nine(flags.dwell), seed),
        Effects::none(),
        noise.clone(),
        flags.rate,
        seed,
    ));
    let c = r.model_check.expect("the filter makes a model check");
    if !c.adequate {
        println!("  clean seed {seed} flagged: {}", c.summary);
        if flags.real {
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
    if flags.each {
        println!(
            "  clean seed {seed}: χ² {:.0}/{:.0}, largest |z| {:.2}/{:.2}",
            c.statistic, c.threshold, c.largest_z, c.largest_z_threshold
        );
    }
    c
}

/// One effect case over seeds 1…N: its table row, and an example check
/// on stderr.
fn effect_row(case: &EffectCase, flags: &Flags) {
    let seeds = flags.seeds;
    let mut hits = 0;
    let (mut min_ratio, mut min_z) = (f64::INFINITY, f64::INFINITY);
    let mut example = String::new();
    for seed in 1..=seeds {
        let c = check(&config(
            flags.as_run(&case.scheme, seed),
            case.effects,
            flags.noise(seed),
            flags.rate,
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

fn main() {
    let flags = Flags::from_env();
    print_header(&flags);
    let t0 = Instant::now();
    let mut clean = CleanTally {
        flagged: 0,
        sum_ratio: 0.0,
        sum_ratio2: 0.0,
        worst_ratio: 0.0,
        worst_z: 0.0,
    };
    for seed in flags.first..flags.first + flags.clean {
        clean.add(&clean_check(seed, &flags));
    }
    clean.print(flags.clean, t0);
    if !flags.with_effects {
        return;
    }
    println!("| effect | size | flagged | min χ²/threshold | min largest |z| |");
    println!("|---|---|---|---|---|");
    let sizes = match flags.size {
        Some(k) => vec![k],
        None => vec![1.0, 2.0],
    };
    for k in sizes {
        for case in low_end_effects(k, flags.dwell) {
            effect_row(&case, &flags);
        }
    }
    println!("({:.0} s)", t0.elapsed().as_secs_f64());
}
