//! A run on disk: the data file and its metadata (and, for simulated runs,
//! the truth) in one folder.

use std::path::{Path, PathBuf};

use super::data::{DataFormat, RecordWriter, WriteOptions};
use super::meta::{write_json, MetaError, RunMetadata, Truth};
use crate::sim::{simulate, SchemeRef, SimConfig, SimError};

/// Errors writing a run.
#[derive(Debug, thiserror::Error)]
pub enum RunWriteError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error(transparent)]
    Meta(#[from] MetaError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Where a written run's files are.
#[derive(Clone, Debug)]
pub struct RunFiles {
    pub data: PathBuf,
    pub metadata: PathBuf,
    pub truth: PathBuf,
    pub records: u64,
}

/// The data file name for a format: `run.csv`, `run.csv.gz` or `run.bin`.
pub fn data_file_name(format: DataFormat, gzip: bool) -> &'static str {
    match (format, gzip) {
        (DataFormat::Csv, false) => "run.csv",
        (DataFormat::Csv, true) => "run.csv.gz",
        (DataFormat::F64le, _) => "run.bin",
    }
}

/// The metadata file that goes with a data file: the same folder, the
/// file name up to its first dot, then `.json` (`run.csv.gz` → `run.json`).
/// What the command line reads when no `--meta` is given, and how
/// [`write_simulated_run`] names what it writes.
pub fn metadata_sidecar(data: &Path) -> PathBuf {
    let name = data.file_name().and_then(|n| n.to_str()).unwrap_or("run");
    let stem = name.split('.').next().unwrap_or(name);
    data.with_file_name(format!("{stem}.json"))
}

/// Simulates `cfg` into `dir` (created if needed): the data streamed to
/// `run.csv`/`run.csv.gz`/`run.bin`, then `run.json` (metadata for
/// `unit_serial`) and `truth.json`, written after the records so that it
/// holds the wandering biases' `bias_mean_over_run` (SPEC §2a). A run with a temperature history has
/// the `temp_c` column (T at each record's time); a soaked one states
/// `temperature_c` in its metadata.
pub fn write_simulated_run(
    cfg: &SimConfig,
    dir: &Path,
    format: DataFormat,
    gzip: bool,
    unit_serial: &str,
) -> Result<RunFiles, RunWriteError> {
    let io_err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| RunWriteError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let data = dir.join(data_file_name(format, gzip));
    let options = WriteOptions {
        gzip,
        comments: vec![format!(
            "simulated by sinscal {}: scheme {}, seed {}",
            env!("CARGO_PKG_VERSION"),
            cfg.scheme.name,
            cfg.seed
        )],
        temperature_column: cfg.temperature_column(),
    };
    let options = if format == DataFormat::F64le {
        WriteOptions {
            temperature_column: options.temperature_column,
            ..WriteOptions::default()
        }
    } else {
        options
    };
    let mut sim = simulate(cfg)?;
    let mut writer = RecordWriter::create(&data, format, &options).map_err(io_err(&data))?;
    let mut records = 0;
    let column = cfg.temperature_column();
    while let Some(rec) = sim.next() {
        match sim.temperature_c(rec.t).filter(|_| column) {
            Some(temp_c) => writer.write_record_with_temperature(&rec, temp_c),
            None => writer.write_record(&rec),
        }
        .map_err(io_err(&data))?;
        records += 1;
    }
    writer.finish().map_err(io_err(&data))?;

    let meta = RunMetadata {
        unit_serial: unit_serial.to_string(),
        sample_rate_hz: cfg.sample_rate_hz,
        latitude_deg: cfg.site.latitude_deg,
        longitude_deg: cfg.site.longitude_deg,
        height_m: cfg.site.height_m,
        gravity_mps2: cfg.site.gravity_mps2,
        format,
        scheme: Some(SchemeRef::Inline(cfg.scheme.clone())),
        station: None,
        operator: None,
        recorded_at: None,
        // A soak is stated once; a history is the column.
        temperature_c: cfg.temperature.as_ref().and_then(|h| h.soak_c()),
        temperature_column: column && format == DataFormat::F64le,
        counts: None,
        product: None,
        notes: Some("simulated run".into()),
        extra: Default::default(),
    };
    meta.validate()?;
    let metadata = metadata_sidecar(&data);
    write_json(&metadata, &meta)?;
    let truth = dir.join("truth.json");
    let mut truth_doc = Truth::from_sim_config(cfg);
    truth_doc.bias_mean_over_run = sim.bias_mean_over_run();
    write_json(&truth, &truth_doc)?;
    Ok(RunFiles {
        data,
        metadata,
        truth,
        records,
    })
}
