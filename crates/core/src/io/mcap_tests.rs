//! Recordings written here with the `mcap` crate's own writer (chunked,
//! uncompressed, as rosbag2 writes by default) and Imu messages encoded by
//! a small CDR encoder, imported and read back; and recordings the
//! importer must refuse.

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use mcap::records::MessageHeader;

use super::*;
use crate::io::data::{DataFormat, RecordReader};

const MESSAGES: u32 = 300;
/// 100 Hz, stamped from a calendar time.
const STEP_NS: i64 = 10_000_000;
const START_S: i32 = 1_700_000_000;

/// One Imu message as a ROS 2 publisher serialises it: little-endian
/// CDR, the doubles aligned to 8 after the frame id.
fn imu_cdr(stamp_ns: i64, w: [f64; 3], f: [f64; 3]) -> Vec<u8> {
    let frame = "imu_link";
    let mut b = vec![0, 1, 0, 0];
    b.extend_from_slice(&((stamp_ns.div_euclid(1_000_000_000)) as i32).to_le_bytes());
    b.extend_from_slice(&(stamp_ns.rem_euclid(1_000_000_000) as u32).to_le_bytes());
    b.extend_from_slice(&(frame.len() as u32 + 1).to_le_bytes());
    b.extend_from_slice(frame.as_bytes());
    b.push(0);
    while (b.len() - 4) % 8 != 0 {
        b.push(0);
    }
    let orientation = [0.0, 0.0, 0.0, 1.0];
    let covariance = [1e-6; 9];
    for v in [
        &orientation[..],
        &[-1.0; 9],
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

/// Message k's rate and force: varied doubles, none of them short.
fn sample(k: u32) -> ([f64; 3], [f64; 3]) {
    let x = f64::from(k);
    (
        [1e-3 * (0.1 * x).sin(), -7.3e-5 + 1e-9 * x, 0.3 / (x + 3.0)],
        [0.01 * (0.07 * x).cos(), -0.02, 9.79 + x / 7.0e4],
    )
}

fn stamp(k: u32) -> i64 {
    i64::from(START_S) * 1_000_000_000 + i64::from(k) * STEP_NS
}

/// A recording with the topic `/imu` (schema `schema`) and `/odom`; the
/// payload of each `/imu` message by `payload(k)`, k from 0; log times
/// jittered by up to ±0.4 ms and late by 2 ms.
fn write_mcap(path: &Path, schema: &str, payload: impl Fn(u32) -> Vec<u8>) {
    let out = BufWriter::new(File::create(path).unwrap());
    let options = mcap::WriteOptions::new()
        .compression(None)
        .chunk_size(Some(16 * 1024));
    let mut w = options.create(out).unwrap();
    let imu = w.add_schema(schema, "ros2msg", b"# definition").unwrap();
    let odom = w
        .add_schema("nav_msgs/msg/Odometry", "ros2msg", b"# definition")
        .unwrap();
    let none = BTreeMap::new();
    let imu = w.add_channel(imu, "/imu", "cdr", &none).unwrap();
    let odom = w.add_channel(odom, "/odom", "cdr", &none).unwrap();
    for k in 0..MESSAGES {
        let log_time = (stamp(k) + 2_000_000 + i64::from(k % 9) * 100_000 - 400_000) as u64;
        let header = |channel_id| MessageHeader {
            channel_id,
            sequence: k,
            log_time,
            publish_time: log_time,
        };
        w.write_to_known_channel(&header(imu), &payload(k)).unwrap();
        if k % 10 == 0 {
            w.write_to_known_channel(&header(odom), &[0, 1, 0, 0, 9, 9])
                .unwrap();
        }
    }
    w.finish().unwrap();
}

fn good(k: u32) -> Vec<u8> {
    let (w, f) = sample(k);
    imu_cdr(stamp(k), w, f)
}

fn options(topic: &str) -> McapImport<'_> {
    McapImport {
        topic,
        unit_serial: "UNIT-1",
        site: Site::new(28.2215, 112.9924, 50.0),
    }
}

fn import(path: &Path, topic: &str) -> (PathBuf, Result<ImportedMcap, McapError>) {
    let out = path.with_extension("run");
    let result = import_mcap(path, &out, &options(topic));
    (out, result)
}

/// The rates file's records as numbers, comments and header skipped.
fn rows(data: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(data).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(lines.next(), Some("t,wx,wy,wz,fx,fy,fz"));
    lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn a_recording_round_trips_through_the_importer() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu.mcap");
    write_mcap(&path, IMU_SCHEMA, good);
    let (_, result) = import(&path, "/imu");
    let run = result.expect("imports");
    assert_eq!(run.source.messages, u64::from(MESSAGES));
    assert_eq!(run.source.clock, Clock::HeaderStamp);
    assert_eq!(run.source.frame_id, "imu_link");
    assert_eq!(run.sample_rate_hz, 100.0);
    let rows = rows(&run.data);
    assert_eq!(rows.len(), MESSAGES as usize);
    for (k, row) in (0..).zip(&rows) {
        let (w, f) = sample(k);
        let t = f64::from(k) * 0.01;
        assert!((row[0] - t).abs() < 1e-9, "message {k}: t {}", row[0]);
        assert_eq!(row[1..4], w, "message {k}");
        assert_eq!(row[4..7], f, "message {k}");
    }
    let meta = RunMetadata::from_json(&std::fs::read(&run.metadata).unwrap()).unwrap();
    assert_eq!(meta.unit_serial, "UNIT-1");
    assert_eq!(meta.sample_rate_hz, 100.0);
    assert_eq!(meta.latitude_deg, 28.2215);
    assert_eq!(
        meta.recorded_at.as_deref(),
        Some("2023-11-14T22:13:20.000Z")
    );
    assert_eq!(meta.extra["mcap"]["clock"], "header.stamp");
    assert_eq!(meta.extra["mcap"]["topic"], "/imu");
    // The core's reader takes the file as a run: every sample, in order.
    let reader = RecordReader::open(&run.data, DataFormat::Csv, meta.sample_rate_hz).unwrap();
    let records: Vec<_> = reader.collect::<Result<_, _>>().expect("a valid run");
    assert_eq!(records.len(), rows.len());
    for (r, row) in records.iter().zip(&rows).skip(1) {
        assert_eq!(r.t, row[0]);
        assert!((r.dtheta[0] - row[1] * 0.01).abs() <= 1e-12 * row[1].abs());
    }
}

#[test]
fn zero_header_stamps_take_the_log_time() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("unstamped.mcap");
    write_mcap(&path, IMU_SCHEMA, |k| {
        let (w, f) = sample(k);
        imu_cdr(0, w, f)
    });
    let run = import(&path, "/imu").1.expect("imports");
    assert_eq!(run.source.clock, Clock::LogTime);
    // The log time's jitter is k % 9 × 0.1 ms: the median step is 10.1 ms
    // or 10 ms by the pattern's draw, and the rate near 100 Hz.
    assert!(
        (run.sample_rate_hz - 100.0).abs() < 1.0,
        "{}",
        run.sample_rate_hz
    );
    let rows = rows(&run.data);
    assert_eq!(rows[1][0], 0.0101);
    assert_eq!(rows[9][0], 0.09);
}

#[test]
fn an_absent_topic_is_refused_naming_the_topics_present() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu.mcap");
    write_mcap(&path, IMU_SCHEMA, good);
    let (out, result) = import(&path, "/imu/data_raw");
    let err = result.expect_err("no such topic");
    assert!(matches!(err, McapError::TopicAbsent { .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("\"/imu\", \"/odom\""), "{text}");
    assert!(!out.join("run.csv").exists());
}

#[test]
fn a_topic_of_another_schema_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mag.mcap");
    write_mcap(&path, "sensor_msgs/msg/MagneticField", good);
    let err = import(&path, "/imu").1.expect_err("not Imu");
    assert!(
        err.to_string()
            .contains("schema \"sensor_msgs/msg/MagneticField\" in message encoding \"cdr\""),
        "{err}"
    );
}

/// The message (1-based among the topic's) and the fault of an error.
fn message_fault(err: McapError) -> (u64, MessageFault) {
    match err {
        McapError::Message { message, fault, .. } => (message, fault),
        other => panic!("not a message error: {other}"),
    }
}

#[test]
fn a_truncated_message_is_refused_by_its_number() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short.mcap");
    write_mcap(&path, IMU_SCHEMA, |k| {
        let mut b = good(k);
        if k == 41 {
            b.truncate(200);
        }
        b
    });
    let (out, result) = import(&path, "/imu");
    let err = result.expect_err("truncated");
    let text = err.to_string();
    assert!(
        text.contains("message 42 of /imu: truncated payload"),
        "{text}"
    );
    let (n, fault) = message_fault(err);
    assert_eq!(n, 42);
    assert!(matches!(
        fault,
        MessageFault::Cdr(CdrError::Truncated {
            field: "angular_velocity_covariance",
            need: 228,
            have: 200
        })
    ));
    assert!(!out.join("run.csv").exists(), "the partial run is removed");
}

#[test]
fn a_stamp_that_does_not_increase_is_refused_by_its_number() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("repeat.mcap");
    write_mcap(&path, IMU_SCHEMA, |k| {
        let (w, f) = sample(k);
        imu_cdr(stamp(if k == 7 { 6 } else { k }), w, f)
    });
    let err = import(&path, "/imu").1.expect_err("repeated stamp");
    assert!(
        err.to_string()
            .contains("stamp 1700000000.060000000 s does not follow 1700000000.060000000 s"),
        "{err}"
    );
    assert_eq!(message_fault(err).0, 8);
}

#[test]
fn nan_and_absent_values_are_refused_by_their_number() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nan.mcap");
    write_mcap(&path, IMU_SCHEMA, |k| {
        let (w, mut f) = sample(k);
        if k == 2 {
            f[1] = f64::NAN;
        }
        imu_cdr(stamp(k), w, f)
    });
    let (n, fault) = message_fault(import(&path, "/imu").1.expect_err("NaN"));
    assert_eq!(n, 3);
    assert!(matches!(
        fault,
        MessageFault::NonFinite { field: "linear_acceleration.y", value } if value.is_nan()
    ));
    let path = dir.path().join("absent.mcap");
    write_mcap(&path, IMU_SCHEMA, |k| {
        let mut b = good(k);
        // angular_velocity_covariance[0]: after the header (24 bytes with
        // the frame id and padding), orientation and its covariance.
        let at = 4 + 24 + 8 * 16;
        b[at..at + 8].copy_from_slice(&(-1.0f64).to_le_bytes());
        b
    });
    let (n, fault) = message_fault(import(&path, "/imu").1.expect_err("absent"));
    assert_eq!(
        (n, fault),
        (
            1,
            MessageFault::NotProvided {
                field: "angular_velocity"
            }
        )
    );
}

/// An MCAP record: opcode, length, body.
fn record(out: &mut Vec<u8>, opcode: u8, body: &[u8]) {
    out.push(opcode);
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
}

fn string(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

#[test]
fn a_compressed_chunk_is_refused_naming_its_compression() {
    let mut file = b"\x89MCAP0\r\n".to_vec();
    let mut header = Vec::new();
    string(&mut header, "");
    string(&mut header, "test");
    record(&mut file, 0x01, &header);
    let mut chunk = Vec::new();
    for v in [0u64, 0, 64] {
        chunk.extend_from_slice(&v.to_le_bytes());
    }
    chunk.extend_from_slice(&0u32.to_le_bytes());
    string(&mut chunk, "zstd");
    chunk.extend_from_slice(&16u64.to_le_bytes());
    chunk.extend_from_slice(&[0x28, 0xb5, 0x2f, 0xfd, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    record(&mut file, 0x06, &chunk);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("zstd.mcap");
    std::fs::write(&path, file).unwrap();
    let err = import(&path, "/imu").1.expect_err("compressed");
    assert!(
        matches!(&err, McapError::Compression { compression, .. } if compression == "zstd"),
        "{err}"
    );
}
