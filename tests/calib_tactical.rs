//! Honest σ at tactical-grade noise (ARW 0.001–0.003 deg/√h, VRW
//! 10–50 µg/√Hz): over 20 seeds, err/σ has an RMS in [0.7, 1.3] in every
//! parameter family. Shortened run (300 s dwells, 20 Hz); starts tilted up
//! to 5° at headings all round, random truths up to 2× the paper's.

use std::sync::atomic::AtomicBool;

use rand::SeedableRng;
use sinscal::calib::sources::SimSource;
use sinscal::calib::{estimate, EstimateOptions, RunInfo};
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

/// Seed k's densities: both ranges covered, ends included, every 15 seeds.
fn tactical_noise(seed: u64) -> Noise {
    Noise {
        gyro_arw_deg_rt_h: [0.001, 0.002, 0.003][(seed % 3) as usize],
        accel_vrw_ug_rt_hz: [10.0, 20.0, 30.0, 40.0, 50.0][(seed % 5) as usize],
    }
}

#[test]
fn sigma_is_honest_at_tactical_grade_over_twenty_seeds() {
    let site = Site::new(28.2215, 112.9924, 50.0);
    let opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    let run = RunInfo {
        site,
        sample_rate_hz: 20.0,
    };
    let mut sum_sq = [0.0; GROUPS.len()];
    let mut count = [0usize; GROUPS.len()];
    for seed in 201..221u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let truth = ErrorParameters::random(&mut rng);
        let k = seed as f64;
        let cfg = SimConfig {
            site,
            sample_rate_hz: 20.0,
            scheme: Scheme::builtin("ten-position-9+9", 300.0).unwrap(),
            params: truth,
            effects: Effects::none(),
            noise: tactical_noise(seed),
            initial_attitude_error_deg: [
                5.0 * (1.3 * k).sin(),
                5.0 * (2.1 * k).cos(),
                (97.0 * k) % 360.0,
            ],
            seed,
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
            let e = &res.parameters[p.name];
            let z = (e.value - truth.canonical(i)) / e.sigma;
            let g = GROUPS.iter().position(|g| *g == p.group).unwrap();
            sum_sq[g] += z * z;
            count[g] += 1;
        }
    }
    for (g, group) in GROUPS.iter().enumerate() {
        let rms = (sum_sq[g] / count[g] as f64).sqrt();
        eprintln!("{group:?}: rms err/σ {rms:.2}");
        assert!((0.7..1.3).contains(&rms), "{group:?}: rms err/σ {rms:.2}");
    }
}
