//! ROS 2 recordings (MCAP) of `sensor_msgs/msg/Imu` imported as runs of the
//! contract (SPEC §5), in the rates layout `t,wx,wy,wz,fx,fy,fz`.
//!
//! One topic is read: every channel of that topic must carry the schema
//! `sensor_msgs/msg/Imu` in the message encoding `cdr`. Each message is one
//! sample — `angular_velocity` (rad/s) and `linear_acceleration` (m/s², a
//! specific force as ROS defines it: +g up at rest) — taken at its stamp,
//! written as it is read. Axes stay the message's frame (`frame_id`, kept in
//! the metadata), read as body x, y, z.
//!
//! Time. t is the message's `header.stamp` (sec + nanosec) less the first
//! message's, so the run starts at t = 0. A driver that leaves the stamp
//! zero gives no time at all; when the *first* message's stamp is zero the
//! whole run takes the recorder's log time instead (its receive clock,
//! which carries the transport's jitter), never a mix of the two clocks.
//! The clock used is in the metadata (`mcap.clock`). Stamps must strictly
//! increase; the reader judges the steps (SPEC §2a: gaps, jitter).
//!
//! The sample rate is 10⁹ / the median step (ns) of the stamps: the median,
//! not the mean, so that lost messages (long steps) do not lower it. It is
//! taken over an even sample of at most 8192 steps spread over the run, so
//! that memory stays fixed however long the recording.
//!
//! Streaming: the file is read through the `mcap` crate's sans-io linear
//! reader fed from a buffered file (no memory map, no index), and each
//! sample is written before the next message is read. Chunks compressed
//! with zstd or lz4 are refused naming the compression: the crate is built
//! without them, whose C libraries the core does not otherwise need.

use std::collections::{BTreeSet, HashMap, HashSet};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader};
use serde::Serialize;

use super::data::DataFormat;
use super::meta::{validate_serial, write_json, MetaError, RunMetadata};
use super::run::{data_file_name, metadata_sidecar};
use crate::nav::Site;

#[path = "mcap_cdr.rs"]
mod cdr;
#[path = "mcap_rates.rs"]
mod rates;

pub use cdr::CdrError;
use rates::{RatesWriter, StepSample};

/// The schema name a channel must carry.
pub const IMU_SCHEMA: &str = "sensor_msgs/msg/Imu";
/// The message encoding a channel must carry.
pub const CDR_ENCODING: &str = "cdr";

/// Errors importing an MCAP recording.
#[derive(Debug, thiserror::Error)]
pub enum McapError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A chunk compressed with a compression this build does not read.
    #[error(
        "{path}: a chunk is compressed with {compression:?}, which this build does not \
         read; re-record or convert the file without chunk compression \
         (e.g. `mcap convert --compression none`)"
    )]
    Compression { path: PathBuf, compression: String },
    /// The file is not MCAP, or its structure is broken.
    #[error("{path}: not a readable MCAP file: {source}")]
    Mcap {
        path: PathBuf,
        #[source]
        source: mcap::McapError,
    },
    #[error("{path}: no channel has the topic {topic:?}; the topics present: {present}")]
    TopicAbsent {
        path: PathBuf,
        topic: String,
        present: String,
    },
    #[error(
        "{path}: topic {topic:?} carries schema {schema:?} in message encoding \
         {encoding:?}; {IMU_SCHEMA} in {CDR_ENCODING} is what can be imported"
    )]
    WrongSchema {
        path: PathBuf,
        topic: String,
        schema: String,
        encoding: String,
    },
    /// A message of the topic is unusable: its number (1-based, among the
    /// topic's messages in file order) and why.
    #[error("{path}, message {message} of {topic}: {fault}")]
    Message {
        path: PathBuf,
        topic: String,
        message: u64,
        #[source]
        fault: MessageFault,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error(transparent)]
    Meta(#[from] MetaError),
}

/// Why one message cannot be a sample.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum MessageFault {
    #[error(transparent)]
    Cdr(#[from] CdrError),
    #[error("stamp {} s does not follow {} s: time must strictly increase", secs(*.stamp_ns), secs(*.previous_ns))]
    NotIncreasing { stamp_ns: i64, previous_ns: i64 },
    #[error("header.stamp.nanosec {0} is not below 10⁹")]
    Nanosec(u32),
    #[error("{field} is {value}")]
    NonFinite { field: &'static str, value: f64 },
    /// REP 145: covariance element 0 set to −1 says the field is not given.
    #[error("{field} is marked as not provided (its covariance element 0 is -1)")]
    NotProvided { field: &'static str },
    #[error("log time {0} ns is beyond the i64 nanosecond range")]
    LogTime(u64),
}

/// Nanoseconds as seconds with all nine decimals.
fn secs(ns: i64) -> String {
    let sign = if ns < 0 { "-" } else { "" };
    let a = ns.unsigned_abs();
    format!("{sign}{}.{:09}", a / 1_000_000_000, a % 1_000_000_000)
}

/// Which clock the run's times come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Clock {
    /// The messages' `header.stamp`.
    #[serde(rename = "header.stamp")]
    HeaderStamp,
    /// The recorder's log time (the first header stamp was zero).
    #[serde(rename = "log_time")]
    LogTime,
}

/// What to import and how to label it.
#[derive(Clone, Debug)]
pub struct McapImport<'a> {
    pub topic: &'a str,
    pub unit_serial: &'a str,
    /// Where the unit stood: a recording does not say.
    pub site: Site,
}

/// Where the samples came from, kept in the metadata under `mcap`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct McapSource {
    pub file: String,
    pub topic: String,
    pub schema: String,
    pub clock: Clock,
    pub frame_id: String,
    pub messages: u64,
    /// The first message's time on its clock (t = 0), ns.
    pub origin_ns: i64,
    pub median_step_ns: f64,
}

/// What an import wrote.
#[derive(Clone, Debug)]
pub struct ImportedMcap {
    pub data: PathBuf,
    pub metadata: PathBuf,
    pub sample_rate_hz: f64,
    /// The last sample's t, s.
    pub duration_s: f64,
    pub source: McapSource,
}

/// Imports the topic `options.topic` of the MCAP file `input` into the
/// folder `out_dir` (created if needed) as `run.csv` (rates) and `run.json`,
/// streaming; the data file is removed on an error.
pub fn import_mcap(
    input: &Path,
    out_dir: &Path,
    options: &McapImport,
) -> Result<ImportedMcap, McapError> {
    let invalid = |message: String| McapError::Invalid {
        path: input.to_path_buf(),
        message,
    };
    validate_serial(options.unit_serial).map_err(|m| invalid(format!("unit serial: {m}")))?;
    let file = File::open(input).map_err(io_error(input))?;
    std::fs::create_dir_all(out_dir).map_err(io_error(out_dir))?;
    let data = out_dir.join(data_file_name(DataFormat::Csv, false));
    let written = write_samples(input, file, &data, options.topic)
        .and_then(|samples| finish_metadata(input, &data, options, samples));
    let (meta, imported) = written.inspect_err(|_| {
        let _ = std::fs::remove_file(&data);
    })?;
    write_json(&imported.metadata, &meta)?;
    Ok(imported)
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> McapError {
    let path = path.to_path_buf();
    move |source| McapError::Io { path, source }
}

/// Feeds every record of the file to `each`, in file order (records inside
/// uncompressed chunks included), holding one record at a time.
fn for_each_record(
    path: &Path,
    file: File,
    mut each: impl FnMut(mcap::records::Record<'_>) -> Result<(), McapError>,
) -> Result<(), McapError> {
    let mut input = BufReader::with_capacity(256 * 1024, file);
    let mut reader = LinearReader::new();
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| mcap_error(path, e))? {
            LinearReadEvent::ReadRequest(need) => {
                let n = input.read(reader.insert(need)).map_err(io_error(path))?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, data } => {
                each(mcap::parse_record(opcode, data).map_err(|e| mcap_error(path, e))?)?;
            }
        }
    }
    Ok(())
}

fn mcap_error(path: &Path, source: mcap::McapError) -> McapError {
    match source {
        mcap::McapError::UnsupportedCompression(compression) => McapError::Compression {
            path: path.to_path_buf(),
            compression,
        },
        source => McapError::Mcap {
            path: path.to_path_buf(),
            source,
        },
    }
}

/// The samples as they are read: the channels that carry the topic, the
/// clock, the last stamp and the steps.
struct Samples<'a> {
    path: &'a Path,
    data: &'a Path,
    topic: &'a str,
    /// Schema id → name.
    schemas: HashMap<u16, String>,
    topics: BTreeSet<String>,
    channels: HashSet<u16>,
    writer: RatesWriter,
    messages: u64,
    clock: Clock,
    origin_ns: i64,
    last_ns: i64,
    frame_id: String,
    steps: StepSample,
}

impl Samples<'_> {
    fn record(&mut self, record: mcap::records::Record<'_>) -> Result<(), McapError> {
        use mcap::records::Record;
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(c) => {
                self.topics.insert(c.topic.clone());
                if c.topic == self.topic {
                    self.channel(c)?;
                }
            }
            Record::Message { header, data } if self.channels.contains(&header.channel_id) => {
                self.messages += 1;
                let (t, imu) =
                    self.message(header.log_time, &data)
                        .map_err(|fault| McapError::Message {
                            path: self.path.to_path_buf(),
                            topic: self.topic.to_string(),
                            message: self.messages,
                            fault,
                        })?;
                self.writer
                    .write(t, &imu.angular_velocity, &imu.linear_acceleration)
                    .map_err(io_error(self.data))?;
            }
            _ => {}
        }
        Ok(())
    }

    /// Accepts a channel of the topic if it carries Imu in CDR. A channel
    /// names its schema by an id defined before it (schema 0: none).
    fn channel(&mut self, c: mcap::records::Channel) -> Result<(), McapError> {
        let schema = self.schemas.get(&c.schema_id).cloned().unwrap_or_default();
        if schema != IMU_SCHEMA || c.message_encoding != CDR_ENCODING {
            return Err(McapError::WrongSchema {
                path: self.path.to_path_buf(),
                topic: c.topic,
                schema,
                encoding: c.message_encoding,
            });
        }
        self.channels.insert(c.id);
        Ok(())
    }

    /// The sample's t, s, and the message, or why it is none.
    fn message(&mut self, log_time: u64, payload: &[u8]) -> Result<(f64, cdr::Imu), MessageFault> {
        let imu = cdr::decode_imu(payload)?;
        if imu.stamp_nanosec >= 1_000_000_000 {
            return Err(MessageFault::Nanosec(imu.stamp_nanosec));
        }
        check_values(&imu)?;
        let first = self.messages == 1;
        if first {
            let zero = imu.stamp_sec == 0 && imu.stamp_nanosec == 0;
            self.clock = if zero {
                Clock::LogTime
            } else {
                Clock::HeaderStamp
            };
            self.frame_id = imu.frame_id.clone();
        }
        let ns = match self.clock {
            Clock::HeaderStamp => {
                i64::from(imu.stamp_sec) * 1_000_000_000 + i64::from(imu.stamp_nanosec)
            }
            Clock::LogTime => {
                i64::try_from(log_time).map_err(|_| MessageFault::LogTime(log_time))?
            }
        };
        if first {
            self.origin_ns = ns;
        } else if ns <= self.last_ns {
            return Err(MessageFault::NotIncreasing {
                stamp_ns: ns,
                previous_ns: self.last_ns,
            });
        } else {
            self.steps.push((ns - self.last_ns) as u64);
        }
        self.last_ns = ns;
        // Integer nanoseconds first, then one rounding.
        Ok(((ns - self.origin_ns) as f64 / 1e9, imu))
    }
}

/// The rate and force must be numbers, and given (REP 145's −1).
fn check_values(imu: &cdr::Imu) -> Result<(), MessageFault> {
    const NAMES: [&str; 6] = [
        "angular_velocity.x",
        "angular_velocity.y",
        "angular_velocity.z",
        "linear_acceleration.x",
        "linear_acceleration.y",
        "linear_acceleration.z",
    ];
    let values = imu.angular_velocity.iter().chain(&imu.linear_acceleration);
    if let Some((field, &value)) = NAMES.into_iter().zip(values).find(|(_, v)| !v.is_finite()) {
        return Err(MessageFault::NonFinite { field, value });
    }
    if imu.angular_velocity_covariance_0 == -1.0 {
        return Err(MessageFault::NotProvided {
            field: "angular_velocity",
        });
    }
    if imu.linear_acceleration_covariance_0 == -1.0 {
        return Err(MessageFault::NotProvided {
            field: "linear_acceleration",
        });
    }
    Ok(())
}

/// Reads the topic's messages from `file` into the rates file `data`.
fn write_samples(
    path: &Path,
    file: File,
    data: &Path,
    topic: &str,
) -> Result<(McapSource, f64), McapError> {
    let comment = format!(
        "imported by sinscal {} from the MCAP recording {}, topic {topic} ({IMU_SCHEMA})",
        env!("CARGO_PKG_VERSION"),
        path.display()
    );
    let mut samples = Samples {
        path,
        data,
        topic,
        schemas: HashMap::new(),
        topics: BTreeSet::new(),
        channels: HashSet::new(),
        writer: RatesWriter::create(data, &[comment]).map_err(io_error(data))?,
        messages: 0,
        clock: Clock::HeaderStamp,
        origin_ns: 0,
        last_ns: 0,
        frame_id: String::new(),
        steps: StepSample::new(),
    };
    for_each_record(path, file, |r| samples.record(r))?;
    let invalid = |message: String| McapError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    if samples.channels.is_empty() {
        let present: Vec<String> = samples.topics.iter().map(|t| format!("{t:?}")).collect();
        return Err(McapError::TopicAbsent {
            path: path.to_path_buf(),
            topic: topic.to_string(),
            present: if present.is_empty() {
                "none".into()
            } else {
                present.join(", ")
            },
        });
    }
    let median_step_ns = samples.steps.median_ns().ok_or_else(|| {
        invalid(format!(
            "topic {topic:?} has {} message(s): a rate needs at least two",
            samples.messages
        ))
    })?;
    samples.writer.finish().map_err(io_error(data))?;
    let duration_s = (samples.last_ns - samples.origin_ns) as f64 / 1e9;
    let source = McapSource {
        file: path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
        topic: topic.to_string(),
        schema: IMU_SCHEMA.to_string(),
        clock: samples.clock,
        frame_id: samples.frame_id,
        messages: samples.messages,
        origin_ns: samples.origin_ns,
        median_step_ns,
    };
    Ok((source, duration_s))
}

/// The run's metadata: the caller's site, the rate from the median step,
/// the first stamp as `recorded_at` when it is a calendar time, and where
/// the samples came from under `mcap`.
fn finish_metadata(
    input: &Path,
    data: &Path,
    options: &McapImport,
    (source, duration_s): (McapSource, f64),
) -> Result<(RunMetadata, ImportedMcap), McapError> {
    let mut extra = std::collections::BTreeMap::new();
    extra.insert(
        "mcap".to_string(),
        serde_json::to_value(&source).map_err(|source| MetaError::Json {
            what: "mcap source".into(),
            source,
        })?,
    );
    let sample_rate_hz = 1e9 / source.median_step_ns;
    let meta = RunMetadata {
        unit_serial: options.unit_serial.to_string(),
        sample_rate_hz,
        latitude_deg: options.site.latitude_deg,
        longitude_deg: options.site.longitude_deg,
        height_m: options.site.height_m,
        gravity_mps2: options.site.gravity_mps2,
        format: DataFormat::Csv,
        scheme: None,
        station: None,
        operator: None,
        recorded_at: calendar_time(source.origin_ns),
        temperature_c: None,
        temperature_column: false,
        counts: None,
        product: None,
        notes: Some(format!(
            "imported from the MCAP recording {}, topic {} ({IMU_SCHEMA}): axes of the \
             frame {:?} as recorded (ROS bodies: x forward, y left, z up), read as body x, y, z",
            input.display(),
            source.topic,
            source.frame_id
        )),
        extra,
    };
    meta.validate()?;
    let imported = ImportedMcap {
        data: data.to_path_buf(),
        metadata: metadata_sidecar(data),
        sample_rate_hz,
        duration_s,
        source,
    };
    Ok((meta, imported))
}

/// A stamp as RFC 3339 when it is a calendar time (after 2000; simulated
/// time and boot clocks start near zero and say nothing of the date).
fn calendar_time(ns: i64) -> Option<String> {
    const Y2000_S: i64 = 946_684_800;
    let s = ns.div_euclid(1_000_000_000);
    if s < Y2000_S {
        return None;
    }
    let t = chrono::DateTime::from_timestamp(s, ns.rem_euclid(1_000_000_000) as u32)?;
    Some(t.to_rfc3339_opts(chrono::SecondsFormat::Millis, true))
}

#[cfg(test)]
#[path = "mcap_tests.rs"]
mod tests;
