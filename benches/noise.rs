//! Speed and memory of the noise analysis on the reference run: the 3.2 h
//! `ten-position-9+9` run at 100 Hz (paper errors, ARW 0.0003 deg/√h,
//! VRW 5 µg/√Hz) written to disk as f64le and CSV, then analysed over its
//! 19 dwells from the file through `pipeline::noise_file`, the entry the
//! CLI and the server call (best of three; two streaming reads each).
//! Run: `cargo bench --bench noise`.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

mod common;
use common::peak_rss_mb;

use sinscal_core::io::data::DataFormat;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::noise::NoiseOptions;
use sinscal_core::pipeline::noise_file;

fn main() {
    let cfg = common::reference_run();
    let dir = std::env::temp_dir().join(format!("sinscal-bench-noise-{}", std::process::id()));
    let cancel = AtomicBool::new(false);
    println!("peak RSS before the analyses: {:.1} MB", peak_rss_mb());
    for (format, label) in [(DataFormat::F64le, "f64le"), (DataFormat::Csv, "csv")] {
        let files = write_simulated_run(&cfg, &dir.join(label), format, false, "BENCH-N").unwrap();
        let meta = RunMetadata::from_json(&std::fs::read(&files.metadata).unwrap()).unwrap();
        let mut best = f64::INFINITY;
        let mut report = None;
        for _ in 0..3 {
            let start = Instant::now();
            let r = noise_file(&files.data, &meta, &NoiseOptions::default(), &cancel).unwrap();
            best = best.min(start.elapsed().as_secs_f64());
            report = Some(r);
        }
        let r = report.unwrap();
        let c = &r.computed_over;
        println!(
            "noise 3.2 h {label:<5} {best:6.3} s  ({} dwells, {:.0} s at rest, tau up to {:.0} s, {} points)  peak RSS {:.1} MB",
            c.stretches.len(),
            c.seconds_used,
            c.max_tau_s,
            r.curves.tau_s.len(),
            peak_rss_mb()
        );
        println!(
            "  ARW x/y/z {} {} {} deg/sqrt(h) (true 0.0003); VRW x/y/z {} {} {} ug/sqrt(Hz) (true 5)",
            r.gyro.x.arw_deg_rt_h.cell(),
            r.gyro.y.arw_deg_rt_h.cell(),
            r.gyro.z.arw_deg_rt_h.cell(),
            r.accel.x.vrw_ug_rt_hz.cell(),
            r.accel.y.vrw_ug_rt_hz.cell(),
            r.accel.z.vrw_ug_rt_hz.cell()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
