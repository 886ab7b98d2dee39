//! Calibration speed and memory on the reference run: the 3.2 h
//! `ten-position-9+9` run at 100 Hz (paper errors, ARW 0.0003 deg/√h,
//! VRW 5 µg/√Hz), written to disk as f64le and CSV, then calibrated from the
//! file in streaming passes on one core. Run: `cargo bench --bench calibrate`.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

mod common;
use common::peak_rss_mb;

use sinscal_core::calib::EstimateOptions;
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::pipeline::calibrate_file;

fn main() {
    let cfg = common::reference_run();
    let dir = std::env::temp_dir().join(format!("sinscal-bench-calib-{}", std::process::id()));
    let cancel = AtomicBool::new(false);
    println!("peak RSS before calibrating: {:.1} MB", peak_rss_mb());
    for (format, label) in [(DataFormat::F64le, "f64le"), (DataFormat::Csv, "csv")] {
        let run_dir = dir.join(label);
        let files = write_simulated_run(&cfg, &run_dir, format, false, "BENCH-1").unwrap();
        let meta = RunMetadata::from_json(&std::fs::read(&files.metadata).unwrap()).unwrap();
        for cross_check in [false, true] {
            let opts = EstimateOptions {
                cross_check,
                ..EstimateOptions::default()
            };
            let mut best = f64::INFINITY;
            let mut passes = 0;
            for _ in 0..3 {
                let start = Instant::now();
                let res = calibrate_file(&files.data, &meta, &opts, &mut |_| {}, &cancel).unwrap();
                best = best.min(start.elapsed().as_secs_f64());
                passes = res.passes;
            }
            println!(
                "calibrate 3.2 h {label:<5} cross-check {:<5} {best:6.3} s  ({passes} filter passes)  peak RSS {:.1} MB",
                cross_check,
                peak_rss_mb()
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
