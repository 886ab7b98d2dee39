//! The one library function the CLI and the server call to calibrate a run
//! stored on disk: its data file read in streaming passes, its metadata
//! giving the site and rate.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use crate::calib::{
    self, CalibError, CalibrationResult, EstimateOptions, Progress, RecordSource, RunInfo,
};
use crate::io::data::{DataFormat, ReadLimits, RecordReader};
use crate::io::meta::RunMetadata;
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
