//! What a calibration is given and what it reports as it goes: the run's
//! records (streamed, re-readable), the facts about the run besides them,
//! the estimator chosen, and progress.

use serde::{Deserialize, Serialize};

use super::error::CalibError;
use super::result::ResultEstimator;
use super::temperature::TemperatureCurve;
use crate::nav::Site;
use crate::record::Record;

/// A run's records, readable as many times as the estimator makes passes.
/// Implementations stream: no pass may hold the run in memory.
pub trait RecordSource: Sync {
    /// A fresh pass over the records from the first.
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError>;

    /// The unit's temperature through the run, when the run carries it
    /// record by record (SPEC §3a's column); a soaked run, which states
    /// one temperature in its metadata, and a run without temperature
    /// have none. Sources that read files make one more streaming pass.
    fn temperature(&self) -> Result<Option<TemperatureCurve>, CalibError> {
        Ok(None)
    }
}

/// What the estimator needs to know about a run besides its records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunInfo {
    pub site: Site,
    pub sample_rate_hz: f64,
}

/// Which estimator produces the primary result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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

impl From<EstimatorKind> for ResultEstimator {
    fn from(kind: EstimatorKind) -> Self {
        match kind {
            EstimatorKind::Kf => ResultEstimator::Kf,
            EstimatorKind::Lsq => ResultEstimator::Lsq,
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
