//! Accuracy over many seeds at full length: the reference scenario (paper
//! truth, `ten-position-9+9`, 600 s dwells, 100 Hz, ARW 0.0003 deg/√h,
//! VRW 5 µg/√Hz), seeds 1…N (default 20). Prints per family the RMS of
//! err/σ (honest σ ⇔ ≈ 1), the mean σ and the largest |err| against the
//! paper's Table 1 bound. Run: `cargo bench --bench accuracy [-- N]`.

use std::sync::atomic::AtomicBool;

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

fn main() {
    let n: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(20);
    let truth = ErrorParameters::paper();
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
    for seed in 1..=n {
        let cfg = SimConfig {
            site,
            sample_rate_hz: 100.0,
            scheme: Scheme::builtin("ten-position-9+9", 600.0).unwrap(),
            params: truth,
            effects: Effects::none(),
            noise: Noise::default_navigation_grade(),
            initial_attitude_error_deg: [0.1, -0.1, 2.0],
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
        for (i, p) in PARAMETERS.iter().enumerate() {
            let g = GROUPS.iter().position(|g| *g == p.group).unwrap();
            let e = &res.parameters[p.name];
            let err = e.value - truth.canonical(i);
            z2[g] += (err / e.sigma).powi(2);
            sig[g] += e.sigma;
            worst[g] = worst[g].max(err.abs());
            count[g] += 1;
            if err.abs() > paper_accuracy(p.group) {
                beyond.push(format!(
                    "seed {seed} {} err {err:.6} ({:.2}σ)",
                    p.name,
                    err / e.sigma
                ));
            }
        }
    }
    println!("{n} seeds, reference scenario, filter only");
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
    println!("estimates beyond a Table 1 bound: {}", beyond.len());
    for b in beyond {
        println!("  {b}");
    }
}
