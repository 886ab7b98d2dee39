use sinscal::calib::sources::SimSource;
use sinscal::calib::{estimate, EstimateOptions, RunInfo};
use sinscal::model::{Effects, ErrorParameters, PARAMETERS};
use sinscal::nav::Site;
use sinscal::sim::{Noise, Scheme, SimConfig};
use std::sync::atomic::AtomicBool;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args[1].parse().unwrap();
    let name = args[2].clone();
    let cfg = SimConfig {
        site: Site::new(28.2215, 112.9924, 50.0),
        sample_rate_hz: 100.0,
        scheme: Scheme::builtin("ten-position-9+9", 300.0).unwrap(),
        params: ErrorParameters::paper(),
        effects: Effects::none(),
        noise: Noise {
            gyro_arw_deg_rt_h: std::env::var("ARW")
                .map(|v| v.parse().unwrap())
                .unwrap_or(0.0),
            accel_vrw_ug_rt_hz: std::env::var("VRW")
                .map(|v| v.parse().unwrap())
                .unwrap_or(5.0),
        },
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed,
    };
    let truth = cfg.params;
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
    let i = PARAMETERS.iter().position(|p| p.name == name).unwrap();
    let h = &res.convergence;
    for k in (0..h.t.len()).step_by(20) {
        println!(
            "{:8.1} err {:+.5} sig {:.5}",
            h.t[k],
            h.value[k][i] - truth.canonical(i),
            h.sigma[k][i]
        );
    }
}
