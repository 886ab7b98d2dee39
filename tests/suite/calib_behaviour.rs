//! How the estimator behaves around the numbers: cancellation, progress,
//! runs it cannot use, and bad data met mid-run.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

use sinscal_core::calib::sources::{SimSource, SliceSource};
use sinscal_core::calib::{estimate, CalibError, EstimateOptions, RunInfo};
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::Site;
use sinscal_core::pipeline::calibrate_file;
use sinscal_core::sim::{simulate, Noise, Scheme, SchemeRef, SimConfig};

fn short_run(scheme: Scheme) -> SimConfig {
    SimConfig {
        site: Site::new(45.0, 7.0, 200.0),
        sample_rate_hz: 20.0,
        scheme,
        params: ErrorParameters::paper(),
        effects: Effects::none(),
        noise: Noise::default_navigation_grade(),
        initial_attitude_error_deg: [0.0; 3],
        seed: 5,
        thermal: None,
        temperature: None,
    }
}

fn run_info(cfg: &SimConfig) -> RunInfo {
    RunInfo {
        site: cfg.site,
        sample_rate_hz: cfg.sample_rate_hz,
    }
}

#[test]
fn progress_rises_to_one_and_cancel_stops_the_run() {
    let cfg = short_run(Scheme::builtin("ten-position", 60.0).unwrap());
    let mut fractions = Vec::new();
    let res = estimate(
        &SimSource(cfg.clone()),
        &run_info(&cfg),
        &EstimateOptions::default(),
        &mut |p| fractions.push(p.fraction),
        &AtomicBool::new(false),
    )
    .unwrap();
    assert!(res.passes >= 2);
    assert!(
        fractions.windows(2).all(|w| w[1] >= w[0] - 1e-12),
        "progress went back"
    );
    assert_eq!(fractions.last().copied(), Some(1.0));
    assert!(res.convergence.t.len() <= 500 && !res.convergence.t.is_empty());
    assert_eq!(res.convergence.value[0].len(), 24);

    // Cancelled from the progress callback, as the server's workers do.
    let cancel = AtomicBool::new(false);
    let out = estimate(
        &SimSource(cfg.clone()),
        &run_info(&cfg),
        &EstimateOptions::default(),
        &mut |p| {
            if p.fraction > 0.3 {
                cancel.store(true, Ordering::Relaxed)
            }
        },
        &cancel,
    );
    assert!(matches!(out, Err(CalibError::Cancelled)), "{out:?}");
}

#[test]
fn a_run_that_starts_moving_is_refused_with_the_reason() {
    let scheme: SchemeRef = serde_json::from_str(
        r#"{"steps": [{"rotate": {"axis": "z", "angle_deg": 90}}, {"dwell_s": 60},
                      {"rotate": {"axis": "x", "angle_deg": 90}}, {"dwell_s": 60}]}"#,
    )
    .unwrap();
    let cfg = short_run(scheme.resolve(None).unwrap());
    let records: Vec<_> = simulate(&cfg).unwrap().collect();
    let out = estimate(
        &SliceSource(&records),
        &run_info(&cfg),
        &EstimateOptions::default(),
        &mut |_| {},
        &AtomicBool::new(false),
    );
    match out {
        Err(CalibError::Unusable(msg)) => assert!(msg.contains("begin at rest"), "{msg}"),
        other => panic!("expected Unusable, got {other:?}"),
    }
}

#[test]
fn a_few_positions_leave_parameters_flagged_as_poorly_observable() {
    // Two dwells and one turn about z cannot separate most parameters.
    let scheme: SchemeRef = serde_json::from_str(
        r#"{"steps": [{"dwell_s": 120}, {"rotate": {"axis": "z", "angle_deg": 90}}, {"dwell_s": 120}]}"#,
    )
    .unwrap();
    let cfg = short_run(scheme.resolve(None).unwrap());
    let opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    let res = estimate(
        &SimSource(cfg.clone()),
        &run_info(&cfg),
        &opts,
        &mut |_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    let poorly: Vec<_> = res
        .warnings
        .iter()
        .filter(|w| w.contains("poorly observable"))
        .collect();
    assert!(
        poorly.iter().any(|w| w.starts_with("accel_scale_x")),
        "{:?}",
        res.warnings
    );
    assert!(
        res.warnings.iter().any(|w| w.contains("only 2 dwells")),
        "{:?}",
        res.warnings
    );
}

#[test]
fn bad_data_mid_run_fails_the_calibration_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = short_run(Scheme::builtin("ten-position", 30.0).unwrap());
    let files = sinscal_core::io::run::write_simulated_run(
        &cfg,
        dir.path(),
        sinscal_core::io::data::DataFormat::Csv,
        false,
        "U-1",
    )
    .unwrap();
    // Corrupt one value far into the file.
    let text = std::fs::read_to_string(&files.data).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut fields: Vec<&str> = lines[3000].split(',').collect();
    fields[2] = "nan";
    lines[3000] = fields.join(",");
    let mut f = std::fs::File::create(&files.data).unwrap();
    f.write_all((lines.join("\n") + "\n").as_bytes()).unwrap();
    let meta = RunMetadata::from_json(&std::fs::read(&files.metadata).unwrap()).unwrap();
    let out = calibrate_file(
        &files.data,
        &meta,
        &EstimateOptions::default(),
        &mut |_| {},
        &AtomicBool::new(false),
    );
    match out {
        Err(CalibError::Source(msg)) => assert!(msg.contains("line 3001"), "{msg}"),
        other => panic!("expected a source error, got {other:?}"),
    }
}
