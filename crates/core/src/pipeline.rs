//! The library functions the CLI and the server call on a run stored on
//! disk (calibrate, diagnose, noise analysis, compensation): its data file
//! read in streaming passes, its metadata giving the site and rate.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use crate::calib::result::{RunTemperature, SchemeCoverage};
use crate::calib::temperature::TemperatureCurve;
use crate::calib::{
    self, CalibError, CalibrationResult, DetectOptions, EstimateOptions, Progress, RecordSource,
    RunInfo, SegmentKind,
};
use crate::compensation::thermal::ThermalTerms;
use crate::compensation::CompensationFile;
use crate::io::data::{
    CountsConversion, DataError, DataFormat, ReadLimits, RecordReader, RecordWriter, WriteOptions,
};
use crate::io::meta::{write_json, MetaError, RunMetadata};
use crate::io::run::metadata_sidecar;
use crate::model::{Compensator, ErrorParameters, Group};
use crate::noise::{NoiseError, NoiseOptions, NoiseReport, Span, Stretches};
use crate::record::Record;

/// A run's data file, opened afresh for every pass of the estimator.
pub struct FileSource {
    pub path: PathBuf,
    pub format: DataFormat,
    pub sample_rate_hz: f64,
    pub limits: ReadLimits,
    /// f64le: each record carries `temp_c` (the metadata's
    /// `temperature_column`).
    pub temperature_column: bool,
    /// A counts file's nominal conversion (the metadata's `counts`).
    pub counts: Option<CountsConversion>,
}

impl FileSource {
    /// The run in `data` as `meta` describes it: its records, read with
    /// the default limits, and the site and rate the estimators need.
    pub fn of_run(data: &Path, meta: &RunMetadata) -> (FileSource, RunInfo) {
        let source = FileSource {
            path: data.to_path_buf(),
            format: meta.format,
            sample_rate_hz: meta.sample_rate_hz,
            limits: ReadLimits::default(),
            temperature_column: meta.temperature_column,
            counts: meta.counts,
        };
        let run = RunInfo {
            site: meta.site(),
            sample_rate_hz: meta.sample_rate_hz,
        };
        (source, run)
    }
}

impl RecordSource for FileSource {
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError> {
        let reader = RecordReader::open_with_limits(
            &self.path,
            self.format,
            self.sample_rate_hz,
            self.limits,
        )
        .map_err(|e| CalibError::Source(e.to_string()))?
        .with_temperature_column(self.temperature_column)
        .with_counts(self.counts);
        Ok(Box::new(
            reader.map(|r| r.map_err(|e| CalibError::Source(e.to_string()))),
        ))
    }

    /// The `temp_c` column: one more streaming pass, made only when the
    /// header (CSV) or the metadata (f64le) says there is a column.
    fn temperature(&self) -> Result<Option<TemperatureCurve>, CalibError> {
        temperature_curve(self).map_err(|e| CalibError::Source(e.to_string()))
    }
}

/// The run's temperature through it from its `temp_c` column, one
/// streaming pass; `None` without a column.
fn temperature_curve(source: &FileSource) -> Result<Option<TemperatureCurve>, DataError> {
    let mut reader = RecordReader::open_with_limits(
        &source.path,
        source.format,
        source.sample_rate_hz,
        source.limits,
    )?
    .with_temperature_column(source.temperature_column)
    .with_counts(source.counts);
    if !reader.has_temperature() {
        return Ok(None);
    }
    for record in reader.by_ref() {
        record?;
    }
    let Some(t) = reader.temperature_summary() else {
        return Ok(None);
    };
    let summary = RunTemperature {
        mean_c: t.mean_c,
        min_c: t.min_c,
        max_c: t.max_c,
        max_rate_c_per_min: t.max_rate_c_per_min.unwrap_or(0.0),
    };
    let points = reader
        .temperature_history()
        .into_iter()
        .map(|p| (p.t_s, p.temp_c))
        .collect();
    Ok(TemperatureCurve::new(points, summary))
}

/// Calibrates the run in `data` described by `meta`.
pub fn calibrate_file(
    data: &Path,
    meta: &RunMetadata,
    opts: &EstimateOptions,
    progress: &mut dyn FnMut(Progress),
    cancel: &AtomicBool,
) -> Result<CalibrationResult, CalibError> {
    let (source, run) = FileSource::of_run(data, meta);
    let mut result = calib::estimate(&source, &run, opts, progress, cancel)?;
    // A soaked run states its temperature once, in its metadata; a run
    // with a temp_c column has it from the column (the estimator's).
    if let Some(t) = meta.temperature_c {
        result.temperature = Some(RunTemperature::soaked(t));
    }
    result.scheme_coverage = scheme_coverage(meta, &result);
    Ok(result)
}

/// The dwells the calibration found against the positions of the scheme
/// the metadata declares (a built-in's positions do not depend on its
/// dwell); `None` when it declares none or names no known scheme.
fn scheme_coverage(meta: &RunMetadata, result: &CalibrationResult) -> Option<SchemeCoverage> {
    let declared = meta.scheme.as_ref()?.resolve(None).ok()?;
    let dwells_found = result
        .segments
        .iter()
        .filter(|s| s.kind == SegmentKind::Dwell)
        .count();
    Some(SchemeCoverage {
        dwells_found,
        positions_declared: declared.positions(),
    })
}

/// Diagnoses the run in `data` described by `meta`: the one
/// function the CLI and the server call for the discrepancy workflow.
pub fn diagnose_file(
    data: &Path,
    meta: &RunMetadata,
    opts: &crate::diagnose::DiagnoseOptions,
    progress: &mut dyn FnMut(Progress),
    cancel: &AtomicBool,
) -> Result<crate::diagnose::DiagnoseReport, crate::diagnose::DiagnoseError> {
    let (source, run) = FileSource::of_run(data, meta);
    crate::diagnose::diagnose(&source, &run, opts, progress, cancel)
}

/// The overlapping Allan deviation and noise terms of the run in `data`
/// described by `meta`: the one function the CLI and the server call for a
/// noise analysis. Reads the file twice: the estimator's pre-scan finds the
/// dwells (or the run's extent, for a whole static run), then the noise
/// analysis reads the records over them.
pub fn noise_file(
    data: &Path,
    meta: &RunMetadata,
    opts: &NoiseOptions,
    cancel: &AtomicBool,
) -> Result<NoiseReport, NoiseError> {
    let (source, run) = FileSource::of_run(data, meta);
    let (stretches, warnings) = still_stretches(&source, &run, opts.span, cancel)?;
    let records = source.records().map_err(noise_error)?;
    let mut report = crate::noise::analyse(
        records.map(|r| r.map_err(noise_error)),
        run.sample_rate_hz,
        &stretches,
        opts,
        cancel,
    )?;
    report.warnings.splice(0..0, warnings);
    Ok(report)
}

/// The stretches a noise analysis runs over, from the estimator's
/// pre-scan: its dwells, or the whole run (with a warning when the
/// pre-scan finds turns in a run declared static).
fn still_stretches(
    source: &FileSource,
    run: &RunInfo,
    span: Span,
    cancel: &AtomicBool,
) -> Result<(Stretches, Vec<String>), NoiseError> {
    let scan = calib::prescan::prescan(source, run, &DetectOptions::default(), cancel)
        .map_err(noise_error)?;
    let mut warnings = Vec::new();
    let windows = match span {
        Span::Dwells => scan.dwells().map(|d| (d.t_start, d.t_end)).collect(),
        Span::WholeRun => {
            let motions = scan
                .segments
                .iter()
                .filter(|s| s.kind == SegmentKind::Motion)
                .count();
            if motions > 0 {
                warnings.push(format!(
                    "the whole run was analysed but the pre-scan finds {motions} motion(s) in it: \
                     turns raise the curve; analyse the dwells instead"
                ));
            }
            vec![(scan.t_begin, scan.t_end)]
        }
    };
    Ok((Stretches { span, windows }, warnings))
}

/// The estimator's errors as the noise analysis reports them.
fn noise_error(e: CalibError) -> NoiseError {
    match e {
        CalibError::Source(m) => NoiseError::Source(m),
        CalibError::Cancelled => NoiseError::Cancelled,
        CalibError::Unusable(m) | CalibError::Numerical(m) => NoiseError::Unusable(m),
        CalibError::Options(m) => NoiseError::Options(m),
    }
}

/// Where and how [`compensate_file`] writes the compensated run.
#[derive(Clone, Debug)]
pub struct CompensateTarget {
    /// The data file; its metadata goes to the sidecar beside it
    /// (`io::run::metadata_sidecar`).
    pub data: PathBuf,
    pub format: DataFormat,
    /// Gzip the CSV.
    pub gzip: bool,
    /// Apply a file whose unit serial differs from the run's.
    pub any_unit: bool,
}

/// What [`compensate_file`] wrote.
#[derive(Clone, Debug)]
pub struct CompensatedRun {
    pub data: PathBuf,
    pub metadata: PathBuf,
    pub records: u64,
}

/// Errors compensating a run file.
#[derive(Debug, thiserror::Error)]
pub enum CompensateError {
    #[error(transparent)]
    Read(#[from] DataError),
    #[error("{path}: {source}")]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Meta(#[from] MetaError),
    #[error("{0}")]
    Refused(String),
}

/// Compensates the run in `data` (described by `meta`) with `file`,
/// streaming every record through the exact inversion of SPEC §2 into a
/// run of the same contract at `target`, whose metadata is the run's own
/// with `format` set and the applied file under `compensation` (a field
/// the contract keeps, CONTRACT §5). A rate file comes out as increments.
/// On an error the partial data file is removed.
pub fn compensate_file(
    data: &Path,
    meta: &RunMetadata,
    file: &CompensationFile,
    target: &CompensateTarget,
) -> Result<CompensatedRun, CompensateError> {
    check_compensate_paths(data, target)?;
    if let Some(serial) = &file.provenance.unit_serial {
        if *serial != meta.unit_serial && !target.any_unit {
            return Err(CompensateError::Refused(format!(
                "the compensation is unit {serial}'s, the run is unit {}'s",
                meta.unit_serial
            )));
        }
    }
    let metadata = metadata_sidecar(&target.data);
    let records = write_compensated(data, meta, file, target).inspect_err(|_| {
        let _ = std::fs::remove_file(&target.data);
    })?;
    let mut out_meta = meta.clone();
    out_meta.format = target.format;
    // A CSV input states its column in its header; the output's f64le
    // needs the metadata to say it.
    out_meta.temperature_column = records.1;
    let applied = serde_json::to_value(file).map_err(|source| MetaError::Json {
        what: "compensation".into(),
        source,
    })?;
    out_meta.extra.insert("compensation".into(), applied);
    write_json(&metadata, &out_meta)?;
    Ok(CompensatedRun {
        data: target.data.clone(),
        metadata,
        records: records.0,
    })
}

/// The parameters a compensation file puts in force over a run: its own,
/// or with thermal terms, at the run's temperature (a soak's metadata, or
/// the column at mid-record, with k Ṫ on the gyro biases).
enum ParametersInForce {
    Fixed(Compensator),
    Following {
        at_reference: ErrorParameters,
        terms: Box<ThermalTerms>,
        temperature: TemperatureCurve,
    },
}

impl ParametersInForce {
    fn new(
        data: &Path,
        meta: &RunMetadata,
        file: &CompensationFile,
    ) -> Result<Self, CompensateError> {
        let Some(terms) = &file.thermal else {
            return Ok(Self::Fixed(file.parameters().compensator()));
        };
        if let Some(t) = meta.temperature_c {
            return Ok(Self::Fixed(file.parameters_at(t).compensator()));
        }
        let (source, _) = FileSource::of_run(data, meta);
        match temperature_curve(&source)? {
            Some(temperature) => Ok(Self::Following {
                at_reference: file.parameters(),
                terms: Box::new(terms.clone()),
                temperature,
            }),
            None => Err(CompensateError::Refused(
                "the compensation carries thermal terms and the run states no temperature \
                 (neither metadata temperature_c nor a temp_c column): its parameters at the \
                 unit's temperature are unknown"
                    .into(),
            )),
        }
    }

    /// The compensator for a record whose middle is at `t_mid`.
    fn at(&self, t_mid: f64) -> std::borrow::Cow<'_, Compensator> {
        match self {
            Self::Fixed(c) => std::borrow::Cow::Borrowed(c),
            Self::Following {
                at_reference,
                terms,
                temperature,
            } => {
                let mut p = terms.parameters_at(at_reference, temperature.temperature_c(t_mid));
                let k = terms.gyro_bias_from_rate(temperature.rate_c_per_s(t_mid));
                for (b, dk) in p.si[Group::GyroBias.range()].iter_mut().zip(k.iter()) {
                    *b += dk;
                }
                std::borrow::Cow::Owned(p.compensator())
            }
        }
    }
}

/// The output must not replace the input's data, nor its sidecar.
fn check_compensate_paths(data: &Path, target: &CompensateTarget) -> Result<(), CompensateError> {
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    };
    let sidecar = metadata_sidecar(&target.data);
    if same(data, &target.data) || same(data, &sidecar) {
        return Err(CompensateError::Refused(format!(
            "{} would overwrite the run being compensated",
            target.data.display()
        )));
    }
    Ok(())
}

fn write_compensated(
    data: &Path,
    meta: &RunMetadata,
    file: &CompensationFile,
    target: &CompensateTarget,
) -> Result<(u64, bool), CompensateError> {
    let reader = RecordReader::open(data, meta.format, meta.sample_rate_hz)?
        .with_temperature_column(meta.temperature_column)
        .with_counts(meta.counts);
    let temperature_column = reader.has_temperature();
    let options = if target.format == DataFormat::Csv {
        let p = &file.provenance;
        WriteOptions {
            gzip: target.gzip,
            comments: vec![format!(
                "compensated by sinscal {} with {} ({}{}); unit {}",
                env!("CARGO_PKG_VERSION"),
                p.source.as_deref().unwrap_or("a compensation file"),
                p.model,
                p.run_id
                    .as_deref()
                    .map_or(String::new(), |id| format!(", run {id}")),
                meta.unit_serial
            )],
            temperature_column,
        }
    } else {
        WriteOptions {
            gzip: target.gzip,
            comments: Vec::new(),
            temperature_column,
        }
    };
    let write_err = |source| CompensateError::Write {
        path: target.data.clone(),
        source,
    };
    let mut writer =
        RecordWriter::create(&target.data, target.format, &options).map_err(write_err)?;
    let mut records = 0;
    let parameters = ParametersInForce::new(data, meta, file)?;
    let mut reader = reader;
    while let Some(rec) = reader.next() {
        let rec = rec?;
        // Each record over its own interval (SPEC §2a); a gap passes
        // through as a gap.
        let dt = reader.interval().dt;
        let rec = parameters.at(rec.t - 0.5 * dt).record(&rec, dt);
        // The temperature column, if any, passes through unchanged.
        match reader.temperature_c() {
            Some(temp_c) => writer.write_record_with_temperature(&rec, temp_c),
            None => writer.write_record(&rec),
        }
        .map_err(write_err)?;
        records += 1;
    }
    writer.finish().map_err(write_err)?;
    Ok((records, temperature_column))
}
