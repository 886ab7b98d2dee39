//! Calibration: finding the 24 parameters (and any effect states) from a
//! run. Alignment, the systematic Kalman filter, the least-squares
//! cross-check and covariance planning. No I/O happens here: records come
//! through [`RecordSource`], which the caller implements.

pub mod align;
pub mod estimate;
pub mod filter;
pub mod kf_pass;
pub mod lsq;
pub mod model_check;
pub(crate) mod normal;
pub mod options;
pub mod plan;
pub mod prescan;
pub mod priors;
pub mod result;
pub mod segment;
pub mod sensitivity;
pub mod sources;
pub mod walk;

use serde::{Deserialize, Serialize};

pub use estimate::estimate;
pub use model_check::ModelCheck;
pub use options::{EstimateOptions, NoiseDensity};
pub use result::{CalibrationResult, ParameterEstimate};
pub use segment::{DetectOptions, RunSegment, SegmentKind};

use crate::nav::Site;
use crate::record::Record;

/// Errors of a calibration.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    /// The record source failed (bad data, I/O); its message names where.
    #[error("{0}")]
    Source(String),
    #[error("cancelled")]
    Cancelled,
    /// The run cannot be calibrated as recorded (no initial dwell, too few
    /// dwells, …).
    #[error("run not usable: {0}")]
    Unusable(String),
    #[error("numerical failure: {0}")]
    Numerical(String),
}

/// A run's records, readable as many times as the estimator makes passes.
/// Implementations stream: no pass may hold the run in memory.
pub trait RecordSource: Sync {
    /// A fresh pass over the records from the first.
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError>;
}

/// What the estimator needs to know about a run besides its records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunInfo {
    pub site: Site,
    pub sample_rate_hz: f64,
}

/// Which estimator produces the primary result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EstimatorKind {
    /// The systematic Kalman filter (with the least-squares cross-check).
    #[default]
    Kf,
    /// The velocity-error-rate least squares alone.
    Lsq,
}

impl EstimatorKind {
    pub fn name(self) -> &'static str {
        match self {
            EstimatorKind::Kf => "kf",
            EstimatorKind::Lsq => "lsq",
        }
    }
}

/// Progress of a calibration, for the server's job records.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    /// 0 … 1 over the whole calibration.
    pub fraction: f64,
    /// What is being done, e.g. "pass 2 of 5".
    pub stage: String,
}
