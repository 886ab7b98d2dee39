//! Simulation speed and memory: the 3.2 h `ten-position-9+9` run at
//! 100 Hz with the paper's errors and noise, turned on a table and by hand
//! (SPEC §4 flips), as a real sensor (SPEC §2a), generated in memory and
//! written to disk. Run:
//! `cargo bench --bench simulate [-- WORD]`; with WORD, only the cases
//! whose label holds it (e.g. `hand`), so their peak RSS is their own.

use std::time::Instant;

mod common;
use common::peak_rss_mb;

use sinscal_core::io::data::DataFormat;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::Site;
use sinscal_core::sim::{simulate, HandTurns, Noise, Scheme, SimConfig};

fn config(scheme: &str, effects: Effects) -> SimConfig {
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: 100.0,
        scheme: Scheme::builtin(scheme, 600.0).unwrap(),
        params: ErrorParameters::paper(),
        effects,
        noise: Noise::default_navigation_grade(),
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed: 1,
        thermal: None,
        temperature: None,
    }
}

fn time_generation(label: &str, cfg: &SimConfig) {
    let mut best = f64::INFINITY;
    let mut n = 0;
    for _ in 0..3 {
        let start = Instant::now();
        let mut checksum = 0.0;
        n = 0;
        for r in simulate(cfg).unwrap() {
            checksum += r.dv[2];
            n += 1;
        }
        best = best.min(start.elapsed().as_secs_f64());
        assert!(checksum.is_finite());
    }
    println!(
        "simulate {label:<34} {n:>8} records  {best:6.3} s  ({:.2} M records/s)  peak RSS {:.1} MB",
        n as f64 / best / 1e6,
        peak_rss_mb()
    );
}

fn main() {
    // `cargo bench` passes `--bench`; the first other argument filters.
    let filter = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let selected = |label: &str| match filter.as_deref() {
        Some(f) => label.contains(f),
        None => true,
    };
    let timed = |label: &str, cfg: &SimConfig| {
        if selected(label) {
            time_generation(label, cfg);
        }
    };
    // Memory must not grow with run length: the 1.7 h run first, then the
    // 3.2 h one; peak RSS is reported after each.
    timed(
        "ten-position (1.7 h)",
        &config("ten-position", Effects::none()),
    );
    timed(
        "ten-position-9+9 (3.2 h)",
        &config("ten-position-9+9", Effects::none()),
    );
    let nominal = config("ten-position-9+9", Effects::none());
    let by_hand = SimConfig {
        scheme: Scheme::by_hand(&nominal.scheme, 1, &HandTurns::default()).unwrap(),
        ..nominal
    };
    timed("ten-position-9+9 by hand (3.2 h)", &by_hand);
    let all_effects: Effects = serde_json::from_str(
        r#"{"accel_lever_arm": {"x": [50, 0, 0], "y": [0, 50, 0], "z": [0, 0, 50]},
            "gyro_g_sensitivity": [0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.01],
            "accel_delay": 2.0, "bias_drift": {"gyro": [0.01, 0.01, 0.01], "accel": [10, 10, 10]},
            "gyro_scale_asymmetry": [50, 50, 50]}"#,
    )
    .unwrap();
    timed(
        "ten-position-9+9, all effects",
        &config("ten-position-9+9", all_effects),
    );
    // SPEC §2a: wandering biases, pulses, floor vibration; then jittered
    // stamps too (every step's transitions and phases evaluated afresh).
    let real = SimConfig {
        noise: Noise::real_navigation_grade(),
        ..config("ten-position-9+9", Effects::none())
    };
    timed("ten-position-9+9, real sensor", &real);
    let jittered = SimConfig {
        noise: Noise {
            time_jitter_pct: 5.0,
            ..Noise::real_navigation_grade()
        },
        ..config("ten-position-9+9", Effects::none())
    };
    timed("ten-position-9+9, real sensor, jitter", &jittered);

    let dir = std::env::temp_dir().join(format!("sinscal-bench-sim-{}", std::process::id()));
    for (format, gzip, label) in [
        (DataFormat::F64le, false, "f64le"),
        (DataFormat::Csv, false, "csv"),
        (DataFormat::Csv, true, "csv.gz"),
    ] {
        if !selected(&format!("write {label}")) {
            continue;
        }
        let start = Instant::now();
        let files = write_simulated_run(
            &config("ten-position-9+9", Effects::none()),
            &dir,
            format,
            gzip,
            "BENCH-1",
        )
        .unwrap();
        let secs = start.elapsed().as_secs_f64();
        let bytes = std::fs::metadata(&files.data).map(|m| m.len()).unwrap_or(0);
        println!(
            "simulate+write {label:<8} 3.2 h run  {secs:6.3} s  {:.1} MB on disk  peak RSS {:.1} MB",
            bytes as f64 / 1e6,
            peak_rss_mb()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
