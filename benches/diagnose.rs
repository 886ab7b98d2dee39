//! Speed and memory of the discrepancy workflow on the reference run: the
//! 3.2 h `ten-position-9+9` run at 100 Hz (paper errors, ARW 0.0003 deg/√h,
//! VRW 5 µg/√Hz) written to disk as f64le, once with a 2 ms accelerometer
//! delay and once clean, each diagnosed from the file through
//! `pipeline::diagnose_file`, the entry the CLI and the server call
//! (best of three). Run: `cargo bench --bench diagnose`.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

mod common;
use common::peak_rss_mb;

use sinscal_core::diagnose::DiagnoseOptions;
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::model::Effects;
use sinscal_core::pipeline::diagnose_file;
use sinscal_core::sim::SimConfig;

/// Lowers this process's peak RSS to its current RSS (Linux `clear_refs`),
/// so a case's figure is not the previous case's peak. False where
/// unsupported.
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn main() {
    let reference = common::reference_run();
    let cases = [
        (
            "accel_delay 2 ms",
            Effects {
                accel_delay: Some(2.0),
                ..Effects::none()
            },
        ),
        ("clean", Effects::none()),
    ];
    let dir = std::env::temp_dir().join(format!("sinscal-bench-diagnose-{}", std::process::id()));
    let cancel = AtomicBool::new(false);
    let per_case_rss = reset_peak_rss();
    if !per_case_rss {
        println!("peak RSS cannot be reset here: each figure is the largest so far");
    }
    for (i, (label, effects)) in cases.into_iter().enumerate() {
        let cfg = SimConfig {
            effects,
            ..reference.clone()
        };
        let files = write_simulated_run(
            &cfg,
            &dir.join(format!("case{i}")),
            DataFormat::F64le,
            false,
            "BENCH-D",
        )
        .unwrap();
        let meta = RunMetadata::from_json(&std::fs::read(&files.metadata).unwrap()).unwrap();
        // Writing the run is not part of the workflow's footprint.
        if per_case_rss {
            reset_peak_rss();
        }
        // Best of three: the machine may be shared with other work.
        let mut wall = f64::INFINITY;
        let mut report = None;
        for _ in 0..3 {
            let start = Instant::now();
            let r = diagnose_file(
                &files.data,
                &meta,
                &DiagnoseOptions::default(),
                &mut |_| {},
                &cancel,
            )
            .unwrap();
            wall = wall.min(start.elapsed().as_secs_f64());
            report = Some(r);
        }
        let report = report.unwrap();
        println!(
            "diagnose 3.2 h f64le {label:<16} {wall:7.2} s  named {} {:?}  gap RMS {:.3e} -> {:.3e} m/s  floor {:.3e} m/s  peak RSS {:.1} MB",
            report.named.len(),
            report.named,
            report.gap_rms_before,
            report.gap_rms_after,
            report.noise_floor_rms,
            peak_rss_mb()
        );
        let _ = std::fs::remove_dir_all(dir.join(format!("case{i}")));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
