//! `sinscal import psins`: a PSINS SIMU log written here by the rules of
//! the toolbox's `imufile.m` (header lines with `%f`, counts with `%d`, a
//! trailing 0 on the header lines and a dither column in µs when the stamps
//! are dithered), imported and read back; and logs that break the format,
//! refused with the line named.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use sinscal_core::io::data::{DataFormat, RecordReader};
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::psins::import_psins;
use sinscal_core::model::units::ARCSEC;

const G: f64 = 9.780327;
const GYRO_SCALE: [f64; 3] = [0.1, 0.1, 0.2];
const ACCEL_SCALE: [f64; 3] = [125.0, 125.0, 100.0];

/// Counts and dither (µs) of record k.
fn counts(k: i64) -> ([i64; 6], i64) {
    (
        [
            k % 7 - 3,
            (k * 5) % 11 - 5,
            k % 3,
            -(k % 4),
            k % 2,
            80 + k % 3,
        ],
        (k * 13) % 41 - 20,
    )
}

/// The log as `imufile.m` writes it.
fn write_log(path: &Path, records: i64, dithered: bool) {
    let tail = if dithered { " 0" } else { "" };
    let mut s =
        String::from("% PSINS-format SIMU log file. (DO NOT MODIFY!)\n% written by the test\n\n");
    writeln!(
        s,
        "{:.6} {:.6} {:.6} {:.6} {:.6} {:.6}{tail}",
        0.5, -0.25, -90.6, 0.0, 0.0, 0.0
    )
    .unwrap();
    writeln!(
        s,
        "{:.8} {:.8} {:.3} {:.8} {:.8} {:.6}{tail}",
        34.246048, 108.909664, 380.0, 0.0, 10.0, G
    )
    .unwrap();
    writeln!(
        s,
        "{:.6} {:.6} {:.6} {:.3} {:.3} {:.3}{tail}\n",
        GYRO_SCALE[0], GYRO_SCALE[1], GYRO_SCALE[2], ACCEL_SCALE[0], ACCEL_SCALE[1], ACCEL_SCALE[2]
    )
    .unwrap();
    for k in 1..=records {
        let (c, d) = counts(k);
        let line: Vec<String> = c.iter().map(|v| v.to_string()).collect();
        if dithered {
            writeln!(s, "{} {d}", line.join(" ")).unwrap();
        } else {
            writeln!(s, "{}", line.join(" ")).unwrap();
        }
    }
    std::fs::write(path, s).unwrap();
}

fn sinscal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sinscal"))
}

/// Both data formats, with and without dither: every record back with its
/// stamp (t0 + kΔt + Σ dither·10⁻⁶) and its counts × scale bit for bit,
/// the site, g and rate in run.json.
#[test]
fn a_psins_log_round_trips_through_the_importer() {
    let dir = tempfile::tempdir().unwrap();
    let records = 3000;
    for (dithered, format) in [(true, "csv"), (false, "f64le")] {
        let log = dir.path().join(format!("log-{format}.imu"));
        write_log(&log, records, dithered);
        let out = dir.path().join(format!("run-{format}"));
        let status = sinscal()
            .args(["import", "psins"])
            .arg(&log)
            .arg("--out")
            .arg(&out)
            .args(["--format", format])
            .output()
            .unwrap();
        assert!(
            status.status.success(),
            "{}",
            String::from_utf8_lossy(&status.stderr)
        );
        let meta = RunMetadata::from_json(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
        assert_eq!(meta.sample_rate_hz, 100.0);
        assert_eq!(
            (meta.latitude_deg, meta.longitude_deg, meta.height_m),
            (34.246048, 108.909664, 380.0)
        );
        assert_eq!(meta.gravity_mps2, Some(G));
        assert_eq!(meta.extra["psins"]["attitude_deg"][2], -90.6);
        let data = out.join(if format == "csv" {
            "run.csv"
        } else {
            "run.bin"
        });
        let fmt: DataFormat = format.parse().unwrap();
        let reader = RecordReader::open(&data, fmt, 100.0).unwrap();
        let mut dither_us = 0i64;
        let mut n = 0;
        for (k, r) in (1..).zip(reader) {
            let r = r.unwrap();
            let (c, d) = counts(k);
            if dithered {
                dither_us += d;
            }
            let t = k as f64 * 0.01 + dither_us as f64 * 1e-6;
            assert!((r.t - t).abs() < 1e-9, "record {k}: t {} against {t}", r.t);
            for a in 0..3 {
                assert_eq!(
                    r.dtheta[a],
                    c[a] as f64 * GYRO_SCALE[a] * ARCSEC,
                    "record {k}"
                );
                assert_eq!(
                    r.dv[a],
                    c[3 + a] as f64 * ACCEL_SCALE[a] * 1e-6 * G,
                    "record {k}"
                );
            }
            n += 1;
        }
        assert_eq!(n, records);
    }
}

/// Logs that break the format: each refused with the line at fault, and
/// no data file left behind.
#[test]
fn broken_psins_logs_are_refused_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("log.imu");
    write_log(&log, 50, false);
    let text = std::fs::read_to_string(&log).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // The header's first line is line 4 (two comments, a blank line), the
    // records start at line 8.
    let cases: [(usize, &str, &str); 4] = [
        (20, "1 2 3.5 4 5 6", "not a whole count"),
        (21, "1 2 3 4 5", "5 values, 6 expected"),
        (5, "34.2 108.9 380 0 -10 9.78", "sampling interval -10 ms"),
        (6, "0.1 0.1 0.1 125 0 125", "every scale must be positive"),
    ];
    for (line, replacement, message) in cases {
        let mut broken = lines.clone();
        broken[line - 1] = replacement;
        let path = dir.path().join(format!("broken-{line}.imu"));
        std::fs::write(&path, broken.join("\n")).unwrap();
        let out = dir.path().join(format!("out-{line}"));
        let err = import_psins(&path, &out, DataFormat::Csv, "PSINS-T")
            .expect_err("refused")
            .to_string();
        assert!(err.contains(&format!("line {line}:")), "{err}");
        assert!(err.contains(message), "{err}");
        assert!(!out.join("run.csv").exists(), "{err}");
    }
    let short = dir.path().join("short.imu");
    std::fs::write(&short, lines[..5].join("\n")).unwrap();
    let err = import_psins(&short, &dir.path().join("o"), DataFormat::Csv, "PSINS-T")
        .expect_err("refused")
        .to_string();
    assert!(
        err.contains("ends before the header line of scales"),
        "{err}"
    );
}
