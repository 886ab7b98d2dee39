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

use sinscal_core::calib::sources::calibrate_in_memory;
use sinscal_core::calib::{CalibrationResult, EstimateOptions, NoiseDensity};
use sinscal_core::model::{Grade, Group, PARAMETERS};
use sinscal_core::sim::grade_runs::{hand_run, StartHeading};
use sinscal_core::sim::{simulate, BiasMean, Noise, SimConfig};

/// The number of parameter families (`Group::ALL`).
const FAMILIES: usize = 7;

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
}

impl Flags {
    fn from_env() -> Self {
        let args: Vec<String> = std::env::args().collect();
        let grade = args
            .iter()
            .position(|a| a == "--grade")
            .and_then(|i| args.get(i + 1))
            .map(|g| match g.as_str() {
                "tactical" => Grade::Tactical,
                "consumer" => Grade::Consumer,
                other => panic!("--grade {other}: tactical or consumer"),
            });
        Flags {
            seeds: args
                .iter()
                .skip(1)
                .take_while(|a| *a != "--only")
                .find_map(|a| a.parse().ok())
                .unwrap_or(20),
            grades: grade.map_or(vec![Grade::Tactical, Grade::Consumer], |g| vec![g]),
            per_seed: args.iter().any(|a| a == "--per-seed"),
            nominal_heading: args.iter().any(|a| a == "--nominal-heading"),
            white: args.iter().any(|a| a == "--white"),
            no_pulses: args.iter().any(|a| a == "--no-pulses"),
            known_noise: args.iter().any(|a| a == "--known-noise"),
            only: args
                .iter()
                .position(|a| a == "--only")
                .and_then(|i| args.get(i + 1))
                .and_then(|v| v.parse().ok()),
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
    cfg
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
    z2: [f64; FAMILIES],
    count: [usize; FAMILIES],
    worst: [f64; FAMILIES],
    calibrated: usize,
    failed: Vec<String>,
    inadequate: usize,
    graded: std::collections::BTreeMap<String, usize>,
}

impl Tally {
    fn add(&mut self, z: &[f64]) {
        for (info, z) in PARAMETERS.iter().zip(z) {
            let k = info.group.index();
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
        for (k, g) in Group::ALL.iter().enumerate() {
            println!(
                "  {:<14} RMS err/σ {:5.2}   max |err/σ| {:5.2}",
                format!("{g:?}"),
                (self.z2[k] / self.count[k].max(1) as f64).sqrt(),
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
            cross_check: false,
            noise: flags.known_noise.then(|| NoiseDensity::from(&cfg.noise)),
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
        let given = res.grade.map_or("none".into(), |g| g.to_string());
        *tally.graded.entry(given.clone()).or_default() += 1;
        let z = z_scores(&cfg, &res, mean.as_ref());
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
            println!("{line}");
        }
        tally.add(&z);
    }
    tally
}

fn main() {
    let flags = Flags::from_env();
    for &grade in &flags.grades {
        run_grade(grade, &flags).print(grade, &flags);
    }
}
