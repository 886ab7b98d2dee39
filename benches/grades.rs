//! Units of every grade over many seeds: tactical and consumer (MEMS)
//! units turned by hand with 5–30 s dwells from any heading, random truths
//! up to their datasheets' largest errors and SPEC §2a noise at their
//! grade's sizes (`sim::grade_runs`). Prints per grade and family the RMS
//! of err/σ (honest σ ⇔ ≈ 1; a bias scored against its run mean), the
//! largest |err/σ|, the model check's verdicts, the grade each run was
//! given and every failed calibration.
//!
//! Run: `cargo bench --bench grades [-- N] [--grade tactical|consumer]
//! [--per-seed] [--nominal-heading] [--white] [--no-pulses] [--known-noise]
//! [--only K]` (seeds 1…N, default 20, both grades). `--nominal-heading` starts every run at SPEC §4's nominal
//! heading (x east, ±3°) instead of anywhere; `--white` keeps only the
//! white noise (ARW, VRW) of each seed, `--no-pulses` all but its pulses;
//! `--known-noise` gives the filter the simulated noise model.
//!
//! `--g-sensitivity G` gives each unit a gyro g-sensitivity (SPEC §3), its
//! nine terms drawn uniform in ±G deg/h/g (stream 9 of the seed; a MEMS
//! gyro's are tenths of a deg/s per g: imu_tk's Xsens 100–560 deg/h/g);
//! `--carry-g` calibrates with it as states (`base-24+gyro_g_sensitivity`)
//! and scores its six cross terms as an eighth family; `--model M`
//! calibrates with model M (`base+accel_lever_arm+…`) instead.
//!
//! `--cross-check` runs the least-squares cross-check too and counts the
//! runs where it differs from the filter by more than 3σ.
//!
//! `--diagnose` runs the discrepancy workflow on each seed's run instead
//! and counts its verdicts: on runs without effects every one it names
//! is a false alarm (with `--g-sensitivity`, the effect it should name).

use rand::{Rng, SeedableRng};
use std::sync::atomic::AtomicBool;

use sinscal_core::calib::sources::{calibrate_in_memory, SliceSource};
use sinscal_core::calib::{
    CalibrationResult, Effect, ErrorModel, EstimateOptions, NoiseDensity, RunInfo,
};
use sinscal_core::diagnose::{diagnose, DiagnoseOptions};
use sinscal_core::model::{Grade, Group, PARAMETERS};
use sinscal_core::sim::grade_runs::{hand_run, StartHeading};
use sinscal_core::sim::{simulate, BiasMean, Noise, SimConfig};
use sinscal_core::Record;

/// The number of parameter families (`Group::ALL`), and the
/// g-sensitivity's row after them.
const FAMILIES: usize = 7;
const G_ROW: usize = FAMILIES;

/// The bench's command line, read once (see the file's doc).
struct Flags {
    seeds: u64,
    grades: Vec<Grade>,
    per_seed: bool,
    nominal_heading: bool,
    /// White noise only (the ARW and VRW): no wander, no pulses.
    white: bool,
    /// No pulses: the outputs as exact increments.
    no_pulses: bool,
    /// The filter is given the simulated noise model instead of
    /// measuring and fitting it (what the estimator could do at best).
    known_noise: bool,
    /// Only this seed.
    only: Option<u64>,
    /// Bound of the drawn g-sensitivity terms, deg/h/g.
    g_sensitivity: Option<f64>,
    /// Calibrate with the g-sensitivity as states.
    carry_g: bool,
    /// Diagnose each run and count the verdicts.
    diagnose: bool,
    /// Calibrate with this model (`base+…`) instead.
    model: Option<ErrorModel>,
    /// Run the least-squares cross-check and count the runs it flags.
    cross_check: bool,
}

impl Flags {
    fn from_env() -> Self {
        let args: Vec<String> = std::env::args().collect();
        let has = |flag: &str| args.iter().any(|a| a == flag);
        // The argument after `flag`.
        let value = |flag: &str| {
            let i = args.iter().position(|a| a == flag)?;
            args.get(i + 1).map(String::as_str)
        };
        let grade = value("--grade").map(|g| match g {
            "tactical" => Grade::Tactical,
            "consumer" => Grade::Consumer,
            other => panic!("--grade {other}: tactical or consumer"),
        });
        Flags {
            seeds: args
                .iter()
                .skip(1)
                .take_while(|a| !matches!(a.as_str(), "--only" | "--g-sensitivity" | "--model"))
                .find_map(|a| a.parse().ok())
                .unwrap_or(20),
            grades: grade.map_or(vec![Grade::Tactical, Grade::Consumer], |g| vec![g]),
            per_seed: has("--per-seed"),
            nominal_heading: has("--nominal-heading"),
            white: has("--white"),
            no_pulses: has("--no-pulses"),
            known_noise: has("--known-noise"),
            only: value("--only").and_then(|v| v.parse().ok()),
            g_sensitivity: value("--g-sensitivity").and_then(|v| v.parse().ok()),
            carry_g: has("--carry-g"),
            diagnose: has("--diagnose"),
            cross_check: has("--cross-check"),
            model: value("--model").map(|m| m.parse().expect("--model base+<effect>…")),
        }
    }
}

/// Seed k's run at `grade`, as the flags change it.
fn sim_config(grade: Grade, seed: u64, flags: &Flags) -> SimConfig {
    let start = if flags.nominal_heading {
        StartHeading::Nominal
    } else {
        StartHeading::Anywhere
    };
    let mut cfg = hand_run(grade, seed, start);
    let noise = &mut cfg.noise;
    if flags.white {
        *noise = Noise {
            gyro_arw_deg_rt_h: noise.gyro_arw_deg_rt_h,
            accel_vrw_ug_rt_hz: noise.accel_vrw_ug_rt_hz,
            ..Noise::default()
        };
    }
    if flags.no_pulses {
        noise.gyro_quantum_arcsec = 0.0;
        noise.accel_quantum_mps = 0.0;
    }
    if let Some(bound) = flags.g_sensitivity {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(9);
        cfg.effects.gyro_g_sensitivity =
            Some(std::array::from_fn(|_| rng.gen_range(-bound..=bound)));
    }
    cfg
}

/// err/σ of each g-sensitivity term the calibration carried.
fn g_sensitivity_z(cfg: &SimConfig, res: &CalibrationResult) -> Vec<f64> {
    let truth = cfg.effects.gyro_g_sensitivity.unwrap_or_default();
    let axes = ["x", "y", "z"];
    // The diagonal terms keep their navigation prior below navigation
    // grade (CONTRACT, "Units of every grade"): held near zero, they are
    // not scored.
    (0..9)
        .filter(|k| k / 3 != k % 3)
        .filter_map(|k| {
            let name = format!("gyro_g_sensitivity_{}{}", axes[k / 3], axes[k % 3]);
            res.effects
                .get(&name)
                .map(|p| (p.value - truth[k]) / p.sigma)
        })
        .collect()
}

/// err/σ of every parameter, a bias against its run mean.
fn z_scores(cfg: &SimConfig, res: &CalibrationResult, mean: Option<&BiasMean>) -> Vec<f64> {
    PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, info)| {
            let truth = cfg.params.canonical(i) + mean.map_or(0.0, |m| m.of_parameter(i));
            let p = &res.parameters[info.name];
            (p.value - truth) / p.sigma
        })
        .collect()
}

/// The sums and extremes over one grade's seeds.
#[derive(Default)]
struct Tally {
    z2: [f64; FAMILIES + 1],
    count: [usize; FAMILIES + 1],
    worst: [f64; FAMILIES + 1],
    calibrated: usize,
    failed: Vec<String>,
    inadequate: usize,
    cross_check_flagged: usize,
    graded: std::collections::BTreeMap<String, usize>,
}

impl Tally {
    fn add(&mut self, z: &[f64], z_g: &[f64]) {
        let rows = PARAMETERS.iter().map(|info| info.group.index());
        let rows = rows.chain(std::iter::repeat(G_ROW));
        for (k, z) in rows.zip(z.iter().chain(z_g)) {
            self.z2[k] += z * z;
            self.count[k] += 1;
            self.worst[k] = self.worst[k].max(z.abs());
        }
    }

    fn print(&self, grade: Grade, flags: &Flags) {
        println!(
            "{grade}: {} of {} seeds calibrated, model check inadequate on {}, graded {:?}",
            self.calibrated, flags.seeds, self.inadequate, self.graded
        );
        for f in &self.failed {
            println!("  failed: {f}");
        }
        if flags.cross_check {
            println!(
                "  the cross-check flagged {} of {}",
                self.cross_check_flagged, self.calibrated
            );
        }
        let names = Group::ALL.iter().map(|g| format!("{g:?}"));
        let names = names.chain(std::iter::once("GSensitivity".to_string()));
        for (k, name) in names.enumerate().filter(|&(k, _)| self.count[k] > 0) {
            println!(
                "  {:<14} RMS err/σ {:5.2}   max |err/σ| {:5.2}",
                name,
                (self.z2[k] / self.count[k] as f64).sqrt(),
                self.worst[k]
            );
        }
    }
}

fn run_grade(grade: Grade, flags: &Flags) -> Tally {
    let mut tally = Tally::default();
    let seeds = match flags.only {
        Some(k) => k..=k,
        None => 1..=flags.seeds,
    };
    for seed in seeds {
        let cfg = sim_config(grade, seed, flags);
        let opts = EstimateOptions {
            cross_check: flags.cross_check,
            noise: flags.known_noise.then(|| NoiseDensity::from(&cfg.noise)),
            model: match &flags.model {
                Some(m) => m.clone(),
                None if flags.carry_g => ErrorModel::with(&[Effect::GyroGSensitivity]),
                None => ErrorModel::base(),
            },
            ..EstimateOptions::default()
        };
        let mut sim = simulate(&cfg).expect("valid");
        for _ in sim.by_ref() {}
        let mean = sim.bias_mean_over_run();
        let res = match calibrate_in_memory(&cfg, &opts) {
            Ok(r) => r,
            Err(e) => {
                tally.failed.push(format!("seed {seed}: {e}"));
                continue;
            }
        };
        tally.calibrated += 1;
        let check = res.model_check.as_ref().expect("a model check");
        tally.inadequate += usize::from(!check.adequate);
        if let Some(cc) = &res.cross_check {
            let flagged: Vec<&str> = cc
                .entries
                .iter()
                .filter(|e| e.flagged)
                .map(|e| e.name.as_str())
                .collect();
            tally.cross_check_flagged += usize::from(!flagged.is_empty());
            if flags.per_seed && !flagged.is_empty() {
                println!(
                    "{grade} seed {seed:>3}: the cross-check differs on {}",
                    flagged.join(", ")
                );
            }
        }
        let given = res.grade.map_or("none".into(), |g| g.to_string());
        *tally.graded.entry(given.clone()).or_default() += 1;
        let z = z_scores(&cfg, &res, mean.as_ref());
        let z_g = g_sensitivity_z(&cfg, &res);
        if flags.per_seed {
            let mut line = format!(
                "{grade} seed {seed:>3}: heading {:.0}°, graded {given}, check {} χ² {:.0}/{:.0} max|z| {:.1};",
                cfg.initial_attitude_error_deg[2],
                if check.adequate { "ok " } else { "BAD" },
                check.statistic,
                check.threshold,
                check.largest_z
            );
            if let Some(n) = &res.noise_model {
                line.push_str(&format!(
                    " noise {:?} B {:.1}/{:.1} deg/h {:.0}/{:.0} µg;",
                    n.source,
                    n.model.gyro_bias_instability_deg_h[0],
                    cfg.noise.gyro_bias_instability_deg_h,
                    n.model.accel_bias_instability_ug[0],
                    cfg.noise.accel_bias_instability_ug,
                ));
            }
            for (info, z) in PARAMETERS.iter().zip(&z).filter(|(_, z)| z.abs() > 3.0) {
                line.push_str(&format!(" {} {z:.1}", info.name));
            }
            for (k, z) in z_g.iter().enumerate().filter(|(_, z)| z.abs() > 3.0) {
                line.push_str(&format!(" g-sensitivity term {k} {z:.1}"));
            }
            println!("{line}");
        }
        tally.add(&z, &z_g);
    }
    tally
}

/// The discrepancy workflow on each seed's run: its verdicts, counted.
fn diagnose_grade(grade: Grade, flags: &Flags) {
    let seeds = match flags.only {
        Some(k) => k..=k,
        None => 1..=flags.seeds,
    };
    let mut verdicts = std::collections::BTreeMap::<String, usize>::new();
    for seed in seeds {
        let cfg = sim_config(grade, seed, flags);
        let records: Vec<Record> = simulate(&cfg).expect("valid").collect();
        let run = RunInfo {
            site: cfg.site,
            sample_rate_hz: cfg.sample_rate_hz,
        };
        let cancel = AtomicBool::new(false);
        let mut stage = String::new();
        let mut opts = DiagnoseOptions::default();
        opts.estimate.noise = flags.known_noise.then(|| NoiseDensity::from(&cfg.noise));
        let verdict = match diagnose(
            &SliceSource(&records),
            &run,
            &opts,
            &mut |p| stage = p.stage,
            &cancel,
        ) {
            Ok(rep) => {
                if flags.per_seed {
                    println!(
                        "{grade} seed {seed:>3}: {} (gap z {:.1} → {:.1})",
                        rep.verdict, rep.z_before, rep.z_after
                    );
                }
                rep.verdict.to_string()
            }
            Err(e) => {
                if flags.per_seed {
                    println!("{grade} seed {seed:>3}: failed at \"{stage}\": {e}");
                }
                format!("failed: {e}")
            }
        };
        *verdicts.entry(verdict).or_default() += 1;
    }
    let runs: usize = verdicts.values().sum();
    println!("{grade}: diagnosis verdicts over {runs} runs");
    for (verdict, n) in verdicts {
        println!("  {n:>3}  {verdict}");
    }
}

fn main() {
    let flags = Flags::from_env();
    for &grade in &flags.grades {
        if flags.diagnose {
            diagnose_grade(grade, &flags);
        } else {
            run_grade(grade, &flags).print(grade, &flags);
        }
    }
}
