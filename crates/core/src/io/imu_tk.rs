//! imu_tk's recordings (a pair of text files, accelerometer and gyro, each
//! line `t x y z` separated by blanks, both at the same stamps) imported
//! as SPEC §5 runs of raw outputs: a `counts` CSV of the samples as
//! recorded and the datasheet's nominal offset and scale of each channel
//! in the metadata (`counts`, kind `rates`), so that the 24 parameters are
//! what is left after that conversion (SPEC §2a).
//!
//! Either file may be gzip-compressed (told by its magic bytes). imu_tk
//! stores neither rate nor site: the rate is the median step of the
//! first stamps (read ahead, not kept), and the site is the caller's.
//! Both files are read line by line in step; nothing holds the run.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use super::data::{CountedKind, CountsConversion, DataFormat, TriadConversion};
use super::meta::{write_json, MetaError, RunMetadata};
use super::run::metadata_sidecar;
use super::text_lines::TextLines;
use crate::nav::Site;

/// Stamps read ahead to find the rate.
const RATE_PROBE_STEPS: usize = 100;

/// Errors importing an imu_tk recording.
#[derive(Debug, thiserror::Error)]
pub enum ImuTkError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A line breaks the format: the file, the line (1-based) and why.
    #[error("{path}, line {line}: {message}")]
    Line {
        path: PathBuf,
        line: u64,
        message: String,
    },
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Meta(#[from] MetaError),
}

/// A channel triad's datasheet conversion as imu_tk's users state it: the
/// count that reads zero and the counts per unit (m/s², rad/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NominalTriad {
    pub offset: [f64; 3],
    pub counts_per_unit: [f64; 3],
}

impl NominalTriad {
    fn conversion(&self) -> TriadConversion {
        TriadConversion {
            offset: self.offset,
            weight: self.counts_per_unit.map(|c| 1.0 / c),
        }
    }
}

/// What an import is given besides the two files.
#[derive(Clone, Debug)]
pub struct ImuTkImport {
    pub unit_serial: String,
    pub site: Site,
    pub accel: NominalTriad,
    pub gyro: NominalTriad,
}

/// What an import wrote.
#[derive(Clone, Debug)]
pub struct ImportedRun {
    pub data: PathBuf,
    pub metadata: PathBuf,
    pub records: u64,
    pub sample_rate_hz: f64,
}

/// One file's lines of `t x y z`, read through gzip when the file starts
/// with its magic bytes.
struct Samples {
    path: PathBuf,
    lines: TextLines,
}

impl Samples {
    fn open(path: &Path) -> Result<Self, ImuTkError> {
        let io_err = |source| ImuTkError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut file = BufReader::new(File::open(path).map_err(io_err)?);
        let gzip = file.fill_buf().map_err(io_err)?.starts_with(&[0x1f, 0x8b]);
        let reader: Box<dyn BufRead> = if gzip {
            Box::new(BufReader::new(flate2::bufread::MultiGzDecoder::new(file)))
        } else {
            Box::new(file)
        };
        Ok(Samples {
            path: path.to_path_buf(),
            lines: TextLines::new(reader),
        })
    }

    fn error(&self, message: impl Into<String>) -> ImuTkError {
        ImuTkError::Line {
            path: self.path.clone(),
            line: self.lines.line,
            message: message.into(),
        }
    }

    /// The next sample (blank lines skipped), `None` at the end.
    fn next_sample(&mut self) -> Result<Option<[f64; 4]>, ImuTkError> {
        let more = self
            .lines
            .advance(str::is_empty)
            .map_err(|source| ImuTkError::Io {
                path: self.path.clone(),
                source,
            })?;
        if more {
            self.parse().map(Some)
        } else {
            Ok(None)
        }
    }

    fn parse(&self) -> Result<[f64; 4], ImuTkError> {
        let fields: Vec<&str> = self.lines.text.split_whitespace().collect();
        if fields.len() != 4 {
            return Err(self.error(format!("{} values, expected 4 (t x y z)", fields.len())));
        }
        let mut v = [0.0; 4];
        for (i, (slot, text)) in v.iter_mut().zip(&fields).enumerate() {
            *slot = text
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    self.error(format!(
                        "{} `{text}` is not a finite number",
                        ["t", "x", "y", "z"][i]
                    ))
                })?;
        }
        Ok(v)
    }
}

/// The median step of the first stamps of `path`, as a rate in Hz.
fn probe_rate(path: &Path) -> Result<f64, ImuTkError> {
    let mut samples = Samples::open(path)?;
    let mut stamps = Vec::with_capacity(RATE_PROBE_STEPS + 1);
    while stamps.len() <= RATE_PROBE_STEPS {
        match samples.next_sample()? {
            Some(s) => stamps.push(s[0]),
            None => break,
        }
    }
    let mut steps: Vec<f64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    match steps.get(steps.len() / 2) {
        Some(&step) if step > 0.0 => Ok(1.0 / step),
        _ => Err(ImuTkError::Invalid(format!(
            "{}: fewer than two increasing stamps, no rate",
            path.display()
        ))),
    }
}

/// Imports the recording `accel` + `gyro` into `out` (run.csv and
/// run.json), refusing the first line that breaks the format or whose
/// stamps differ between the files.
pub fn import_imu_tk(
    accel: &Path,
    gyro: &Path,
    out: &Path,
    how: &ImuTkImport,
) -> Result<ImportedRun, ImuTkError> {
    std::fs::create_dir_all(out).map_err(|source| ImuTkError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let sample_rate_hz = probe_rate(accel)?;
    let data = out.join("run.csv");
    let records = write_counts(accel, gyro, &data)?;
    let meta = RunMetadata {
        unit_serial: how.unit_serial.clone(),
        sample_rate_hz,
        latitude_deg: how.site.latitude_deg,
        longitude_deg: how.site.longitude_deg,
        height_m: how.site.height_m,
        gravity_mps2: how.site.gravity_mps2,
        format: DataFormat::Csv,
        scheme: None,
        station: None,
        operator: None,
        recorded_at: None,
        temperature_c: None,
        temperature_column: false,
        counts: Some(CountsConversion {
            kind: CountedKind::Rates,
            gyro: how.gyro.conversion(),
            accel: how.accel.conversion(),
        }),
        product: None,
        notes: Some(format!(
            "imported from the imu_tk recording {} + {}: raw samples, datasheet conversion",
            accel.display(),
            gyro.display()
        )),
        extra: Default::default(),
    };
    meta.validate()?;
    let metadata = metadata_sidecar(&data);
    write_json(&metadata, &meta)?;
    Ok(ImportedRun {
        data,
        metadata,
        records,
        sample_rate_hz,
    })
}

/// Writes the counts CSV, the two files in step; the number of records.
fn write_counts(accel: &Path, gyro: &Path, data: &Path) -> Result<u64, ImuTkError> {
    let (mut acc, mut gyr) = (Samples::open(accel)?, Samples::open(gyro)?);
    let io_err = |source| ImuTkError::Io {
        path: data.to_path_buf(),
        source,
    };
    let mut w = BufWriter::new(File::create(data).map_err(io_err)?);
    writeln!(w, "t,cgx,cgy,cgz,cax,cay,caz").map_err(io_err)?;
    let mut records = 0u64;
    loop {
        match (acc.next_sample()?, gyr.next_sample()?) {
            (None, None) => break,
            (Some(_), None) => return Err(gyr.error("ends before the accelerometer file")),
            (None, Some(_)) => return Err(acc.error("ends before the gyro file")),
            (Some(a), Some(g)) => {
                if a[0] != g[0] {
                    return Err(gyr.error(format!(
                        "stamp {} differs from the accelerometer's {} (line {})",
                        g[0], a[0], acc.lines.line
                    )));
                }
                writeln!(
                    w,
                    "{},{},{},{},{},{},{}",
                    a[0], g[1], g[2], g[3], a[1], a[2], a[3]
                )
                .map_err(io_err)?;
                records += 1;
            }
        }
    }
    if records == 0 {
        return Err(ImuTkError::Invalid(format!(
            "{}: no samples",
            accel.display()
        )));
    }
    w.flush().map_err(io_err)?;
    Ok(records)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::data::RecordReader;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn how() -> ImuTkImport {
        ImuTkImport {
            unit_serial: "XSENS-1".into(),
            site: Site::new(45.4, 11.9, 12.0),
            accel: NominalTriad {
                offset: [33123.0, 33276.0, 32360.0],
                counts_per_unit: [415.0, 413.0, 415.0],
            },
            gyro: NominalTriad {
                offset: [32768.0, 32466.0, 32485.0],
                counts_per_unit: [4778.0, 4758.0, 4766.0],
            },
        }
    }

    /// imu_tk's layout, written as its recordings are: the run reads back
    /// through the metadata's conversion to the samples' physical values.
    #[test]
    fn a_recording_in_imu_tk_layout_reads_back_as_its_physical_values() {
        let dir = tempfile::tempdir().unwrap();
        let (mut acc, mut gyr) = (String::new(), String::new());
        for k in 0..300 {
            let t = 0.02984 + 0.01 * k as f64;
            acc.push_str(&format!(
                "   {t:.7e}   {:.7e}   {:.7e}   {:.7e}\n",
                33123.0 + (k % 7) as f64,
                33276.0,
                32360.0 + 4074.0
            ));
            gyr.push_str(&format!(
                "   {t:.7e}   {:.7e}   {:.7e}   {:.7e}\n",
                32768.0 + 4778.0,
                32466.0,
                32485.0 - (k % 3) as f64
            ));
        }
        let a = write(dir.path(), "acc.mat", &acc);
        let g = write(dir.path(), "gyro.mat", &gyr);
        let run = import_imu_tk(&a, &g, &dir.path().join("run"), &how()).unwrap();
        assert_eq!(run.records, 300);
        assert!((run.sample_rate_hz - 100.0).abs() < 1e-6);
        let meta = RunMetadata::from_json(&std::fs::read(&run.metadata).unwrap()).unwrap();
        let records: Vec<_> = RecordReader::open(&run.data, meta.format, meta.sample_rate_hz)
            .unwrap()
            .with_counts(meta.counts)
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(records.len(), 300);
        let r = &records[10];
        let dt = r.t - records[9].t;
        assert!((r.dtheta[0] / dt - 1.0).abs() < 1e-9, "1 rad/s on x");
        assert!((r.dv[2] / dt - 4074.0 / 415.0).abs() < 1e-9);
        assert!(
            (r.dv[0] / dt - 3.0 / 415.0).abs() < 1e-9,
            "sample 10: 3 counts"
        );
    }

    #[test]
    fn refusals_name_the_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let a = write(dir.path(), "a", "0.01 1 2 3\n0.02 1 2 3\n0.03 1 2 3\n");
        let g = write(dir.path(), "g", "0.01 1 2 3\n0.025 1 2 3\n0.03 1 2 3\n");
        let e = import_imu_tk(&a, &g, &dir.path().join("o1"), &how()).unwrap_err();
        assert!(
            e.to_string().contains("g, line 2") && e.to_string().contains("differs"),
            "{e}"
        );
        let g = write(dir.path(), "g2", "0.01 1 2 3\n0.02 1 x 3\n0.03 1 2 3\n");
        let e = import_imu_tk(&a, &g, &dir.path().join("o2"), &how()).unwrap_err();
        assert!(e.to_string().contains("g2, line 2: y `x`"), "{e}");
        let g = write(dir.path(), "g3", "0.01 1 2 3\n0.02 1 2 3\n");
        let e = import_imu_tk(&a, &g, &dir.path().join("o3"), &how()).unwrap_err();
        assert!(e.to_string().contains("ends before"), "{e}");
        let g = write(dir.path(), "g4", "0.01 1 2 3\n0.02 1 2\n0.03 1 2 3\n");
        let e = import_imu_tk(&a, &g, &dir.path().join("o4"), &how()).unwrap_err();
        assert!(e.to_string().contains("3 values, expected 4"), "{e}");
    }
}
