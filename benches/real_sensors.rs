//! Real sensors (SPEC §2a) over many seeds: navigation-grade units with
//! pulse outputs, wandering biases, bias random walk and floor vibration on
//! the reference scheme (`ten-position-9+9`, 600 s dwells, 100 Hz), a
//! random truth (±2× the paper's) and a random start heading per seed.
//! Prints per family the RMS of err/σ (honest σ ⇔ ≈ 1; a bias scored
//! against its run mean, the truth's `bias_mean_over_run`), the largest
//! |err/σ|, and the model check's verdicts.
//!
//! Run: `cargo bench --bench real_sensors [-- N]` (seeds 1…N, default 20;
//! `--first K`: seeds K…K+N−1).
//!
//! - `--known-noise`: the filter is given the simulated noise model
//!   instead of measuring it (what the estimator could do at best);
//! - `--white-model`: the filter assumes white noise only, at the
//!   simulated ARW and VRW (the estimator's model before SPEC §2a);
//! - `--pulses-only`: 1″ and 1e-4 m/s pulses on white noise, no wander
//!   nor vibration; `--white`: no §2a term at all;
//! - `--dwell S`, `--rate HZ`: a shorter or slower run;
//! - `--lever-arm MM`: every accelerometer MM mm off the reference
//!   point along its own axis (SPEC §3), which the model check must flag;
//! - `--vs-plan`: each run's σ against `plan`'s prediction for the same
//!   scheme, start attitude and (simulated) noise model, the range of the
//!   ratio reported, and per family the RMS of err / plan's σ (how close
//!   the estimates themselves come to that covariance analysis, whatever
//!   σ they report);
//! - `--paper-truth`: the paper's parameters and heading 123° on every
//!   seed (the reference scenario) instead of random truths and headings;
//! - `--no-fit`: the measured noise model stands (no likelihood fit);
//!   `--fit-unseen-wander`: a white model the dwells measured is fitted
//!   too when the run's innovations ask for wander
//!   (`EstimateOptions::fit_unseen_wander`);
//! - `--per-seed`: each seed's figures;
//! - `--vs-unquantized`: each run calibrated again without its pulses
//!   (the same draws otherwise), and the largest σ ratio reported;
//! - `--no-gyro-pulses`, `--no-vibration`, `--no-random-walk`,
//!   `--no-instability`: seed k's noise without its gyro pulses, its
//!   vibration, both triads' bias random walk or their bias instability;
//! - `--gyro-instability B`, `--accel-instability B`, `--gyro-rrw K`,
//!   `--accel-rw K`, `--vrw V` (deg/h, µg, deg/h/√h, µg/√h, µg/√Hz):
//!   that term at this size on every seed instead of its draw;
//!   `--no-pulses`: without pulses on either triad (a single term's
//!   effect on the fit, alone or dominant);
//! - `--show-model`: each seed's noise model as the calibration reports it;
//! - `--vs-truth-noise`: the fitted noise model tested against the
//!   simulated one over the fit's own pass (`noise_reference`: the
//!   likelihood ratio and whether the run can tell them apart), with each
//!   seed's range of σ / plan's σ beside it under `--vs-plan`.
//!
//! Always printed: per family the worst |err| against the seed paper's
//! Table 1 accuracy, and the noise model's source.
//!
//! Seed k's noise: gyro bias instability 0.0005–0.003 deg/h, accelerometer
//! 1–5 µg, log-uniform; bias random walk 0.0001–0.0005 deg/h/√h and
//! 1–3 µg/√h; vibration 30 µg rms over 2–30 Hz; pulses 1″ and 1e-4 m/s;
//! ARW 0.0003 deg/√h, VRW 5 µg/√Hz.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};

use sinscal_core::calib::plan::{plan, PlanInput};
use sinscal_core::calib::result::NoiseReferenceTest;
use sinscal_core::calib::sources::calibrate_in_memory;
use sinscal_core::calib::{CalibrationResult, EstimateOptions, ModelCheck, NoiseDensity};
use sinscal_core::model::effects::LeverArms;
use sinscal_core::model::params::paper_accuracy;
use sinscal_core::model::{Effects, ErrorParameters, Group, PARAMETERS};
use sinscal_core::nav::Site;
use sinscal_core::sim::{simulate, BiasMean, Noise, Scheme, SimConfig};

#[path = "real_sensors/noise.rs"]
mod noise;
use noise::{real_noise, HeldTerms};

/// The number of parameter families (`Group::ALL`).
const FAMILIES: usize = 7;

fn value<T: std::str::FromStr>(args: &[String], flag: &str) -> Option<T> {
    args.iter()
        .position(|a| a == flag)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
}

/// The flags followed by a value (not a seed count).
const VALUE_FLAGS: [&str; 9] = [
    "--dwell",
    "--rate",
    "--lever-arm",
    "--first",
    "--gyro-instability",
    "--accel-instability",
    "--gyro-rrw",
    "--accel-rw",
    "--vrw",
];

/// The bench's command line, read once (see the file's doc).
struct Flags {
    /// Seeds 1…`seeds`: the first number among the arguments.
    seeds: u64,
    known_noise: bool,
    white_model: bool,
    pulses_only: bool,
    white: bool,
    no_vibration: bool,
    held: HeldTerms,
    /// s.
    dwell: f64,
    /// Hz.
    rate: f64,
    lever_arm: Option<f64>,
    vs_plan: bool,
    paper_truth: bool,
    no_fit: bool,
    fit_unseen_wander: bool,
    per_seed: bool,
    show_model: bool,
    vs_unquantized: bool,
    vs_truth_noise: bool,
    /// The first seed (`--first K`, default 1).
    first: u64,
}

impl Flags {
    fn from_env() -> Self {
        let args: Vec<String> = std::env::args().collect();
        let switch = |flag: &str| args.iter().any(|a| a == flag);
        Flags {
            seeds: args
                .windows(2)
                .filter(|w| !VALUE_FLAGS.contains(&w[0].as_str()))
                .find_map(|w| w[1].parse().ok())
                .unwrap_or(20),
            known_noise: switch("--known-noise"),
            white_model: switch("--white-model"),
            pulses_only: switch("--pulses-only"),
            white: switch("--white"),
            no_vibration: switch("--no-vibration"),
            held: HeldTerms::from_args(&args),
            dwell: value(&args, "--dwell").unwrap_or(600.0),
            rate: value(&args, "--rate").unwrap_or(100.0),
            lever_arm: value(&args, "--lever-arm"),
            vs_plan: switch("--vs-plan"),
            paper_truth: switch("--paper-truth"),
            no_fit: switch("--no-fit"),
            fit_unseen_wander: switch("--fit-unseen-wander"),
            per_seed: switch("--per-seed"),
            show_model: switch("--show-model"),
            vs_unquantized: switch("--vs-unquantized"),
            vs_truth_noise: switch("--vs-truth-noise"),
            first: value(&args, "--first").unwrap_or(1),
        }
    }

    /// The filter's noise model as the summary names it.
    fn noise_model_name(&self) -> &'static str {
        if self.known_noise {
            "given"
        } else if self.white_model {
            "white, measured"
        } else {
            "measured"
        }
    }
}

/// Every accelerometer `arm` off the reference point along its own axis.
fn lever_arm_effects(arm: Option<f64>) -> Effects {
    match arm {
        Some(arm) => Effects {
            accel_lever_arm: Some(LeverArms {
                x: [arm, 0.0, 0.0],
                y: [0.0, -arm, 0.0],
                z: [0.0, 0.0, arm],
            }),
            ..Effects::none()
        },
        None => Effects::none(),
    }
}

/// Seed k's run: its truth and start heading (random unless
/// `--paper-truth`), its noise and the reference scheme.
fn sim_config(seed: u64, flags: &Flags) -> SimConfig {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    let (params, heading) = if flags.paper_truth {
        (ErrorParameters::paper(), 123.0)
    } else {
        (ErrorParameters::random(&mut rng), rng.gen::<f64>() * 360.0)
    };
    let mut noise = real_noise(seed, flags.pulses_only, flags.white);
    if flags.no_vibration {
        noise.vibration = None;
    }
    flags.held.apply(&mut noise);
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: flags.rate,
        scheme: Scheme::builtin("ten-position-9+9", flags.dwell).expect("built-in"),
        params,
        effects: lever_arm_effects(flags.lever_arm),
        noise,
        initial_attitude_error_deg: [0.05, -0.08, heading],
        seed,
        thermal: None,
        temperature: None,
    }
}

/// The filter's options: its noise model measured, given the simulated
/// one (`--known-noise`) or white at the simulated ARW and VRW
/// (`--white-model`).
fn estimate_options(flags: &Flags, noise: &Noise) -> EstimateOptions {
    let mut opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    if flags.no_fit {
        opts.fit_noise = false;
    }
    opts.fit_unseen_wander = flags.fit_unseen_wander;
    if flags.vs_truth_noise {
        opts.noise_reference = Some(NoiseDensity::from(noise));
    }
    if flags.known_noise {
        opts.noise = Some(NoiseDensity::from(noise));
    } else if flags.white_model {
        opts.noise = Some(NoiseDensity::white(
            noise.gyro_arw_deg_rt_h,
            noise.accel_vrw_ug_rt_hz,
        ));
    }
    opts
}

/// The truth of parameter `i` that a run can see: a bias's truth plus its
/// wander's mean over the run.
fn truth_over_run(cfg: &SimConfig, i: usize, mean: Option<&BiasMean>) -> f64 {
    cfg.params.canonical(i) + mean.map_or(0.0, |m| m.of_parameter(i))
}

/// One parameter's score in one run.
struct Score {
    name: &'static str,
    family: usize,
    /// err/σ.
    z: f64,
    /// |err| / the paper's Table 1 accuracy.
    table1: f64,
}

/// Every parameter's score, in `PARAMETERS` order.
fn scores(cfg: &SimConfig, res: &CalibrationResult, mean: Option<&BiasMean>) -> Vec<Score> {
    PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, info)| {
            let truth = truth_over_run(cfg, i, mean);
            let p = &res.parameters[info.name];
            Score {
                name: info.name,
                family: info.group.index(),
                z: (p.value - truth) / p.sigma,
                table1: (p.value - truth).abs() / paper_accuracy(info.group),
            }
        })
        .collect()
}

/// The run calibrated again without its pulses (the same draws
/// otherwise): the largest σ with pulses / σ without, and per family the
/// worst |err| / Table 1 without; `None` when that calibration fails.
fn unquantized(
    cfg: &SimConfig,
    opts: &EstimateOptions,
    res: &CalibrationResult,
) -> Option<(f64, [f64; FAMILIES])> {
    let mut plain = cfg.clone();
    plain.noise.gyro_quantum_arcsec = 0.0;
    plain.noise.accel_quantum_mps = 0.0;
    let r = calibrate_in_memory(&plain, opts).ok()?;
    let mut sigma_ratio = 0.0f64;
    let mut worst = [0.0f64; FAMILIES];
    for (i, info) in PARAMETERS.iter().enumerate() {
        let ratio = res.parameters[info.name].sigma / r.parameters[info.name].sigma;
        sigma_ratio = sigma_ratio.max(ratio);
        // Without wander the truth is the parameter itself.
        let err = (r.parameters[info.name].value - cfg.params.canonical(i)).abs();
        let fam = info.group.index();
        worst[fam] = worst[fam].max(err / paper_accuracy(info.group));
    }
    Some((sigma_ratio, worst))
}

/// σ / `plan`'s σ for the run's scheme, start attitude and simulated
/// noise model, in `PARAMETERS` order.
fn plan_ratio(cfg: &SimConfig, res: &CalibrationResult) -> Vec<f64> {
    let input = PlanInput {
        scheme: cfg.scheme.clone(),
        site: cfg.site,
        sample_rate_hz: cfg.sample_rate_hz,
        noise: NoiseDensity::from(&cfg.noise),
        initial_attitude_error_deg: cfg.initial_attitude_error_deg,
    };
    let predicted = plan(&input, &EstimateOptions::default()).expect("a plan");
    PARAMETERS
        .iter()
        .map(|info| res.parameters[info.name].sigma / predicted.parameters[info.name].sigma)
        .collect()
}

/// A seed's line for `--per-seed`: its noise, the model check, and every
/// parameter beyond 3σ.
fn seed_line(seed: u64, noise: &Noise, check: &ModelCheck, scores: &[Score]) -> String {
    let mut line = format!(
        "seed {seed:>3}: B {:.4} deg/h {:.1} µg K {:.5} deg/h/√h {:.2} µg/√h; check {} χ² {:.0}/{:.0} max|z| {:.1};",
        noise.gyro_bias_instability_deg_h,
        noise.accel_bias_instability_ug,
        noise.gyro_rrw_deg_h_rt_h,
        noise.accel_rw_ug_rt_h,
        if check.adequate { "ok " } else { "BAD" },
        check.statistic,
        check.threshold,
        check.largest_z
    );
    for s in scores.iter().filter(|s| s.z.abs() > 3.0) {
        line.push_str(&format!(" {} {:.1}", s.name, s.z));
    }
    line
}

/// What one seed's calibration gave.
struct SeedOutcome {
    /// The noise model's source, as `Debug` prints it.
    source: String,
    adequate: bool,
    scores: Vec<Score>,
    /// With `--vs-unquantized`: see [`unquantized`].
    unquantized: Option<(f64, [f64; FAMILIES])>,
    /// With `--vs-plan`: see [`plan_ratio`].
    plan_ratio: Option<Vec<f64>>,
    /// With `--vs-truth-noise`: the simulated noise model against the
    /// fitted one.
    reference: Option<NoiseReferenceTest>,
    /// The `--per-seed` line.
    line: String,
}

/// Simulates and calibrates seed k and scores it; `None` (the error
/// printed) when the calibration fails.
fn calibrate_seed(seed: u64, flags: &Flags) -> Option<SeedOutcome> {
    let cfg = sim_config(seed, flags);
    let mut sim = simulate(&cfg).expect("valid");
    for _ in sim.by_ref() {}
    let mean = sim.bias_mean_over_run();
    let opts = estimate_options(flags, &cfg.noise);
    let res = match calibrate_in_memory(&cfg, &opts) {
        Ok(r) => r,
        Err(e) => {
            println!("seed {seed}: {e}");
            return None;
        }
    };
    let source = res
        .noise_model
        .as_ref()
        .map_or("none".to_string(), |n| format!("{:?}", n.source));
    if flags.show_model {
        println!("seed {seed}: {:?}", res.noise_model);
    }
    let unquantized = flags
        .vs_unquantized
        .then(|| unquantized(&cfg, &opts, &res))
        .flatten();
    let plan_ratio = flags.vs_plan.then(|| plan_ratio(&cfg, &res));
    let check = res.model_check.as_ref().expect("a model check");
    let scores = scores(&cfg, &res, mean.as_ref());
    let reference = res.noise_model.as_ref().and_then(|n| n.reference);
    let mut line = seed_line(seed, &cfg.noise, check, &scores);
    if let Some(r) = &reference {
        line.push_str(&format!(
            " truth's noise: 2ΔlnL {:.1} (marginal {:.1}; 99 % point {:.1}, {} terms)",
            r.statistic, r.marginal_statistic, r.threshold, r.degrees_of_freedom
        ));
    }
    if let Some(ratios) = &plan_ratio {
        let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ratios.iter().copied().fold(0.0, f64::max);
        line.push_str(&format!(" σ/plan {lo:.2}–{hi:.2}"));
    }
    Some(SeedOutcome {
        source,
        adequate: check.adequate,
        line,
        scores,
        unquantized,
        plan_ratio,
        reference,
    })
}

/// The sums and extremes over the seeds, per family where indexed.
struct Tally {
    z2: [f64; FAMILIES],
    count: [usize; FAMILIES],
    worst: [f64; FAMILIES],
    worst_table1: [f64; FAMILIES],
    sigma_ratio: f64,
    worst_plain: [f64; FAMILIES],
    plan_ratio: [f64; 2],
    /// Σ (err / plan's σ)² per family: the estimates' own efficiency,
    /// whatever σ they report.
    plan_z2: [f64; FAMILIES],
    sources: BTreeMap<String, usize>,
    inadequate: usize,
    /// With `--vs-truth-noise`: the seeds tested, those whose run cannot
    /// tell its fitted noise from the simulated one, and the largest
    /// statistic.
    reference: (usize, usize, f64),
}

impl Tally {
    fn new() -> Self {
        Tally {
            z2: [0.0; FAMILIES],
            count: [0; FAMILIES],
            worst: [0.0; FAMILIES],
            worst_table1: [0.0; FAMILIES],
            sigma_ratio: 0.0,
            worst_plain: [0.0; FAMILIES],
            plan_ratio: [f64::INFINITY, 0.0],
            plan_z2: [0.0; FAMILIES],
            sources: BTreeMap::new(),
            inadequate: 0,
            reference: (0, 0, 0.0),
        }
    }

    fn add(&mut self, o: &SeedOutcome) {
        *self.sources.entry(o.source.clone()).or_default() += 1;
        if let Some((ratio, worst)) = o.unquantized {
            self.sigma_ratio = self.sigma_ratio.max(ratio);
            for (w, v) in self.worst_plain.iter_mut().zip(worst) {
                *w = w.max(v);
            }
        }
        if let Some(ratios) = &o.plan_ratio {
            for (r, s) in ratios.iter().zip(&o.scores) {
                self.plan_ratio = [self.plan_ratio[0].min(*r), self.plan_ratio[1].max(*r)];
                self.plan_z2[s.family] += (s.z * r).powi(2);
            }
        }
        if !o.adequate {
            self.inadequate += 1;
        }
        if let Some(r) = &o.reference {
            let (n, consistent, largest) = self.reference;
            self.reference = (
                n + 1,
                consistent + usize::from(r.consistent),
                largest.max(r.statistic),
            );
        }
        for s in &o.scores {
            let fam = s.family;
            self.z2[fam] += s.z * s.z;
            self.count[fam] += 1;
            self.worst[fam] = self.worst[fam].max(s.z.abs());
            self.worst_table1[fam] = self.worst_table1[fam].max(s.table1);
        }
    }

    fn print(&self, flags: &Flags) {
        println!(
            "{} seeds, {} dwells of {} s at {} Hz, noise model {}: model check inadequate on {}",
            flags.seeds,
            19,
            flags.dwell,
            flags.rate,
            flags.noise_model_name(),
            self.inadequate
        );
        println!("noise model sources: {:?}", self.sources);
        if flags.vs_truth_noise {
            let (n, consistent, largest) = self.reference;
            println!(
                "the simulated noise model within the run's 99 % likelihood region on {consistent} of {n} seeds (largest 2ΔlnL {largest:.1})"
            );
        }
        if flags.vs_unquantized {
            println!("largest σ with pulses / σ without: {:.3}", self.sigma_ratio);
        }
        if self.plan_ratio[1] > 0.0 {
            println!(
                "σ / plan's σ for the same noise model: {:.3}–{:.3}",
                self.plan_ratio[0], self.plan_ratio[1]
            );
            let per_family = Group::ALL.iter().enumerate().map(|(k, g)| {
                let rms = (self.plan_z2[k] / self.count[k].max(1) as f64).sqrt();
                format!("{g:?} {rms:.2}")
            });
            println!(
                "RMS err / plan's σ (the estimates' efficiency): {}",
                per_family.collect::<Vec<_>>().join(", ")
            );
        }
        for (k, g) in Group::ALL.iter().enumerate() {
            println!(
                "{:<16} RMS err/σ {:5.2}   max |err/σ| {:5.2}   worst |err| / Table 1 {:4.2}{}",
                format!("{g:?}"),
                (self.z2[k] / self.count[k].max(1) as f64).sqrt(),
                self.worst[k],
                self.worst_table1[k],
                if flags.vs_unquantized {
                    format!(" (unquantized {:4.2})", self.worst_plain[k])
                } else {
                    String::new()
                }
            );
        }
    }
}

fn main() {
    let flags = Flags::from_env();
    let mut tally = Tally::new();
    for seed in flags.first..flags.first + flags.seeds {
        if let Some(outcome) = calibrate_seed(seed, &flags) {
            tally.add(&outcome);
            if flags.per_seed {
                let worst = outcome.scores.iter().map(|s| s.table1).fold(0.0, f64::max);
                let plain = outcome
                    .unquantized
                    .map(|(_, w)| {
                        format!(
                            " (unquantized {:.2})",
                            w.iter().fold(0.0, |a: f64, &b| a.max(b))
                        )
                    })
                    .unwrap_or_default();
                println!("{} worst |err| / Table 1 {worst:.2}{plain}", outcome.line);
            }
        }
    }
    tally.print(&flags);
}
