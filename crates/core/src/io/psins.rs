//! PSINS "SIMU" text logs (the `imufile.m` format of the PSINS toolbox)
//! imported as runs of the contract (SPEC §5).
//!
//! The format: lines beginning `%` are comments and blank lines are
//! skipped; the first three other lines are a header —
//!
//! 1. pitch, roll, yaw (deg) and VE, VN, VU (m/s) at the start;
//! 2. latitude, longitude (deg), height (m), t0 (s), the sampling interval
//!    (ms) and g (m/s²);
//! 3. the gyro scales (arcsec per count, x y z) and the accelerometer
//!    scales (µg·s per count, µg of that g);
//!
//! then one line per record: six whole counts (gyro x y z, accelerometer
//! x y z), and in files written with time dither a seventh, the dither of
//! that record's stamp in microseconds. Every line has the same number of
//! values (header lines carry a trailing 0 in dithered files). Record k
//! (from 1) ends at t0 + k·Δt + 10⁻⁶·Σ_{i≤k} dither_i; its increments are
//! count × arcsec (rad) and count × µg·s × 10⁻⁶ g (m/s).
//!
//! Axes. PSINS mounts its unit x right, y forward, z up, a right-handed
//! triad of the unit's own sensor axes; the records keep them as the body
//! axes x, y, z (SPEC §1's body frame is the sensors' own), so a vehicle
//! heading north starts with x east, y north, z up, SPEC's nominal start.
//! The header's attitude and velocity go to the metadata (`psins`), unused.
//!
//! The run is written as physical increments, not SPEC §5 counts: every
//! tool reads increments, and a count × scale written in the shortest form
//! that reads back to the same double keeps each record an exact multiple
//! of its quantum, which the noise analysis finds again from the data.
//! The scales are kept in the metadata.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::data::{DataFormat, RecordWriter, WriteOptions};
use super::meta::{validate_serial, write_json, MetaError, RunMetadata};
use super::run::{data_file_name, metadata_sidecar};
use super::text_lines::TextLines;
use crate::model::units::ARCSEC;
use crate::record::Record;

/// Errors importing a PSINS log.
#[derive(Debug, thiserror::Error)]
pub enum PsinsError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The log breaks the format: the line (1-based, of the file) and why.
    #[error("{path}, line {line}: {message}")]
    Line {
        path: PathBuf,
        line: u64,
        message: String,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error(transparent)]
    Meta(#[from] MetaError),
}

/// The three header lines.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PsinsHeader {
    pub attitude_deg: [f64; 3],
    pub velocity_enu_mps: [f64; 3],
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub height_m: f64,
    pub t0_s: f64,
    pub interval_ms: f64,
    pub gravity_mps2: f64,
    pub gyro_arcsec_per_count: [f64; 3],
    pub accel_ug_s_per_count: [f64; 3],
    /// Records carry a seventh column, the stamp's dither in µs.
    pub dither_column: bool,
}

impl PsinsHeader {
    /// A record's counts (and dither) as increments in rad and m/s.
    fn increments(&self, counts: &[i64; 6]) -> ([f64; 3], [f64; 3]) {
        let g = std::array::from_fn(|a| counts[a] as f64 * self.gyro_arcsec_per_count[a] * ARCSEC);
        let v = std::array::from_fn(|a| {
            counts[3 + a] as f64 * self.accel_ug_s_per_count[a] * 1e-6 * self.gravity_mps2
        });
        (g, v)
    }
}

/// What an import wrote.
#[derive(Clone, Debug)]
pub struct ImportedRun {
    pub data: PathBuf,
    pub metadata: PathBuf,
    pub records: u64,
    pub header: PsinsHeader,
}

/// The lines of a log that carry numbers, with their line numbers.
struct Lines {
    path: PathBuf,
    lines: TextLines,
}

impl Lines {
    /// Moves to the next line of values (comments and blank lines
    /// skipped); its number, `None` at the end.
    fn next_line(&mut self) -> Result<Option<u64>, PsinsError> {
        let more = self
            .lines
            .advance(|t| t.is_empty() || t.starts_with('%'))
            .map_err(|source| PsinsError::Io {
                path: self.path.clone(),
                source,
            })?;
        Ok(more.then_some(self.lines.line))
    }

    /// The current line's values.
    fn fields(&self) -> Vec<&str> {
        self.lines.text.split_whitespace().collect()
    }

    fn error(&self, line: u64, message: impl Into<String>) -> PsinsError {
        PsinsError::Line {
            path: self.path.clone(),
            line,
            message: message.into(),
        }
    }
}

/// Parses the header (the first three lines of values).
fn read_header(lines: &mut Lines) -> Result<PsinsHeader, PsinsError> {
    let mut rows: Vec<(u64, Vec<f64>)> = Vec::new();
    for what in [
        "attitude and velocity",
        "position, t0, interval and g",
        "scales",
    ] {
        let Some(line) = lines.next_line()? else {
            return Err(PsinsError::Invalid {
                path: lines.path.clone(),
                message: format!("ends before the header line of {what}"),
            });
        };
        let values: Result<Vec<f64>, _> = lines.fields().iter().map(|f| f.parse::<f64>()).collect();
        let values = values
            .ok()
            .filter(|v| v.iter().all(|x| x.is_finite()))
            .ok_or_else(|| {
                lines.error(line, format!("the header line of {what} is not numbers"))
            })?;
        if !(6..=7).contains(&values.len()) {
            return Err(lines.error(
                line,
                format!(
                    "the header line of {what} has {} values, 6 or 7 expected",
                    values.len()
                ),
            ));
        }
        rows.push((line, values));
    }
    let (a, p, s) = (&rows[0].1, &rows[1].1, &rows[2].1);
    let header = PsinsHeader {
        attitude_deg: [a[0], a[1], a[2]],
        velocity_enu_mps: [a[3], a[4], a[5]],
        latitude_deg: p[0],
        longitude_deg: p[1],
        height_m: p[2],
        t0_s: p[3],
        interval_ms: p[4],
        gravity_mps2: p[5],
        gyro_arcsec_per_count: [s[0], s[1], s[2]],
        accel_ug_s_per_count: [s[3], s[4], s[5]],
        dither_column: rows.iter().all(|r| r.1.len() == 7),
    };
    if header.interval_ms.is_nan() || header.interval_ms <= 0.0 {
        return Err(lines.error(
            rows[1].0,
            format!("sampling interval {} ms", header.interval_ms),
        ));
    }
    if !(header.gravity_mps2 > 5.0 && header.gravity_mps2 < 15.0) {
        return Err(lines.error(rows[1].0, format!("g {} m/s²", header.gravity_mps2)));
    }
    if s[..6].iter().any(|x| x.is_nan() || *x <= 0.0) {
        return Err(lines.error(rows[2].0, "every scale must be positive"));
    }
    Ok(header)
}

/// Parses one record line: six whole counts and, with the dither column,
/// the dither in µs.
fn read_counts(
    lines: &Lines,
    line: u64,
    fields: &[&str],
    columns: usize,
) -> Result<([i64; 6], f64), PsinsError> {
    if fields.len() != columns {
        return Err(lines.error(
            line,
            format!(
                "{} values, {columns} expected (as on the header lines)",
                fields.len()
            ),
        ));
    }
    let mut counts = [0i64; 6];
    for (k, f) in fields.iter().take(6).enumerate() {
        counts[k] = f.parse::<i64>().map_err(|_| {
            lines.error(
                line,
                format!("value {} ({f:?}) is not a whole count", k + 1),
            )
        })?;
    }
    let dither = match fields.get(6) {
        Some(f) => f
            .parse::<f64>()
            .ok()
            .filter(|d| d.is_finite())
            .ok_or_else(|| lines.error(line, format!("dither {f:?} is not a number")))?,
        None => 0.0,
    };
    Ok((counts, dither))
}

/// Imports the PSINS SIMU log `input` into the folder `out_dir` (created if
/// needed) as `run.csv` or `run.bin` and `run.json`, streaming; the data
/// file is removed on an error.
pub fn import_psins(
    input: &Path,
    out_dir: &Path,
    format: DataFormat,
    unit_serial: &str,
) -> Result<ImportedRun, PsinsError> {
    validate_serial(unit_serial).map_err(|message| PsinsError::Invalid {
        path: input.to_path_buf(),
        message: format!("unit serial: {message}"),
    })?;
    let io_err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| PsinsError::Io { path, source }
    };
    let file = File::open(input).map_err(io_err(input))?;
    let mut lines = Lines {
        path: input.to_path_buf(),
        lines: TextLines::new(Box::new(BufReader::new(file))),
    };
    let header = read_header(&mut lines)?;
    std::fs::create_dir_all(out_dir).map_err(io_err(out_dir))?;
    let data = out_dir.join(data_file_name(format, false));
    let records = write_records(&mut lines, &header, &data, format).inspect_err(|_| {
        let _ = std::fs::remove_file(&data);
    })?;
    let metadata = metadata_sidecar(&data);
    write_json(
        &metadata,
        &metadata_of(&header, input, format, unit_serial)?,
    )?;
    Ok(ImportedRun {
        data,
        metadata,
        records,
        header,
    })
}

fn write_records(
    lines: &mut Lines,
    header: &PsinsHeader,
    data: &Path,
    format: DataFormat,
) -> Result<u64, PsinsError> {
    let write_err = |source| PsinsError::Io {
        path: data.to_path_buf(),
        source,
    };
    let comments = match format {
        DataFormat::Csv => vec![format!(
            "imported by sinscal {} from the PSINS SIMU log {}",
            env!("CARGO_PKG_VERSION"),
            lines.path.display()
        )],
        DataFormat::F64le => Vec::new(),
    };
    let options = WriteOptions {
        comments,
        ..WriteOptions::default()
    };
    let mut writer = RecordWriter::create(data, format, &options).map_err(write_err)?;
    let columns = if header.dither_column { 7 } else { 6 };
    let dt = header.interval_ms * 1e-3;
    let (mut k, mut dither_us) = (0u64, 0.0);
    let mut last_t = f64::NEG_INFINITY;
    while let Some(line) = lines.next_line()? {
        let (counts, dither) = read_counts(lines, line, &lines.fields(), columns)?;
        k += 1;
        dither_us += dither;
        let t = header.t0_s + k as f64 * dt + dither_us * 1e-6;
        if t <= last_t {
            return Err(lines.error(line, format!("time {t} s does not follow {last_t} s")));
        }
        last_t = t;
        let (dtheta, dv) = header.increments(&counts);
        writer
            .write_record(&Record { t, dtheta, dv })
            .map_err(write_err)?;
    }
    if k == 0 {
        return Err(PsinsError::Invalid {
            path: lines.path.clone(),
            message: "no records after the header".into(),
        });
    }
    writer.finish().map_err(write_err)?;
    Ok(k)
}

/// The run's metadata: the header's site, g and rate, and the log's own
/// fields under `psins`.
fn metadata_of(
    header: &PsinsHeader,
    input: &Path,
    format: DataFormat,
    unit_serial: &str,
) -> Result<RunMetadata, PsinsError> {
    let mut extra = std::collections::BTreeMap::new();
    extra.insert(
        "psins".to_string(),
        serde_json::to_value(header).map_err(|source| MetaError::Json {
            what: "psins header".into(),
            source,
        })?,
    );
    let meta = RunMetadata {
        unit_serial: unit_serial.to_string(),
        sample_rate_hz: 1000.0 / header.interval_ms,
        latitude_deg: header.latitude_deg,
        longitude_deg: header.longitude_deg,
        height_m: header.height_m,
        gravity_mps2: Some(header.gravity_mps2),
        format,
        scheme: None,
        station: None,
        operator: None,
        recorded_at: None,
        temperature_c: None,
        temperature_column: false,
        counts: None,
        product: None,
        notes: Some(format!(
            "imported from the PSINS SIMU log {}: axes x right, y forward, z up as logged",
            input
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned())
        )),
        extra,
    };
    meta.validate()?;
    Ok(meta)
}
