use sinscal::calib::sources::SimSource;
use sinscal::calib::{estimate, EstimateOptions, RunInfo};
use sinscal::model::{Effects, ErrorParameters, PARAMETERS};
use sinscal::nav::Site;
use sinscal::sim::{Noise, Scheme, SimConfig};
use std::sync::atomic::AtomicBool;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(1);
    let dwell: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(600.0);
    let scheme = args.get(3).cloned().unwrap_or("ten-position-9+9".into());
    let noise_on = args.get(4).map(|s| s != "0").unwrap_or(true);
    let cfg = SimConfig {
        site: Site::new(28.2215, 112.9924, 50.0),
        sample_rate_hz: 100.0,
        scheme: Scheme::builtin(&scheme, dwell).unwrap(),
        params: ErrorParameters::paper(),
        effects: Effects::none(),
        noise: if noise_on {
            Noise {
                gyro_arw_deg_rt_h: std::env::var("ARW")
                    .map(|v| v.parse().unwrap())
                    .unwrap_or(0.0003),
                accel_vrw_ug_rt_hz: std::env::var("VRW")
                    .map(|v| v.parse().unwrap())
                    .unwrap_or(5.0),
            }
        } else {
            Noise::default()
        },
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed,
    };
    let truth = cfg.params;
    let t0 = std::time::Instant::now();
    let res = estimate(
        &SimSource(cfg),
        &RunInfo {
            site: Site::new(28.2215, 112.9924, 50.0),
            sample_rate_hz: 100.0,
        },
        &EstimateOptions::default(),
        &mut |_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    println!(
        "noise {:.6} {:.4} dwells {}",
        res.noise_arw_deg_rt_h,
        res.noise_vrw_ug_rt_hz,
        res.dwell_residuals.len()
    );
    println!(
        "passes {} time {:.2}s warnings {:?}",
        res.passes,
        t0.elapsed().as_secs_f64(),
        res.warnings
    );
    for (i, p) in PARAMETERS.iter().enumerate() {
        let e = &res.parameters[p.name];
        let err = e.value - truth.canonical(i);
        println!(
            "{:20} {:12.5} err {:+10.5} sigma {:9.5} z {:+6.2}",
            p.name,
            e.value,
            err,
            e.sigma,
            err / e.sigma
        );
    }
}
