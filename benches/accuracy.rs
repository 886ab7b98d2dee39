//! Accuracy over many seeds at full length: the reference scenario (paper
//! truth, `ten-position-9+9`, 600 s dwells, 100 Hz, ARW 0.0003 deg/√h,
//! VRW 5 µg/√Hz), seeds 1…N (default 20). Prints per family the RMS of
//! err/σ (honest σ ⇔ ≈ 1), the mean σ and the largest |err| against the
//! paper's Table 1 bound. Run: `cargo bench --bench accuracy [-- N]`.
//!
//! `--raw`: uncalibrated units at the same size, seeds 1…N (default 9) in
//! turn paper truth × 10 (one sign), × 20 (mixed signs, 5° tilt, heading
//! 40° + 97° per seed) and a random truth × 10 (mixed, up to 20×). Prints
//! the same table plus the worst |err|/bound per family and overall, the
//! dwells found and the passes taken.

use std::sync::atomic::AtomicBool;

use rand::SeedableRng;
use sinscal::calib::sources::SimSource;
use sinscal::calib::{estimate, EstimateOptions, RunInfo};
use sinscal::model::params::paper_accuracy;
use sinscal::model::{Effects, ErrorParameters, Group, PARAMETERS};
use sinscal::nav::Site;
use sinscal::sim::{Noise, Scheme, SimConfig};

const GROUPS: [Group; 7] = [
    Group::GyroBias,
    Group::GyroScale,
    Group::GyroMisalign,
    Group::AccelBias,
    Group::AccelScale,
    Group::AccelMisalign,
    Group::AccelQuad,
];

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

fn main() {
    let raw = std::env::args().any(|a| a == "--raw");
    let n: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(if raw { 9 } else { 20 });
    let site = Site::new(28.2215, 112.9924, 50.0);
    let opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    let mut z2 = [0.0; 7];
    let mut sig = [0.0; 7];
    let mut worst = [0.0f64; 7];
    let mut count = [0usize; 7];
    let mut beyond = Vec::new();
    let mut worst_ratio = [0.0f64; 7];
    let mut runs = Vec::new();
    for seed in 1..=n {
        let (what, truth, start) = if raw {
            raw_unit(seed)
        } else {
            (
                "paper".to_string(),
                ErrorParameters::paper(),
                [0.1, -0.1, 2.0],
            )
        };
        let cfg = SimConfig {
            site,
            sample_rate_hz: 100.0,
            scheme: Scheme::builtin("ten-position-9+9", 600.0).unwrap(),
            params: truth,
            effects: Effects::none(),
            noise: Noise::default_navigation_grade(),
            initial_attitude_error_deg: start,
            seed,
        };
        let run = RunInfo {
            site,
            sample_rate_hz: 100.0,
        };
        let res = estimate(
            &SimSource(cfg),
            &run,
            &opts,
            &mut |_| {},
            &AtomicBool::new(false),
        )
        .unwrap();
        let mut run_worst = 0.0f64;
        for (i, p) in PARAMETERS.iter().enumerate() {
            let g = GROUPS.iter().position(|g| *g == p.group).unwrap();
            let e = &res.parameters[p.name];
            let err = e.value - truth.canonical(i);
            z2[g] += (err / e.sigma).powi(2);
            sig[g] += e.sigma;
            worst[g] = worst[g].max(err.abs());
            worst_ratio[g] = worst_ratio[g].max(err.abs() / paper_accuracy(p.group));
            run_worst = run_worst.max(err.abs() / paper_accuracy(p.group));
            count[g] += 1;
            if err.abs() > paper_accuracy(p.group) {
                beyond.push(format!(
                    "seed {seed} ({what}) {} err {err:.6} ({:.2}σ)",
                    p.name,
                    err / e.sigma
                ));
            }
        }
        runs.push(format!(
            "seed {seed:>2} {what:<17} start {start:?}: {} dwells, {} passes, worst |err|/bound {run_worst:.2}, {} warnings",
            res.dwell_residuals.len(),
            res.passes,
            res.warnings.len()
        ));
    }
    if raw {
        for r in &runs {
            println!("{r}");
        }
        println!("{n} seeds, uncalibrated units, reference scheme and noise, filter only");
    } else {
        println!("{n} seeds, reference scenario, filter only");
    }
    println!(
        "{:<15} {:>10} {:>12} {:>12} {:>10}",
        "family", "rms err/σ", "mean σ", "max |err|", "bound"
    );
    for (g, group) in GROUPS.iter().enumerate() {
        println!(
            "{:<15} {:>10.2} {:>12.6} {:>12.6} {:>10}",
            format!("{group:?}"),
            (z2[g] / count[g] as f64).sqrt(),
            sig[g] / count[g] as f64,
            worst[g],
            paper_accuracy(*group)
        );
    }
    if raw {
        let all = worst_ratio.iter().copied().fold(0.0, f64::max);
        let per: Vec<String> = GROUPS
            .iter()
            .zip(worst_ratio)
            .map(|(g, r)| format!("{g:?} {r:.2}"))
            .collect();
        println!("worst |err|/bound {all:.2} ({})", per.join(", "));
    }
    println!("estimates beyond a Table 1 bound: {}", beyond.len());
    for b in beyond {
        println!("  {b}");
    }
}
