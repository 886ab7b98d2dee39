//! `sinscal diagnose` end to end: a run simulated by the binary with an
//! accelerometer delay is diagnosed by the binary; its summary, JSON
//! report and gap plot say the same thing. A missing run file is refused
//! with a message, not a panic.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;
use sinscal_core::io::meta::{read_json, Truth};
use sinscal_core::model::PARAMETERS;

fn sinscal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sinscal"))
}

fn succeeded(output: &Output) -> bool {
    if !output.status.success() {
        eprintln!(
            "exit {:?}\nstdout:\n{}\nstderr:\n{}",
            output.status,
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
    output.status.success()
}

fn number(v: &Value, what: &str) -> f64 {
    let x = v
        .as_f64()
        .unwrap_or_else(|| panic!("{what} is not a number: {v}"));
    assert!(x.is_finite(), "{what} = {x}");
    x
}

/// Equal up to the last digits a JSON number round trip may move.
fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
}

fn assert_svg(path: &Path) {
    let text =
        std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let head = text.trim_start();
    assert!(
        head.starts_with("<svg") || head.starts_with("<?xml"),
        "{} starts with {:?}",
        path.display(),
        &head[..head.len().min(80)]
    );
    assert!(
        text.trim_end().ends_with("</svg>"),
        "{} is cut short",
        path.display()
    );
}

#[test]
fn diagnose_names_an_accelerometer_delay() {
    let dir = tempfile::tempdir().unwrap();
    let effects_path = dir.path().join("effects.json");
    std::fs::write(&effects_path, r#"{"accel_delay": 2.0}"#).unwrap();
    let run_dir = dir.path().join("run");
    // The paper's 9+9 scheme with 30 s dwells at 20 Hz (under a second of
    // work): each turn still moves the velocity by far more than the
    // noise when the accelerometers lag the gyros by 2 ms.
    let output = sinscal()
        .args(["simulate", "--scheme", "ten-position-9+9", "--dwell", "30"])
        .args(["--params", "paper", "--seed", "1", "--rate", "20"])
        .args(["--serial", "CLI-DIAG-1", "--format", "f64le", "--effects"])
        .arg(&effects_path)
        .arg("--out")
        .arg(&run_dir)
        .output()
        .unwrap();
    assert!(succeeded(&output), "simulate failed");
    let truth: Truth = read_json(&run_dir.join("truth.json")).unwrap();
    let true_delay = truth
        .effects
        .accel_delay
        .expect("the truth carries the delay");

    let report_path = dir.path().join("report.json");
    let svg_path = dir.path().join("gap.svg");
    let output = sinscal()
        .arg("diagnose")
        .arg(run_dir.join("run.bin"))
        .arg("--meta")
        .arg(run_dir.join("run.json"))
        .arg("--out")
        .arg(&report_path)
        .arg("--svg")
        .arg(&svg_path)
        .output()
        .unwrap();
    assert!(succeeded(&output), "diagnose failed");

    let stdout = String::from_utf8(output.stdout).unwrap();
    assert_eq!(stdout.lines().next(), Some("unit CLI-DIAG-1"), "{stdout}");
    let verdict_line = stdout
        .lines()
        .find(|l| l.starts_with("verdict:"))
        .unwrap_or_else(|| panic!("no verdict in\n{stdout}"));
    assert!(verdict_line.contains("accel_delay"), "{verdict_line}");
    assert!(stdout.contains("gap RMS"), "{stdout}");
    assert!(stdout.contains("final calibration:"), "{stdout}");

    let report: Value = read_json(&report_path).unwrap();
    assert_eq!(report["named"], serde_json::json!(["accel_delay"]));
    assert_eq!(
        report["verdict"].as_str().map(|v| format!("verdict: {v}")),
        Some(verdict_line.to_string())
    );
    let before = number(&report["gap_rms_before"], "gap_rms_before");
    let after = number(&report["gap_rms_after"], "gap_rms_after");
    let floor = number(&report["noise_floor_rms"], "noise_floor_rms");
    assert!(floor > 0.0, "noise floor {floor}");
    assert!(after < before, "gap RMS {before:.3e} -> {after:.3e} m/s");
    assert!(
        after <= 1.2 * floor,
        "gap after {after:.3e} m/s above 1.2x the floor {floor:.3e}"
    );

    // The final calibration: the 24 base parameters and the delay, each
    // with a 1-sigma.
    let cal = &report["calibration"];
    let params = cal["parameters"].as_object().unwrap();
    assert_eq!(params.len(), PARAMETERS.len());
    for info in PARAMETERS.iter() {
        let p = &params[info.name];
        number(&p["value"], info.name);
        assert!(number(&p["sigma"], info.name) > 0.0, "{}: {p}", info.name);
        assert_eq!(p["unit"], info.unit, "{}", info.name);
    }
    let effects = cal["effects"].as_object().unwrap();
    assert_eq!(
        effects.keys().collect::<Vec<_>>(),
        ["accel_delay"],
        "{effects:?}"
    );
    let delay = &effects["accel_delay"];
    assert_eq!(delay["unit"], "ms");
    let (tau, sigma) = (
        number(&delay["value"], "accel_delay"),
        number(&delay["sigma"], "accel_delay sigma"),
    );
    assert!(sigma > 0.0);
    assert!(
        (tau - true_delay).abs() < 3.0 * sigma,
        "delay {tau:.4} ± {sigma:.4} ms, truth {true_delay} ms"
    );
    assert!(
        cal["model"].as_str().unwrap().contains("accel_delay"),
        "{}",
        cal["model"]
    );
    // The effect in SPEC §3 form is the fitted one.
    assert!(same(
        number(&report["effects"]["accel_delay"], "effects"),
        tau
    ));
    assert_eq!(
        report["base_calibration"]["parameters"]
            .as_object()
            .unwrap()
            .len(),
        PARAMETERS.len()
    );

    // Steps: the first names the delay from the base model's gap, the
    // last finds nothing further; their gaps are the report's before and
    // after.
    let steps = report["steps"].as_array().unwrap();
    assert!(steps.len() >= 2, "{} steps", steps.len());
    let first = &steps[0];
    assert_eq!(first["model"], serde_json::json!([]));
    assert_eq!(first["named"], "accel_delay");
    assert!(same(number(&first["gap_rms"], "step 1 gap"), before));
    let last = steps.last().unwrap();
    assert_eq!(last["model"], serde_json::json!(["accel_delay"]));
    assert!(last["named"].is_null(), "{}", last["named"]);
    assert!(same(number(&last["gap_rms"], "last step gap"), after));
    for (i, s) in steps.iter().enumerate() {
        for key in ["gap_rms", "noise_floor_rms", "chi2", "dof", "z"] {
            number(&s[key], &format!("step {} {key}", i + 1));
        }
        assert!(
            !s["decision"].as_str().unwrap().is_empty(),
            "step {} has no decision",
            i + 1
        );
        let candidates = s["candidates"].as_array().unwrap();
        assert!(!candidates.is_empty(), "step {} scored nothing", i + 1);
        for c in candidates {
            number(&c["delta_bic"], "delta_bic");
            number(&c["probability"], "probability");
        }
    }
    let best = first["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .max_by(|a, b| number(&a["delta_bic"], "a").total_cmp(&number(&b["delta_bic"], "b")))
        .unwrap();
    assert_eq!(best["effect"], "accel_delay", "{best}");

    assert_svg(&svg_path);
}

#[test]
fn diagnose_of_a_missing_run_file_fails_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let meta_path = dir.path().join("run.json");
    std::fs::write(
        &meta_path,
        r#"{"unit_serial": "CLI-DIAG-2", "sample_rate_hz": 20, "latitude_deg": 28.2215,
            "longitude_deg": 112.9924, "height_m": 50, "format": "f64le"}"#,
    )
    .unwrap();
    let missing = dir.path().join("run.bin");
    let report_path = dir.path().join("report.json");
    let output = sinscal()
        .arg("diagnose")
        .arg(&missing)
        .arg("--meta")
        .arg(&meta_path)
        .arg("--out")
        .arg(&report_path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    // Exit code 101 is Rust's panic; a signal gives no code at all.
    let code = output.status.code();
    assert!(
        matches!(code, Some(c) if c != 0 && c != 101),
        "exit {code:?}\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains(&missing.display().to_string()),
        "the error does not name the file:\n{stderr}"
    );
    assert!(stderr.contains("cannot open"), "{stderr}");
    assert!(!report_path.exists(), "a report was written for no run");
}
