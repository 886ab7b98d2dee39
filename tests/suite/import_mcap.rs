//! `sinscal import mcap`: a ROS 2 recording written here byte by byte by
//! the MCAP specification (unchunked, as a minimal recorder writes it, so
//! the file does not come from the crate that reads it), with Imu messages
//! in little-endian CDR; imported by the binary, read back as a run and
//! analysed by `sinscal noise`; and a topic that is not there, refused.

use std::path::Path;
use std::process::{Command, Output};

use sinscal_core::io::data::{DataFormat, RecordReader};
use sinscal_core::io::meta::RunMetadata;

const RATE_HZ: u32 = 200;
const MESSAGES: u32 = 6000;
const START_NS: u64 = 1_714_000_000_000_000_000;

fn sinscal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sinscal"))
}

fn string(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

/// An MCAP record: opcode, body length (u64), body.
fn record(out: &mut Vec<u8>, opcode: u8, body: &[u8]) {
    out.push(opcode);
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
}

/// A deterministic noise in [−0.5, 0.5) (a 64-bit mix of `k`).
fn noise(k: u64) -> f64 {
    let mut x = k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 29;
    (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// Message k of a unit at rest, x east, y north, z up: Earth rate, g up.
fn sample(k: u32) -> ([f64; 3], [f64; 3]) {
    let n = |axis: u64| noise(6 * u64::from(k) + axis);
    (
        [1e-4 * n(0), 6.4e-5 + 1e-4 * n(1), 3.4e-5 + 1e-4 * n(2)],
        [2e-3 * n(3), 2e-3 * n(4), 9.79 + 2e-3 * n(5)],
    )
}

fn imu_cdr(stamp_ns: u64, w: [f64; 3], f: [f64; 3]) -> Vec<u8> {
    let mut b = vec![0, 1, 0, 0];
    b.extend_from_slice(&((stamp_ns / 1_000_000_000) as i32).to_le_bytes());
    b.extend_from_slice(&((stamp_ns % 1_000_000_000) as u32).to_le_bytes());
    // frame_id "imu" and its NUL end the header at 16 bytes: the doubles
    // that follow are aligned without padding
    string(&mut b, "imu\0");
    let covariance = [0.0; 9];
    for v in [
        &[0.0, 0.0, 0.0, 1.0][..],
        &covariance,
        &w,
        &covariance,
        &f,
        &covariance,
    ] {
        for x in v {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    b
}

fn write_recording(path: &Path) {
    let mut file = b"\x89MCAP0\r\n".to_vec();
    let mut body = Vec::new();
    string(&mut body, "ros2");
    string(&mut body, "sinscal test");
    record(&mut file, 0x01, &body);
    // Schema 1: sensor_msgs/msg/Imu, ros2msg.
    let mut body = 1u16.to_le_bytes().to_vec();
    string(&mut body, "sensor_msgs/msg/Imu");
    string(&mut body, "ros2msg");
    string(&mut body, "std_msgs/Header header\n# ...");
    record(&mut file, 0x03, &body);
    // Channel 1 on /imu, CDR, no metadata.
    let mut body = [1u16.to_le_bytes(), 1u16.to_le_bytes()].concat();
    string(&mut body, "/imu");
    string(&mut body, "cdr");
    body.extend_from_slice(&0u32.to_le_bytes());
    record(&mut file, 0x04, &body);
    let step = 1_000_000_000 / u64::from(RATE_HZ);
    for k in 0..MESSAGES {
        let stamp = START_NS + u64::from(k) * step;
        let mut body = 1u16.to_le_bytes().to_vec();
        body.extend_from_slice(&k.to_le_bytes());
        body.extend_from_slice(&(stamp + 300_000).to_le_bytes());
        body.extend_from_slice(&stamp.to_le_bytes());
        let (w, f) = sample(k);
        body.extend_from_slice(&imu_cdr(stamp, w, f));
        record(&mut file, 0x05, &body);
    }
    record(&mut file, 0x0F, &0u32.to_le_bytes());
    record(&mut file, 0x02, &[0; 20]);
    file.extend_from_slice(b"\x89MCAP0\r\n");
    std::fs::write(path, file).unwrap();
}

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_ros2_recording_imports_and_reads_as_a_run() {
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("rest.mcap");
    write_recording(&recording);
    let out = dir.path().join("run");
    let import = sinscal()
        .args(["import", "mcap"])
        .arg(&recording)
        .args(["--topic", "/imu", "--serial", "UNIT-1", "--out"])
        .arg(&out)
        .args(["--latitude", "28.2215", "--longitude", "112.9924"])
        .args(["--height", "50"])
        .output()
        .unwrap();
    ok(&import);
    let said = String::from_utf8_lossy(&import.stdout);
    assert!(said.contains("6000 messages of /imu at 200 Hz"), "{said}");
    let meta = RunMetadata::from_json(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(meta.unit_serial, "UNIT-1");
    assert_eq!(meta.sample_rate_hz, f64::from(RATE_HZ));
    assert_eq!(meta.extra["mcap"]["frame_id"], "imu");
    let data = out.join("run.csv");
    let reader = RecordReader::open(&data, DataFormat::Csv, meta.sample_rate_hz).unwrap();
    let mut n = 0;
    for (k, r) in (0..).zip(reader) {
        let r = r.unwrap();
        let (w, f) = sample(k);
        assert!((r.t - f64::from(k) / f64::from(RATE_HZ)).abs() < 1e-9);
        assert!((r.dv[2] - f[2] / f64::from(RATE_HZ)).abs() < 1e-12, "{k}");
        assert!(
            (r.dtheta[1] - w[1] / f64::from(RATE_HZ)).abs() < 1e-15,
            "{k}"
        );
        n += 1;
    }
    assert_eq!(n, MESSAGES);
    // A tool of the contract takes the run as it takes any other.
    let noise = sinscal()
        .args(["noise", "--static", "--out"])
        .arg(dir.path().join("NOISE.json"))
        .arg(&data)
        .output()
        .unwrap();
    ok(&noise);
}

#[test]
fn a_topic_not_recorded_is_refused_naming_the_topics_there() {
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("rest.mcap");
    write_recording(&recording);
    let out = dir.path().join("run");
    let import = sinscal()
        .args(["import", "mcap"])
        .arg(&recording)
        .args(["--topic", "/imu/data", "--out"])
        .arg(&out)
        .args(["--latitude", "28", "--longitude", "113", "--height", "0"])
        .output()
        .unwrap();
    assert!(!import.status.success());
    let said = String::from_utf8_lossy(&import.stderr);
    assert!(
        said.contains("no channel has the topic \"/imu/data\"; the topics present: \"/imu\""),
        "{said}"
    );
    assert!(!out.join("run.csv").exists());
}
