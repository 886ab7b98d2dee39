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
use sinscal_core::calib::{EstimateOptions, NoiseDensity};
use sinscal_core::model::params::paper_accuracy;
use sinscal_core::model::{Effects, ErrorParameters, Group, PARAMETERS};
use sinscal_core::nav::Site;
use sinscal_core::sim::{Noise, Scheme, SimConfig};

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

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let tactical = args.iter().any(|a| a == "--tactical");
    let known_noise = args.iter().any(|a| a == "--known-noise");
    let dwell: f64 = value(&args, "--dwell").unwrap_or(600.0);
    let rate: f64 = value(&args, "--rate").unwrap_or(100.0);
    let latitude: f64 = value(&args, "--latitude").unwrap_or(Site::REFERENCE.latitude_deg);
    let random = args.iter().any(|a| a == "--random");
    let turned = args.iter().any(|a| a == "--turned");
    let turn_rate: Option<f64> = value(&args, "--turn-rate");
    let per_seed = args.iter().any(|a| a == "--per-seed");
    let raw = args.iter().any(|a| a == "--raw");
    let by_hand = args.iter().any(|a| a == "--by-hand");
    let scheme_file: Option<String> = value(&args, "--scheme");
    let flags = [
        "--dwell",
        "--rate",
        "--window",
        "--latitude",
        "--turn-rate",
        "--scheme",
    ];
    let n: u64 = args
        .iter()
        .enumerate()
        .filter(|(i, _)| *i == 0 || !flags.contains(&args[i - 1].as_str()))
        .find_map(|(_, a)| a.parse().ok())
        .unwrap_or(if raw { 9 } else { 20 });
    let site = Site {
        latitude_deg: latitude,
        ..Site::REFERENCE
    };
    let mut base = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    if let Some(w) = value(&args, "--window") {
        base.window_s = w;
    }
    let mut z2 = [0.0; 7];
    let mut sig = [0.0; 7];
    let mut worst = [0.0f64; 7];
    let mut worst_z = [0.0f64; 7];
    let mut count = [0usize; 7];
    let mut beyond = Vec::new();
    let mut worst_ratio = [0.0f64; 7];
    let mut runs = Vec::new();
    for seed in 1..=n {
        let (what, raw_truth, raw_start) = raw_unit(seed);
        let truth = if raw {
            raw_truth
        } else if random {
            ErrorParameters::random(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed))
        } else {
            ErrorParameters::paper()
        };
        let start = if raw {
            raw_start
        } else if turned {
            let k = seed as f64;
            [
                5.0 * (1.3 * k).sin(),
                5.0 * (2.1 * k).cos(),
                (97.0 * k) % 360.0,
            ]
        } else {
            [0.1, -0.1, 2.0]
        };
        let noise = if tactical {
            tactical_noise(seed)
        } else {
            Noise::default_navigation_grade()
        };
        let mut scheme = match &scheme_file {
            Some(path) => {
                let text = std::fs::read(path).expect("reading --scheme");
                serde_json::from_slice::<Scheme>(&text).expect("a SPEC §4 scheme")
            }
            None => Scheme::builtin("ten-position-9+9", dwell).unwrap(),
        };
        if let Some(r) = turn_rate {
            // Fast turns, as by hand: the rate reached in a tenth of a turn.
            for step in &mut scheme.steps {
                if let sinscal_core::sim::scheme::Step::Rotate { rotate } = step {
                    rotate.rate_dps = r;
                    rotate.accel_dps2 = r * r / 9.0;
                }
            }
        }
        if by_hand {
            scheme =
                Scheme::by_hand(&scheme, seed, &sinscal_core::sim::HandTurns::default()).unwrap();
        }
        let cfg = SimConfig {
            site,
            sample_rate_hz: rate,
            scheme,
            params: truth,
            effects: Effects::none(),
            noise: noise.clone(),
            initial_attitude_error_deg: start,
            seed,
            thermal: None,
            temperature: None,
        };
        let opts = EstimateOptions {
            noise: known_noise.then_some(NoiseDensity::white(
                noise.gyro_arw_deg_rt_h,
                noise.accel_vrw_ug_rt_hz,
            )),
            ..base.clone()
        };
        let res = calibrate_simulated(&cfg, &opts).unwrap();
        let mut seed_z2 = [0.0; 7];
        let mut run_worst = 0.0f64;
        for (i, p) in PARAMETERS.iter().enumerate() {
            let g = Group::ALL.iter().position(|g| *g == p.group).unwrap();
            let e = &res.parameters[p.name];
            let err = e.value - truth.canonical(i);
            seed_z2[g] += (err / e.sigma).powi(2);
            z2[g] += (err / e.sigma).powi(2);
            sig[g] += e.sigma;
            worst[g] = worst[g].max(err.abs());
            worst_z[g] = worst_z[g].max((err / e.sigma).abs());
            worst_ratio[g] = worst_ratio[g].max(err.abs() / paper_accuracy(p.group));
            run_worst = run_worst.max(err.abs() / paper_accuracy(p.group));
            count[g] += 1;
            if err.abs() > paper_accuracy(p.group) {
                beyond.push(format!(
                    "seed {seed} {} err {err:.6} ({:.2}σ)",
                    p.name,
                    err / e.sigma
                ));
            }
        }
        if raw {
            runs.push(format!(
                "seed {seed:>2} {what:<17} start {start:?}: {} dwells, {} passes, worst |err|/bound {run_worst:.2}, {} warnings",
                res.dwell_residuals.len(),
                res.passes,
                res.warnings.len()
            ));
        }
        if per_seed {
            // Sum of squared err/σ per family, one line per seed.
            println!("seed {seed} z2 {seed_z2:?}");
        }
    }
    for r in &runs {
        println!("{r}");
    }
    println!(
        "{n} seeds{}, {} noise, {}, {rate} Hz, noise {}, filter only",
        if raw { ", uncalibrated units" } else { "" },
        if tactical {
            "tactical"
        } else {
            "navigation-grade"
        },
        match &scheme_file {
            Some(f) => format!("scheme {f}"),
            None => format!("{dwell} s dwells"),
        },
        if known_noise { "known" } else { "measured" }
    );
    println!(
        "{:<15} {:>10} {:>8} {:>12} {:>12} {:>10}",
        "family", "rms err/σ", "max |z|", "mean σ", "max |err|", "bound"
    );
    for (g, group) in Group::ALL.iter().enumerate() {
        println!(
            "{:<15} {:>10.2} {:>8.2} {:>12.6} {:>12.6} {:>10}",
            format!("{group:?}"),
            (z2[g] / count[g] as f64).sqrt(),
            worst_z[g],
            sig[g] / count[g] as f64,
            worst[g],
            paper_accuracy(*group)
        );
    }
    // Table 1 is a navigation-grade promise; at tactical noise only the
    // ratio err/σ is judged.
    if raw {
        let all = worst_ratio.iter().copied().fold(0.0, f64::max);
        let per: Vec<String> = Group::ALL
            .iter()
            .zip(worst_ratio)
            .map(|(g, r)| format!("{g:?} {r:.2}"))
            .collect();
        println!("worst |err|/bound {all:.2} ({})", per.join(", "));
    }
    if !tactical {
        println!("estimates beyond a Table 1 bound: {}", beyond.len());
        for b in beyond {
            println!("  {b}");
        }
    }
}
