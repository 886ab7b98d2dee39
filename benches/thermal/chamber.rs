//! The chamber ramps of `thermal_support::ChamberRamp`, noisy, calibrated
//! as `sinscal calibrate --thermal` does (noise measured from the run and
//! fitted): is each thermal coefficient's σ honest, on every ramp shape
//! and rate; and from what size the model check sees a quadratic term the
//! in-run states lack. Seeds run on two threads.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use sinscal_core::calib::sources::calibrate_simulated;
use sinscal_core::calib::{CalibrationResult, Effect, ErrorModel, EstimateOptions, NoiseDensity};
use sinscal_core::sim::{Noise, SimConfig};

use super::thermal_support::*;

/// Navigation-grade white noise, the issue's: ARW 0.0003 deg/√h, VRW
/// 5 µg/√Hz; with `--real`, a real unit's SPEC §2a noise over it: 1″ and
/// 1e-4 m/s pulses, bias instability 0.001 deg/h and 1 µg.
fn noise() -> Noise {
    let white = Noise {
        gyro_arw_deg_rt_h: 0.0003,
        accel_vrw_ug_rt_hz: 5.0,
        ..Noise::default()
    };
    if std::env::args().any(|a| a == "--real") {
        Noise {
            gyro_quantum_arcsec: 1.0,
            accel_quantum_mps: 1e-4,
            gyro_bias_instability_deg_h: 0.001,
            accel_bias_instability_ug: 1.0,
            ..white
        }
    } else {
        white
    }
}

/// As `sinscal calibrate --thermal`; with `--stated`, under the truth's
/// white noise model instead of the one measured and fitted on the run.
fn thermal_options() -> EstimateOptions {
    let stated = std::env::args().any(|a| a == "--stated");
    EstimateOptions {
        model: ErrorModel::base().and(Effect::Thermal),
        cross_check: false,
        noise: stated.then(|| NoiseDensity::white(0.0003, 5.0)),
        ..EstimateOptions::default()
    }
}

/// Calibrates `config(seed)` for seeds 1..=seeds on two threads.
fn calibrate_seeds(
    seeds: u64,
    config: impl Fn(u64) -> SimConfig + Sync,
) -> Vec<(u64, CalibrationResult)> {
    let next = AtomicU64::new(1);
    let out = Mutex::new(Vec::new());
    let opts = thermal_options();
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let seed = next.fetch_add(1, Ordering::SeqCst);
                if seed > seeds {
                    return;
                }
                let r = calibrate_simulated(&config(seed), &opts).unwrap();
                out.lock().unwrap().push((seed, r));
            });
        }
    });
    let mut out = out.into_inner().unwrap();
    out.sort_by_key(|(seed, _)| *seed);
    out
}

/// Whether the run's fitted noise model carries a §2a term the white
/// truth does not.
fn fitted_wander(r: &CalibrationResult) -> bool {
    r.noise_model.as_ref().is_some_and(|n| {
        let m = &n.model;
        [
            m.gyro_bias_instability_deg_h,
            m.gyro_rrw_deg_h_rt_h,
            m.accel_bias_instability_ug,
            m.accel_rw_ug_rt_h,
        ]
        .iter()
        .flatten()
        .any(|v| *v > 0.0)
    })
}

pub fn ramps(seeds: u64) {
    let cases = [
        (ChamberRamp::Rising, 100.0),
        (ChamberRamp::Falling, 100.0),
        (ChamberRamp::StopsMidDwell, 100.0),
        (ChamberRamp::Rising, 20.0),
    ];
    // `--only Falling` (a ramp's name) runs that shape alone.
    let args: Vec<String> = std::env::args().collect();
    let only = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1).cloned());
    let cases = cases
        .into_iter()
        .filter(|(ramp, _)| only.as_ref().map_or(true, |o| *o == format!("{ramp:?}")));
    let truth = chamber_truth(&[]);
    for (ramp, rate_hz) in cases {
        let start = Instant::now();
        let results = calibrate_seeds(seeds, |seed| chamber_config(ramp, rate_hz, noise(), seed));
        let (mut z2, mut n, mut worst, mut beyond_4) =
            (0.0, 0usize, (0.0f64, 0u64, String::new()), 0);
        let (mut adequate, mut wander) = (0, 0);
        // Per coefficient: Σz² over the seeds, for the one least honest.
        let mut by_name = std::collections::BTreeMap::<String, f64>::new();
        for (seed, r) in &results {
            for (name, err, sigma, _) in chamber_errors(r.thermal.as_ref().unwrap(), &truth) {
                let z = err / sigma;
                z2 += z * z;
                n += 1;
                *by_name.entry(name.clone()).or_default() += z * z;
                beyond_4 += usize::from(z.abs() > 4.0);
                if z.abs() > worst.0 {
                    worst = (z.abs(), *seed, name);
                }
            }
            adequate += usize::from(r.model_check.as_ref().unwrap().adequate);
            wander += usize::from(fitted_wander(r));
            if std::env::args().any(|a| a == "--each") {
                let (name, z) = chamber_errors(r.thermal.as_ref().unwrap(), &truth)
                    .into_iter()
                    .map(|(name, err, sigma, _)| (name, err / sigma))
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .unwrap();
                let source = r.noise_model.as_ref().map(|n| n.source);
                println!("  seed {seed}: largest z {z:.2} ({name}), noise {source:?}");
            }
        }
        if std::env::args().any(|a| a == "--each") {
            for (name, z2) in &by_name {
                println!("  {name}: RMS err/σ {:.2}", (z2 / seeds as f64).sqrt());
            }
        }
        let (least_honest, most_z2) = by_name
            .iter()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(name, z2)| (name.clone(), *z2))
            .unwrap_or_default();
        println!(
            "chamber {ramp:?} at {rate_hz} Hz, seeds 1-{seeds} ({:.0} s): RMS err/σ of the thermal \
             coefficients {:.2} (n = {n}); largest |z| {:.2} (seed {}, {}); |z| > 4: {beyond_4}; \
             largest RMS of one coefficient {:.2} ({least_honest}); model check adequate \
             {adequate}/{seeds}; noise fitted with a wander term {wander}/{seeds}",
            start.elapsed().as_secs_f64(),
            (z2 / n.max(1) as f64).sqrt(),
            worst.0,
            worst.1,
            worst.2,
            (most_z2 / seeds as f64).sqrt(),
        );
    }
}

/// The rising ramp with a quadratic accelerometer bias (µg/°C², on x)
/// that the in-run linear states cannot follow: at each size the seeds
/// whose model check flags the run, and how far the linear coefficient it
/// drags sits from its truth.
pub fn quadratic(seeds: u64) {
    // `--q=0.05` runs that size alone.
    let only: Option<f64> = std::env::args().find_map(|a| a.strip_prefix("--q=")?.parse().ok());
    let sizes = [0.0, 0.005, 0.01, 0.02, 0.05, 0.1];
    for q in sizes.into_iter().filter(|q| only.map_or(true, |o| o == *q)) {
        let start = Instant::now();
        let results = calibrate_seeds(seeds, |seed| SimConfig {
            thermal: Some(chamber_truth(&[("accel_bias_x", q)])),
            ..chamber_config(ChamberRamp::Rising, 100.0, noise(), seed)
        });
        let mut flagged = 0;
        let mut worst_linear = 0.0f64;
        let truth = chamber_truth(&[]);
        let each = std::env::args().any(|a| a == "--each");
        for (seed, r) in &results {
            let check = r.model_check.as_ref().unwrap();
            flagged += usize::from(!check.adequate);
            if each {
                let source = r.noise_model.as_ref().map(|n| n.source);
                println!(
                    "  seed {seed}: χ² {:.0} / {:.0}, largest |z| {:.2} / {:.2}, noise {source:?}{}",
                    check.statistic,
                    check.threshold,
                    check.largest_z,
                    check.largest_z_threshold,
                    if fitted_wander(r) { " with wander" } else { "" }
                );
            }
            for (name, err, sigma, _) in chamber_errors(r.thermal.as_ref().unwrap(), &truth) {
                if name == "accel_bias_x linear" {
                    worst_linear = worst_linear.max((err / sigma).abs());
                }
            }
        }
        println!(
            "quadratic accel_bias_x {q} µg/°C² ({:.0} s): model check flags {flagged}/{seeds}; \
             accel_bias_x linear up to {worst_linear:.1}σ from its truth",
            start.elapsed().as_secs_f64()
        );
    }
}
