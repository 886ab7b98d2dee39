//! The library functions the CLI and the server call on a run stored on
//! disk (calibrate, diagnose, noise analysis): its data file read in
//! streaming passes, its metadata giving the site and rate.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use crate::calib::{
    self, CalibError, CalibrationResult, EstimateOptions, Progress, RecordSource, RunInfo,
};
use crate::io::data::{DataFormat, ReadLimits, RecordReader};
use crate::io::meta::RunMetadata;
use crate::noise::{NoiseError, NoiseOptions, NoiseReport};
use crate::record::Record;

/// A run's data file, opened afresh for every pass of the estimator.
pub struct FileSource {
    pub path: PathBuf,
    pub format: DataFormat,
    pub sample_rate_hz: f64,
    pub limits: ReadLimits,
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
        .map_err(|e| CalibError::Source(e.to_string()))?;
        Ok(Box::new(
            reader.map(|r| r.map_err(|e| CalibError::Source(e.to_string()))),
        ))
    }
}

/// Calibrates the run in `data` described by `meta`.
pub fn calibrate_file(
    data: &Path,
    meta: &RunMetadata,
    opts: &EstimateOptions,
    progress: &mut dyn FnMut(Progress),
    cancel: &AtomicBool,
) -> Result<CalibrationResult, CalibError> {
    let source = FileSource {
        path: data.to_path_buf(),
        format: meta.format,
        sample_rate_hz: meta.sample_rate_hz,
        limits: ReadLimits::default(),
    };
    let run = RunInfo {
        site: meta.site(),
        sample_rate_hz: meta.sample_rate_hz,
    };
    calib::estimate(&source, &run, opts, progress, cancel)
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
    let source = FileSource {
        path: data.to_path_buf(),
        format: meta.format,
        sample_rate_hz: meta.sample_rate_hz,
        limits: ReadLimits::default(),
    };
    let run = RunInfo {
        site: meta.site(),
        sample_rate_hz: meta.sample_rate_hz,
    };
    crate::diagnose::diagnose(&source, &run, opts, progress, cancel)
}

/// The overlapping Allan deviation and noise terms of the run in `data`
/// described by `meta`: the one function the CLI and the server call for a
/// noise analysis. Reads the file twice (pre-scan, then the Allan sums).
pub fn noise_file(
    data: &Path,
    meta: &RunMetadata,
    opts: &NoiseOptions,
    cancel: &AtomicBool,
) -> Result<NoiseReport, NoiseError> {
    let source = FileSource {
        path: data.to_path_buf(),
        format: meta.format,
        sample_rate_hz: meta.sample_rate_hz,
        limits: ReadLimits::default(),
    };
    let run = RunInfo {
        site: meta.site(),
        sample_rate_hz: meta.sample_rate_hz,
    };
    crate::noise::analyse(&source, &run, opts, cancel)
}
