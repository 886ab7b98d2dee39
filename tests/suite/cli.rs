//! The `sinscal` binary end to end: simulate from a truth file, read the
//! run back, calibrate it, plan a scheme.

use std::process::Command;

use sinscal_core::io::data::{DataFormat, RecordReader};
use sinscal_core::io::meta::{read_json, RunMetadata, Truth};
use sinscal_core::sim::simulate;

/// Runs `cmd`, which must succeed (its stderr shown if not), and returns
/// what it printed.
fn stdout_of(cmd: &mut Command) -> String {
    let output = cmd.output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

fn sinscal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sinscal"))
}

#[test]
fn simulate_from_truth_writes_the_run_the_truth_describes() {
    let dir = tempfile::tempdir().unwrap();
    let truth_path = dir.path().join("in.json");
    std::fs::write(
        &truth_path,
        r#"{"sample_rate_hz": 50, "latitude_deg": 28.2215, "longitude_deg": 112.9924, "height_m": 50,
            "parameters": {"gyro_bias_x": 0.05, "gyro_bias_y": -0.03, "gyro_bias_z": 0.01,
              "gyro_scale_x": 500, "gyro_scale_y": -300, "gyro_scale_z": 100,
              "gyro_misalign_xy": 200, "gyro_misalign_xz": -100, "gyro_misalign_yz": 50,
              "accel_bias_x": 200, "accel_bias_y": -100, "accel_bias_z": 50,
              "accel_scale_x": 500, "accel_scale_y": 300, "accel_scale_z": -200,
              "accel_misalign_xy": 200, "accel_misalign_xz": 100, "accel_misalign_yx": -100,
              "accel_misalign_yz": 50, "accel_misalign_zx": 20, "accel_misalign_zy": -20,
              "accel_quad_x": 490, "accel_quad_y": 100, "accel_quad_z": -50},
            "noise": {"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5},
            "effects": {"accel_delay": 1.0},
            "initial_attitude_error_deg": [0.1, -0.1, 2.0],
            "scheme": {"name": "short", "steps": [{"dwell_s": 30}, {"rotate": {"axis": "y", "angle_deg": 90}}, {"dwell_s": 30}]},
            "seed": 9}"#,
    )
    .unwrap();
    let out = dir.path().join("run");
    let status = sinscal()
        .args(["simulate", "--truth"])
        .arg(&truth_path)
        .arg("--out")
        .arg(&out)
        .args(["--gzip"])
        .status()
        .unwrap();
    assert!(status.success());
    let truth: Truth = read_json(&out.join("truth.json")).unwrap();
    let meta: RunMetadata = read_json(&out.join("run.json")).unwrap();
    assert_eq!(meta.sample_rate_hz, 50.0);
    assert_eq!(meta.format, DataFormat::Csv);
    // The records on disk are those the library simulates from the truth
    // written beside them, to the last bit.
    let expected: Vec<_> = simulate(&truth.to_sim_config().unwrap()).unwrap().collect();
    let reader = RecordReader::open(out.join("run.csv.gz"), DataFormat::Csv, 50.0).unwrap();
    assert!(reader.is_gzip());
    let got: Vec<_> = reader.collect::<Result<_, _>>().unwrap();
    assert_eq!(got.len(), expected.len());
    assert_eq!(got, expected);
    // 30 + 9.5 + 30 s at 50 Hz.
    assert_eq!(got.len(), 3475);
}

#[test]
fn calibrate_prints_the_table_and_writes_the_result() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let status = sinscal()
        .args([
            "simulate",
            "--scheme",
            "ten-position",
            "--dwell",
            "60",
            "--params",
            "random",
            "--seed",
            "4",
        ])
        .args(["--rate", "20", "--format", "f64le", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let result_path = dir.path().join("result.json");
    let table = stdout_of(
        sinscal()
            .arg("calibrate")
            .arg(out.join("run.bin"))
            .arg("--out")
            .arg(&result_path),
    );
    for name in ["gyro_bias_x", "accel_misalign_zy", "accel_quad_z"] {
        assert!(table.contains(name), "{table}");
    }
    assert!(table.contains("ug/g^2") && table.contains("arcsec"));
    assert!(table.contains("model check: adequate"), "{table}");
    let result: serde_json::Value = read_json(&result_path).unwrap();
    let p = &result["parameters"]["gyro_scale_x"];
    assert_eq!(p["unit"], "ppm");
    assert!(p["sigma"].as_f64().unwrap() > 0.0);
    assert_eq!(result["model_check"]["adequate"], true);
    assert!(result["model_check"]["threshold"].as_f64().unwrap() > 0.0);
}

/// A run the 24-parameter model cannot explain (a 2 ms accelerometer
/// delay) is calibrated, and the table says so and what to do.
#[test]
fn calibrate_says_when_the_model_does_not_explain_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let effects = dir.path().join("effects.json");
    std::fs::write(&effects, r#"{"accel_delay": 2.0}"#).unwrap();
    let out = dir.path().join("run");
    let status = sinscal()
        .args(["simulate", "--scheme", "ten-position", "--dwell", "60"])
        .args(["--params", "paper", "--seed", "5", "--rate", "20"])
        .arg("--effects")
        .arg(&effects)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let output = sinscal()
        .arg("calibrate")
        .arg(out.join("run.csv"))
        .output()
        .unwrap();
    assert!(output.status.success());
    let table = String::from_utf8(output.stdout).unwrap();
    assert!(table.contains("model check: inadequate"), "{table}");
    assert!(table.contains("velocity step across the turn"), "{table}");
    assert!(table.contains("run `sinscal diagnose`"), "{table}");

    // The same run with the delay in the model: estimated, and the model
    // explains the run.
    let table = stdout_of(
        sinscal()
            .arg("calibrate")
            .arg(out.join("run.csv"))
            .args(["--model", "base+accel_delay"]),
    );
    assert!(table.contains("base-24+accel_delay"), "{table}");
    assert!(table.contains("model check: adequate"), "{table}");
    let line = table
        .lines()
        .find(|l| l.starts_with("accel_delay"))
        .unwrap();
    let value: f64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!((value - 2.0).abs() < 0.05, "{line}");

    let output = sinscal()
        .arg("calibrate")
        .arg(out.join("run.csv"))
        .args(["--model", "base+accel_dleay"])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(err.contains("not a SPEC §3 effect"), "{err}");
}

#[test]
fn plan_says_what_a_run_of_the_scheme_would_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan.json");
    let text = stdout_of(
        sinscal()
            .args(["plan", "--scheme", "ten-position", "--dwell", "120"])
            .args(["--rate", "20", "--detect", "--out"])
            .arg(&out),
    );
    let line = text
        .lines()
        .find(|l| l.starts_with("a run of this scheme would name "))
        .unwrap_or_else(|| panic!("{text}"));
    for quantity in [
        "lever arm",
        "delay ≥",
        "g-sensitivity",
        "gyro drift",
        "asymmetry",
    ] {
        assert!(line.contains(quantity), "{line}");
    }
    let plan: serde_json::Value = read_json(&out).unwrap();
    let detectable = plan["detectable"].as_array().unwrap();
    assert!(detectable.len() >= 6);
    assert!(detectable.iter().all(|t| t["size"].as_f64().unwrap() > 0.0));
}

/// `plan` of `ten-position` with 120 s dwells at 20 Hz.
const PLAN_TEN_POSITION: [&str; 7] = [
    "plan",
    "--scheme",
    "ten-position",
    "--dwell",
    "120",
    "--rate",
    "20",
];

#[test]
fn plan_prints_a_sigma_for_every_parameter() {
    let text = stdout_of(sinscal().args(PLAN_TEN_POSITION));
    assert_eq!(
        text.lines()
            .filter(|l| l.starts_with("gyro_") || l.starts_with("accel_"))
            .count(),
        24,
        "{text}"
    );
}

/// `plan` with a real sensor's terms (SPEC §2a, `simulate`'s flag names)
/// predicts what its wander costs: an accelerometer bias that wanders by
/// 5 µg is known to no better than its wander allows, far worse than
/// white noise alone lets it; a negative term is refused naming its flag.
#[test]
fn plan_predicts_a_real_sensors_sigma() {
    let sigma_of = |text: &str, name: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("{text}"));
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    let base = PLAN_TEN_POSITION;
    let white = stdout_of(sinscal().args(base));
    let real = stdout_of(sinscal().args(base).args([
        "--accel-bias-instability",
        "5",
        "--gyro-bias-instability",
        "0.002",
        "--accel-quantum",
        "1e-4",
    ]));
    let (w, r) = (
        sigma_of(&white, "accel_bias_x"),
        sigma_of(&real, "accel_bias_x"),
    );
    assert!(
        r > 2.0 * w,
        "accel_bias_x σ {r} µg with wander, {w} µg white"
    );
    let refused = sinscal().args(base).arg("--gyro-rrw=-1").output().unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--gyro-rrw"));
}

#[test]
fn simulate_refuses_half_given_options() {
    let output = sinscal()
        .args(["simulate", "--scheme", "ten-position", "--out", "/tmp/x"])
        .output()
        .unwrap();
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("--params"));
}

/// `--attitude-error x,y,z` is one value: it may stand anywhere, a negative
/// first component included, and a wrong count is refused.
#[test]
fn simulate_takes_the_attitude_error_anywhere_on_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let status = sinscal()
        .args([
            "simulate",
            "--scheme",
            "ten-position",
            "--dwell",
            "20",
            "--params",
            "paper",
        ])
        .args(["--attitude-error", "-0.1,0.2,3", "--serial", "ATT-1"])
        .args(["--rate", "10", "--format", "f64le", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let truth: Truth = read_json(&out.join("truth.json")).unwrap();
    assert_eq!(truth.initial_attitude_error_deg, [-0.1, 0.2, 3.0]);
    let meta: RunMetadata = read_json(&out.join("run.json")).unwrap();
    assert_eq!(meta.unit_serial, "ATT-1");

    let bad = sinscal()
        .args(["simulate", "--attitude-error", "1,2", "--out"])
        .arg(dir.path().join("bad"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("expected x,y,z, got 2 numbers"));
}

/// `export` writes the compensation file (JSON and CSV); `compensate`
/// applies a result or that file to the run, streaming, into a run of the
/// contract with as many records, and refuses to overwrite its input or to
/// apply another unit's file.
#[test]
fn compensate_and_export_write_files_the_readers_take() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let status = sinscal()
        .args(["simulate", "--scheme", "ten-position", "--dwell", "60"])
        .args(["--params", "random", "--seed", "6", "--rate", "20"])
        .args(["--format", "f64le", "--serial", "RLG-7", "--out"])
        .arg(&run)
        .status()
        .unwrap();
    assert!(status.success());
    let data = run.join("run.bin");
    let result = dir.path().join("result.json");
    stdout_of(
        sinscal()
            .arg("calibrate")
            .arg(&data)
            .arg("--out")
            .arg(&result),
    );
    let comp_json = dir.path().join("comp.json");
    let comp_csv = dir.path().join("comp.csv");
    for out in [&comp_json, &comp_csv] {
        stdout_of(
            sinscal()
                .arg("export")
                .arg(&result)
                .args(["--serial", "RLG-7", "--out"])
                .arg(out),
        );
    }
    let file: serde_json::Value = read_json(&comp_json).unwrap();
    assert_eq!(file["format"], "sinscal-compensation");
    assert_eq!(file["provenance"]["unit_serial"], "RLG-7");
    assert_eq!(file["gyro"]["scale_misalignment"][1][0], 0.0);
    let csv = std::fs::read_to_string(&comp_csv).unwrap();
    assert_eq!(csv.lines().filter(|l| !l.starts_with('#')).count(), 25);

    let records = RecordReader::open(&data, DataFormat::F64le, 20.0)
        .unwrap()
        .count();
    // From the result, to CSV; from the file, to f64le.
    for (source, out, format) in [
        (
            &result,
            dir.path().join("a").join("run.csv"),
            DataFormat::Csv,
        ),
        (
            &comp_json,
            dir.path().join("b").join("run.bin"),
            DataFormat::F64le,
        ),
    ] {
        std::fs::create_dir_all(out.parent().unwrap()).unwrap();
        stdout_of(
            sinscal()
                .arg("compensate")
                .arg(source)
                .arg(&data)
                .args(["--format", format.as_str(), "--out"])
                .arg(&out),
        );
        let meta: RunMetadata = read_json(&out.with_file_name("run.json")).unwrap();
        assert_eq!(meta.format, format);
        assert_eq!(meta.unit_serial, "RLG-7");
        assert!(meta.extra["compensation"]["gyro"]["bias_rad_per_s"].is_array());
        let reader = RecordReader::open(&out, format, 20.0).unwrap();
        let got: Vec<_> = reader.collect::<Result<_, _>>().unwrap();
        assert_eq!(got.len(), records);
    }

    // Beside the run, run.csv's sidecar would be the run's own run.json.
    let refused = sinscal()
        .arg("compensate")
        .arg(&result)
        .arg(&data)
        .arg("--out")
        .arg(run.join("run.csv"))
        .output()
        .unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("would overwrite"));
    let meta: RunMetadata = read_json(&run.join("run.json")).unwrap();
    assert!(!meta.extra.contains_key("compensation"));

    // Another unit's file is refused unless asked for.
    let other = dir.path().join("other.json");
    stdout_of(
        sinscal()
            .arg("export")
            .arg(&result)
            .args(["--serial", "RLG-8", "--out"])
            .arg(&other),
    );
    let out = dir.path().join("c").join("run.bin");
    std::fs::create_dir_all(out.parent().unwrap()).unwrap();
    let refused = sinscal()
        .arg("compensate")
        .arg(&other)
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("unit RLG-8's"));
    assert!(!out.exists());
    stdout_of(
        sinscal()
            .arg("compensate")
            .arg(&other)
            .arg(&data)
            .args(["--any-unit", "--out"])
            .arg(&out),
    );
}

/// `sinscal thermal` over results that carry their soak temperature (one
/// given as `RESULT.json@T` instead): the model written, a linear term
/// recovered exactly from exact values, the range and the prediction
/// printed; a result with no temperature refused with the way out named.
#[test]
fn thermal_fits_results_at_their_temperatures() {
    use sinscal_core::calib::result::RunTemperature;
    use sinscal_core::calib::{CalibrationResult, ParameterEstimate};
    use sinscal_core::model::PARAMETERS;
    let dir = tempfile::tempdir().unwrap();
    let mut args = Vec::new();
    for (k, t) in [0.0, 25.0, 50.0].into_iter().enumerate() {
        let result = CalibrationResult {
            parameters: PARAMETERS
                .iter()
                .map(|p| {
                    let e = ParameterEstimate {
                        value: 10.0 + 0.1 * (t - 25.0),
                        sigma: 0.01,
                        unit: p.unit.to_string(),
                    };
                    (p.name.to_string(), e)
                })
                .collect(),
            temperature: (k < 2).then(|| RunTemperature::soaked(t)),
            ..CalibrationResult::default()
        };
        let path = dir.path().join(format!("r{k}.json"));
        std::fs::write(&path, serde_json::to_vec(&result).unwrap()).unwrap();
        args.push(path.display().to_string());
    }
    let out = dir.path().join("model.json");
    // The third carries no temperature.
    let refused = sinscal()
        .arg("thermal")
        .args(&args)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("carries no temperature") && err.contains("@T"),
        "{err}"
    );
    args[2].push_str("@50");
    let compensation = dir.path().join("compensation.csv");
    let text = stdout_of(
        sinscal()
            .arg("thermal")
            .args(&args)
            .args(["--at", "40", "--out"])
            .arg(&out)
            .arg("--compensation")
            .arg(&compensation),
    );
    // The model as a compensation file: 0.1 deg/h per °C on gyro_bias_x.
    let csv = std::fs::read_to_string(&compensation).unwrap();
    let slope = 0.1 * std::f64::consts::PI / 180.0 / 3600.0;
    let row = csv
        .lines()
        .find(|l| l.starts_with("gyro_bias_x.linear,b_g[0]/degC,"))
        .unwrap_or_else(|| panic!("{csv}"));
    let value: f64 = row.split(',').nth(2).unwrap().parse().unwrap();
    assert!((value / slope - 1.0).abs() < 1e-9, "{row}");
    assert!(
        text.contains("fitted over 0.0–50.0 °C from 3 runs"),
        "{text}"
    );
    assert!(text.contains("at 40 °C:"), "{text}");
    let model: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let p = &model["parameters"]["gyro_bias_x"];
    assert!((p["value"].as_f64().unwrap() - 10.0).abs() < 1e-9, "{p}");
    assert!(
        (p["linear"]["value"].as_f64().unwrap() - 0.1).abs() < 1e-9,
        "{p}"
    );
    assert!(p.get("quadratic").is_none(), "{p}");
    assert_eq!(model["range_c"], serde_json::json!([0.0, 50.0]));
    assert_eq!(model["check"]["adequate"], true);
}

#[test]
fn simulate_writes_a_ramp_as_the_temp_c_column_and_a_soak_as_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let thermal = dir.path().join("thermal.json");
    std::fs::write(
        &thermal,
        r#"{"thermal": {"linear": {"gyro_bias_x": 0.01, "accel_bias_z": 5}, "gyro_bias_rate": [0.02, 0, 0]},
            "temperature": {"start_c": 20, "rate_c_per_min": 0.5, "max_c": 21}}"#,
    )
    .unwrap();
    let base = [
        "simulate",
        "--scheme",
        "ten-position",
        "--dwell",
        "20",
        "--params",
        "paper",
        "--rate",
        "20",
    ];
    for format in ["csv", "f64le"] {
        let out = dir.path().join(format!("ramp-{format}"));
        stdout_of(
            sinscal()
                .args(base)
                .args(["--format", format, "--thermal"])
                .arg(&thermal)
                .arg("--out")
                .arg(&out),
        );
        let meta: RunMetadata = read_json(&out.join("run.json")).unwrap();
        assert_eq!(meta.temperature_c, None);
        assert_eq!(meta.temperature_column, format == "f64le");
        let truth: Truth = read_json(&out.join("truth.json")).unwrap();
        assert!(truth.thermal.is_some() && truth.temperature.is_some());
        let data = out.join(if format == "csv" {
            "run.csv"
        } else {
            "run.bin"
        });
        let mut reader = RecordReader::open(&data, meta.format, 20.0)
            .unwrap()
            .with_temperature_column(meta.temperature_column);
        let got: Vec<_> = reader.by_ref().collect::<Result<_, _>>().unwrap();
        // The truth states the parameters in canonical units, so the
        // records it gives agree with the run to rounding, not to the bit.
        let expected: Vec<_> = simulate(&truth.to_sim_config().unwrap()).unwrap().collect();
        assert_eq!(got.len(), expected.len());
        for (a, b) in got.iter().zip(&expected) {
            assert_eq!(a.t, b.t);
            for i in 0..3 {
                assert!((a.dtheta[i] - b.dtheta[i]).abs() < 1e-15, "{a:?} {b:?}");
                assert!((a.dv[i] - b.dv[i]).abs() < 1e-13, "{a:?} {b:?}");
            }
        }
        let s = reader.temperature_summary().unwrap();
        assert!((s.min_c - (20.0 + 0.5 / 60.0 * 0.05)).abs() < 1e-12);
        assert_eq!(s.max_c, 21.0);
        // Two 60 s windows inside the 120 s ramp see its rate.
        let rate = s.max_rate_c_per_min.unwrap();
        assert!((rate - 0.5).abs() < 1e-9, "{rate}");
    }
    let out = dir.path().join("soak");
    stdout_of(
        sinscal()
            .args(base)
            .args(["--temperature-c", "-20"])
            .arg("--out")
            .arg(&out),
    );
    let meta: RunMetadata = read_json(&out.join("run.json")).unwrap();
    assert_eq!(meta.temperature_c, Some(-20.0));
    assert!(!meta.temperature_column);
    let header = std::fs::read_to_string(out.join("run.csv")).unwrap();
    assert!(header.contains("\nt,dthx,dthy,dthz,dvx,dvy,dvz\n"));
}

/// A run with a `temp_c` column (a chamber ramp, CSV and f64le) is
/// calibrated with its temperature summary in the result: start, end and
/// the ramp's rate, and, as it spans 4 °C, a proposal of the thermal
/// states, which `--thermal` then estimates into a SPEC §3a object. A
/// soak's result carries its metadata temperature, and `--thermal` on it
/// is refused with the reason.
#[test]
fn calibrate_keeps_the_run_s_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let thermal = dir.path().join("thermal.json");
    std::fs::write(
        &thermal,
        r#"{"temperature": {"start_c": 10, "rate_c_per_min": 1.0, "max_c": 14}}"#,
    )
    .unwrap();
    for (format, file) in [("csv", "run.csv"), ("f64le", "run.bin")] {
        let out = dir.path().join(format);
        stdout_of(
            sinscal()
                .args(["simulate", "--scheme", "ten-position", "--dwell", "30"])
                .args(["--params", "paper", "--rate", "20", "--format", format])
                .arg("--thermal")
                .arg(&thermal)
                .arg("--out")
                .arg(&out),
        );
        let result = out.join("result.json");
        stdout_of(
            sinscal()
                .arg("calibrate")
                .arg(out.join(file))
                .arg("--out")
                .arg(&result),
        );
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&result).unwrap()).unwrap();
        let t = &r["temperature"];
        assert!(
            (t["min_c"].as_f64().unwrap() - 10.0).abs() < 0.01,
            "{format}: {t}"
        );
        assert!(
            (t["max_c"].as_f64().unwrap() - 14.0).abs() < 0.01,
            "{format}: {t}"
        );
        let rate = t["max_rate_c_per_min"].as_f64().unwrap();
        assert!((rate - 1.0).abs() < 0.05, "{format}: {t}");
        let proposed = r["warnings"].as_array().unwrap().iter().any(|w| {
            let w = w.as_str().unwrap();
            w.contains("spanned 4.0 °C") && w.contains("--thermal")
        });
        assert!(proposed, "{format}: {}", r["warnings"]);
        assert!(r.get("thermal").is_none());

        let table = stdout_of(
            sinscal()
                .arg("calibrate")
                .arg(out.join(file))
                .arg("--thermal")
                .arg("--out")
                .arg(&result),
        );
        assert!(table.contains("gyro_bias_rate_x"), "{table}");
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&result).unwrap()).unwrap();
        assert_eq!(r["model"], "base-24+thermal");
        let th = &r["thermal"];
        let lo = th["range_c"][0].as_f64().unwrap();
        assert!((lo - 10.0).abs() < 0.01, "{format}: {th}");
        assert!(th["gyro_bias_rate"]["z"]["sigma"].as_f64().unwrap() > 0.0);
        let bias = &th["parameters"]["accel_bias_x"];
        assert_eq!(bias["unit"], "ug");
        assert!(bias["linear"]["sigma"].as_f64().unwrap() > 0.0);
        assert_eq!(bias["covariance"].as_array().unwrap().len(), 4);
        assert!(th["parameters"]["accel_quad_x"].get("linear").is_none());
    }
    let soak = dir.path().join("soak");
    stdout_of(
        sinscal()
            .args(["simulate", "--scheme", "ten-position", "--dwell", "30"])
            .args(["--params", "paper", "--rate", "20", "--temperature-c", "-5"])
            .arg("--out")
            .arg(&soak),
    );
    let result = soak.join("result.json");
    stdout_of(
        sinscal()
            .arg("calibrate")
            .arg(soak.join("run.csv"))
            .arg("--out")
            .arg(&result),
    );
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&result).unwrap()).unwrap();
    assert_eq!(r["temperature"]["mean_c"], -5.0);
    assert_eq!(r["temperature"]["max_rate_c_per_min"], 0.0);
    let refused = sinscal()
        .arg("calibrate")
        .arg(soak.join("run.csv"))
        .arg("--thermal")
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("no temperature column") && err.contains("sinscal thermal"),
        "{err}"
    );
}

/// A unit whose noise is known beforehand (characterised once) is
/// calibrated under that model as given, term for term; a noise file with
/// a term the estimator does not have is refused naming it.
#[test]
fn calibrate_takes_a_units_known_noise_model() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    stdout_of(
        sinscal()
            .args(["simulate", "--scheme", "ten-position", "--dwell", "60"])
            .args(["--params", "paper", "--seed", "5", "--rate", "20"])
            .args(["--real-sensor", "--format", "f64le", "--out"])
            .arg(&out),
    );
    let noise = dir.path().join("noise.json");
    std::fs::write(
        &noise,
        r#"{"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5,
            "gyro_bias_instability_deg_h": 0.002, "accel_bias_instability_ug": 3,
            "gyro_rrw_deg_h_rt_h": 0.0003, "accel_rw_ug_rt_h": 3,
            "gyro_quantum_arcsec": 1, "accel_quantum_mps": 1e-4}"#,
    )
    .unwrap();
    let result_path = dir.path().join("result.json");
    // The run calibrated with the noise file under `flag`: its result.
    let calibrated_with = |flag: &str| -> serde_json::Value {
        stdout_of(
            sinscal()
                .arg("calibrate")
                .arg(out.join("run.bin"))
                .arg(flag)
                .arg(&noise)
                .arg("--out")
                .arg(&result_path),
        );
        read_json(&result_path).unwrap()
    };
    let result = calibrated_with("--noise");
    let model = &result["noise_model"];
    assert_eq!(model["source"], "given", "{model}");
    for (term, value) in [
        ("gyro_bias_instability_deg_h", 0.002),
        ("accel_rw_ug_rt_h", 3.0),
        ("gyro_quantum_arcsec", 1.0),
    ] {
        for axis in model[term].as_array().unwrap_or_else(|| panic!("{model}")) {
            let v = axis.as_f64().unwrap();
            assert!((v / value - 1.0).abs() < 1e-9, "{term}: {v}");
        }
    }
    // Held instead of given: the run's own model is fitted and the held
    // one tested against it, over the fit's six terms.
    let result = calibrated_with("--noise-reference");
    let model = &result["noise_model"];
    assert_eq!(model["source"], "fitted", "{model}");
    let test = &model["reference"];
    assert_eq!(test["degrees_of_freedom"], 6, "{model}");
    let (statistic, threshold) = (
        test["statistic"].as_f64().unwrap(),
        test["threshold"].as_f64().unwrap(),
    );
    assert!(
        statistic.is_finite() && (16.0..17.5).contains(&threshold),
        "{test}"
    );
    assert_eq!(test["consistent"], statistic <= threshold, "{test}");
    // Refused for asking both, not for a file it could not read.
    let both = sinscal()
        .arg("calibrate")
        .arg(out.join("run.bin"))
        .arg("--noise")
        .arg(&noise)
        .arg("--noise-reference")
        .arg(&noise)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&both.stderr);
    assert!(
        !both.status.success() && stderr.contains("cannot be used with"),
        "--noise with --noise-reference: {stderr}"
    );
    std::fs::write(
        &noise,
        r#"{"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5, "gyro_bias_instabilty_deg_h": 0.002}"#,
    )
    .unwrap();
    let refused = sinscal()
        .arg("calibrate")
        .arg(out.join("run.bin"))
        .arg("--noise")
        .arg(&noise)
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("gyro_bias_instabilty_deg_h"), "{stderr}");
}
