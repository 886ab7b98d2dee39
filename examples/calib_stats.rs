use sinscal::calib::sources::SimSource;
use sinscal::calib::{estimate, EstimateOptions, RunInfo};
use sinscal::model::{Effects, ErrorParameters, Group, PARAMETERS};
use sinscal::nav::Site;
use sinscal::sim::{Noise, Scheme, SimConfig};
use std::sync::atomic::AtomicBool;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(10);
    let dwell: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(600.0);
    let scheme = args.get(3).cloned().unwrap_or("ten-position-9+9".into());
    let arw: f64 = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(0.0003);
    let vrw: f64 = args.get(5).map(|s| s.parse().unwrap()).unwrap_or(5.0);
    let mut z2 = vec![0.0; 24];
    let mut zs: Vec<Vec<f64>> = vec![vec![]; 24];
    for seed in 1..=n {
        let cfg = SimConfig {
            site: Site::new(28.2215, 112.9924, 50.0),
            sample_rate_hz: 100.0,
            scheme: Scheme::builtin(&scheme, dwell).unwrap(),
            params: if std::env::var("ZEROP").is_ok() {
                ErrorParameters::zero()
            } else {
                ErrorParameters::paper()
            },
            effects: Effects::none(),
            noise: Noise {
                gyro_arw_deg_rt_h: arw,
                accel_vrw_ug_rt_hz: vrw,
            },
            initial_attitude_error_deg: [0.1, -0.1, 2.0],
            seed: seed + 100,
        };
        let truth = cfg.params;
        let res = estimate(
            &SimSource(cfg),
            &RunInfo {
                site: Site::new(28.2215, 112.9924, 50.0),
                sample_rate_hz: 100.0,
            },
            &EstimateOptions {
                window_s: std::env::var("WIN")
                    .map(|v| v.parse().unwrap())
                    .unwrap_or(1.0),
                zupt_sigma_mps: std::env::var("ZS")
                    .map(|v| v.parse().unwrap())
                    .unwrap_or(1e-6),
                ..EstimateOptions::default()
            },
            &mut |_| {},
            &AtomicBool::new(false),
        )
        .unwrap();
        for (i, p) in PARAMETERS.iter().enumerate() {
            let e = &res.parameters[p.name];
            let z = (e.value - truth.canonical(i)) / e.sigma;
            z2[i] += z * z;
            zs[i].push(z);
        }
    }
    for (i, p) in PARAMETERS.iter().enumerate() {
        let mean: f64 = zs[i].iter().sum::<f64>() / n as f64;
        println!(
            "{:20} rms z {:5.2} mean z {:+5.2}",
            p.name,
            (z2[i] / n as f64).sqrt(),
            mean
        );
    }
    let groups = [
        Group::GyroBias,
        Group::GyroScale,
        Group::GyroMisalign,
        Group::AccelBias,
        Group::AccelScale,
        Group::AccelMisalign,
        Group::AccelQuad,
    ];
    for g in groups {
        let (s, c) = PARAMETERS
            .iter()
            .enumerate()
            .filter(|(_, p)| p.group == g)
            .fold((0.0, 0), |(s, c), (i, _)| (s + z2[i], c + n as usize));
        println!("{:?}: rms z {:.2}", g, (s / c as f64).sqrt());
    }
}
