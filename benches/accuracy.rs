//! Accuracy over many seeds at full length: the reference scenario (paper
//! truth, `ten-position-9+9`, 600 s dwells, 100 Hz, ARW 0.0003 deg/√h,
//! VRW 5 µg/√Hz), seeds 1…N (default 20). Prints per family the RMS of
//! err/σ (honest σ ⇔ ≈ 1), the mean σ and the largest |err| against the
//! paper's Table 1 bound. Run: `cargo bench --bench accuracy [-- N]`.
//!
//! `--tactical`: the same at tactical-grade noise, seed k at ARW
//! 0.001/0.002/0.003 deg/√h (k mod 3) and VRW 10/20/30/40/50 µg/√Hz
//! (k mod 5), so twenty seeds cover both ranges. `--dwell S` and
//! `--rate HZ` shorten the run; `--known-noise` gives the filter the
//! simulated densities instead of measuring them; `--window S` sets the
//! propagation window; `--random` draws a truth per seed (±2× the
//! paper's), `--turned` starts each seed tilted up to 5° at its own
//! heading, `--latitude DEG` moves the site, `--turn-rate DPS` makes every
//! turn that fast, `--per-seed` prints each seed's Σ(err/σ)² per family.
//! A dwell that is not a whole number of 0.1 s (e.g. 600.03) starts turns
//! between the pre-scan's blocks, as on real runs.
//!
//! `--scheme FILE`: a SPEC §4 scheme JSON (e.g. from `sinscal design`)
//! instead of the reference scheme.
//!
//! `--by-hand`: every turn a SPEC §4 flip (`Scheme::by_hand`, seeded by
//! the run's seed).
//!
//! `--raw`: uncalibrated units at the same size, seeds 1…N (default 9) in
//! turn paper truth × 10 (one sign), × 20 (mixed signs, 5° tilt, heading
//! 40° + 97° per seed) and a random truth × 10 (mixed, up to 20×). Prints
//! the same table plus the worst |err|/bound per family and overall, the
//! dwells found and the passes taken.

use rand::SeedableRng;

use sinscal_core::calib::sources::calibrate_simulated;
use sinscal_core::calib::{CalibrationResult, EstimateOptions, NoiseDensity};
use sinscal_core::model::params::paper_accuracy;
use sinscal_core::model::{Effects, ErrorParameters, Group, PARAMETERS};
use sinscal_core::nav::Site;
use sinscal_core::sim::{Noise, Scheme, SimConfig};

/// The number of parameter families (`Group::ALL`).
const FAMILIES: usize = 7;

/// The truth and start attitude (deg) of seed `seed` in `--raw` mode.
fn raw_unit(seed: u64) -> (String, ErrorParameters, [f64; 3]) {
    let mut p = ErrorParameters::paper();
    let heading = (40.0 + 97.0 * seed as f64) % 360.0;
    match seed % 3 {
        1 => {
            p.si.iter_mut().for_each(|v| *v *= 10.0);
            ("paper × 10".into(), p, [0.1, -0.1, heading])
        }
        2 => {
            let signs = [1.0, -1.0, -1.0, 1.0, -1.0];
            for (i, v) in p.si.iter_mut().enumerate() {
                *v *= 20.0 * signs[i % signs.len()];
            }
            ("paper × 20 mixed".into(), p, [3.0, -4.0, heading])
        }
        _ => {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut p = ErrorParameters::random(&mut rng);
            p.si.iter_mut().for_each(|v| *v *= 10.0);
            ("random × 10".into(), p, [-5.0, 0.0, heading])
        }
    }
}

/// Tactical-grade densities of seed k: both ranges covered every 15 seeds.
fn tactical_noise(seed: u64) -> Noise {
    Noise {
        gyro_arw_deg_rt_h: [0.001, 0.002, 0.003][(seed % 3) as usize],
        accel_vrw_ug_rt_hz: [10.0, 20.0, 30.0, 40.0, 50.0][(seed % 5) as usize],
        ..Noise::default()
    }
}

/// The value after `flag`, parsed.
fn value<T: std::str::FromStr>(args: &[String], flag: &str) -> Option<T> {
    args.iter()
        .position(|a| a == flag)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
}

/// The bench's command line, read once (see the file's doc).
struct Flags {
    /// Seeds 1…`seeds`: the first number that is no flag's value.
    seeds: u64,
    tactical: bool,
    known_noise: bool,
    /// s.
    dwell: f64,
    /// Hz.
    rate: f64,
    /// deg.
    latitude: f64,
    random: bool,
    turned: bool,
    /// deg/s.
    turn_rate: Option<f64>,
    per_seed: bool,
    raw: bool,
    by_hand: bool,
    scheme_file: Option<String>,
    /// s.
    window: Option<f64>,
}

impl Flags {
    fn from_env() -> Self {
        let args: Vec<String> = std::env::args().skip(1).collect();
        let switch = |flag: &str| args.iter().any(|a| a == flag);
        let raw = switch("--raw");
        let with_value = [
            "--dwell",
            "--rate",
            "--window",
            "--latitude",
            "--turn-rate",
            "--scheme",
        ];
        let seeds = args
            .iter()
            .enumerate()
            .filter(|(i, _)| *i == 0 || !with_value.contains(&args[i - 1].as_str()))
            .find_map(|(_, a)| a.parse().ok())
            .unwrap_or(if raw { 9 } else { 20 });
        Flags {
            seeds,
            tactical: switch("--tactical"),
            known_noise: switch("--known-noise"),
            dwell: value(&args, "--dwell").unwrap_or(600.0),
            rate: value(&args, "--rate").unwrap_or(100.0),
            latitude: value(&args, "--latitude").unwrap_or(Site::REFERENCE.latitude_deg),
            random: switch("--random"),
            turned: switch("--turned"),
            turn_rate: value(&args, "--turn-rate"),
            per_seed: switch("--per-seed"),
            raw,
            by_hand: switch("--by-hand"),
            scheme_file: value(&args, "--scheme"),
            window: value(&args, "--window"),
        }
    }
}

/// Seed k's truth and start attitude (deg).
fn truth_and_start(seed: u64, flags: &Flags) -> (ErrorParameters, [f64; 3]) {
    let (_, raw_truth, raw_start) = raw_unit(seed);
    let truth = if flags.raw {
        raw_truth
    } else if flags.random {
        ErrorParameters::random(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed))
    } else {
        ErrorParameters::paper()
    };
    let start = if flags.raw {
        raw_start
    } else if flags.turned {
        let k = seed as f64;
        [
            5.0 * (1.3 * k).sin(),
            5.0 * (2.1 * k).cos(),
            (97.0 * k) % 360.0,
        ]
    } else {
        [0.1, -0.1, 2.0]
    };
    (truth, start)
}

/// Seed k's scheme: the reference one or `--scheme`'s, its turns at
/// `--turn-rate`, turned by hand with `--by-hand`.
fn scheme(seed: u64, flags: &Flags) -> Scheme {
    let mut scheme = match &flags.scheme_file {
        Some(path) => {
            let text = std::fs::read(path).expect("reading --scheme");
            serde_json::from_slice::<Scheme>(&text).expect("a SPEC §4 scheme")
        }
        None => Scheme::builtin("ten-position-9+9", flags.dwell).unwrap(),
    };
    if let Some(r) = flags.turn_rate {
        // Fast turns, as by hand: the rate reached in a tenth of a turn.
        for step in &mut scheme.steps {
            if let sinscal_core::sim::scheme::Step::Rotate { rotate } = step {
                rotate.rate_dps = r;
                rotate.accel_dps2 = r * r / 9.0;
            }
        }
    }
    if flags.by_hand {
        scheme = Scheme::by_hand(&scheme, seed, &sinscal_core::sim::HandTurns::default()).unwrap();
    }
    scheme
}

/// Seed k's run.
fn sim_config(seed: u64, flags: &Flags) -> SimConfig {
    let (truth, start) = truth_and_start(seed, flags);
    let noise = if flags.tactical {
        tactical_noise(seed)
    } else {
        Noise::default_navigation_grade()
    };
    SimConfig {
        site: Site {
            latitude_deg: flags.latitude,
            ..Site::REFERENCE
        },
        sample_rate_hz: flags.rate,
        scheme: scheme(seed, flags),
        params: truth,
        effects: Effects::none(),
        noise,
        initial_attitude_error_deg: start,
        seed,
        thermal: None,
        temperature: None,
    }
}

/// The filter's options for a run with `noise`: the densities given with
/// `--known-noise`, measured otherwise.
fn estimate_options(flags: &Flags, noise: &Noise) -> EstimateOptions {
    let mut base = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    if let Some(w) = flags.window {
        base.window_s = w;
    }
    EstimateOptions {
        noise: flags.known_noise.then_some(NoiseDensity::white(
            noise.gyro_arw_deg_rt_h,
            noise.accel_vrw_ug_rt_hz,
        )),
        ..base
    }
}

/// One seed's run and its calibration.
struct SeedRun {
    seed: u64,
    cfg: SimConfig,
    res: CalibrationResult,
}

/// Simulates and calibrates seed k.
fn calibrate_seed(seed: u64, flags: &Flags) -> SeedRun {
    let cfg = sim_config(seed, flags);
    let opts = estimate_options(flags, &cfg.noise);
    let res = calibrate_simulated(&cfg, &opts).unwrap();
    SeedRun { seed, cfg, res }
}

/// One seed's figures: Σ(err/σ)² per family and the worst |err|/bound.
struct SeedScore {
    z2: [f64; FAMILIES],
    worst_ratio: f64,
}

/// The sums and extremes over the seeds, per family where indexed.
struct Tally {
    z2: [f64; FAMILIES],
    sig: [f64; FAMILIES],
    worst: [f64; FAMILIES],
    worst_z: [f64; FAMILIES],
    count: [usize; FAMILIES],
    worst_ratio: [f64; FAMILIES],
    /// The estimates beyond a Table 1 bound, a line each.
    beyond: Vec<String>,
    /// With `--raw`: a line per run.
    runs: Vec<String>,
}

impl Tally {
    fn new() -> Self {
        Tally {
            z2: [0.0; FAMILIES],
            sig: [0.0; FAMILIES],
            worst: [0.0; FAMILIES],
            worst_z: [0.0; FAMILIES],
            count: [0; FAMILIES],
            worst_ratio: [0.0; FAMILIES],
            beyond: Vec::new(),
            runs: Vec::new(),
        }
    }

    /// Scores `run` against its truth into the sums.
    fn add(&mut self, run: &SeedRun) -> SeedScore {
        let seed = run.seed;
        let mut score = SeedScore {
            z2: [0.0; FAMILIES],
            worst_ratio: 0.0,
        };
        for (i, p) in PARAMETERS.iter().enumerate() {
            let g = p.group.index();
            let e = &run.res.parameters[p.name];
            let err = e.value - run.cfg.params.canonical(i);
            score.z2[g] += (err / e.sigma).powi(2);
            self.z2[g] += (err / e.sigma).powi(2);
            self.sig[g] += e.sigma;
            self.worst[g] = self.worst[g].max(err.abs());
            self.worst_z[g] = self.worst_z[g].max((err / e.sigma).abs());
            self.worst_ratio[g] = self.worst_ratio[g].max(err.abs() / paper_accuracy(p.group));
            score.worst_ratio = score.worst_ratio.max(err.abs() / paper_accuracy(p.group));
            self.count[g] += 1;
            if err.abs() > paper_accuracy(p.group) {
                self.beyond.push(format!(
                    "seed {seed} {} err {err:.6} ({:.2}σ)",
                    p.name,
                    err / e.sigma
                ));
            }
        }
        score
    }

    /// Notes `run`'s line for `--raw`.
    fn add_raw_run(&mut self, run: &SeedRun, worst_ratio: f64) {
        let (seed, res) = (run.seed, &run.res);
        let (what, _, _) = raw_unit(seed);
        let start = run.cfg.initial_attitude_error_deg;
        self.runs.push(format!(
            "seed {seed:>2} {what:<17} start {start:?}: {} dwells, {} passes, worst |err|/bound {worst_ratio:.2}, {} warnings",
            res.dwell_residuals.len(),
            res.passes,
            res.warnings.len()
        ));
    }

    fn print(&self, flags: &Flags) {
        for r in &self.runs {
            println!("{r}");
        }
        println!(
            "{} seeds{}, {} noise, {}, {} Hz, noise {}, filter only",
            flags.seeds,
            if flags.raw {
                ", uncalibrated units"
            } else {
                ""
            },
            if flags.tactical {
                "tactical"
            } else {
                "navigation-grade"
            },
            match &flags.scheme_file {
                Some(f) => format!("scheme {f}"),
                None => format!("{} s dwells", flags.dwell),
            },
            flags.rate,
            if flags.known_noise {
                "known"
            } else {
                "measured"
            }
        );
        println!(
            "{:<15} {:>10} {:>8} {:>12} {:>12} {:>10}",
            "family", "rms err/σ", "max |z|", "mean σ", "max |err|", "bound"
        );
        for (g, group) in Group::ALL.iter().enumerate() {
            println!(
                "{:<15} {:>10.2} {:>8.2} {:>12.6} {:>12.6} {:>10}",
                format!("{group:?}"),
                (self.z2[g] / self.count[g] as f64).sqrt(),
                self.worst_z[g],
                self.sig[g] / self.count[g] as f64,
                self.worst[g],
                paper_accuracy(*group)
            );
        }
        // Table 1 is a navigation-grade promise; at tactical noise only the
        // ratio err/σ is judged.
        if flags.raw {
            let all = self.worst_ratio.iter().copied().fold(0.0, f64::max);
            let per: Vec<String> = Group::ALL
                .iter()
                .zip(self.worst_ratio)
                .map(|(g, r)| format!("{g:?} {r:.2}"))
                .collect();
            println!("worst |err|/bound {all:.2} ({})", per.join(", "));
        }
        if !flags.tactical {
            println!("estimates beyond a Table 1 bound: {}", self.beyond.len());
            for b in &self.beyond {
                println!("  {b}");
            }
        }
    }
}

fn main() {
    let flags = Flags::from_env();
    let mut tally = Tally::new();
    for seed in 1..=flags.seeds {
        let run = calibrate_seed(seed, &flags);
        let score = tally.add(&run);
        if flags.raw {
            tally.add_raw_run(&run, score.worst_ratio);
        }
        if flags.per_seed {
            // Sum of squared err/σ per family, one line per seed.
            println!("seed {seed} z2 {:?}", score.z2);
        }
    }
    tally.print(&flags);
}
