//! What can stop a calibration.

use crate::estimation::EstimationError;

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
    /// The options ask for what the estimator does not do.
    #[error("options: {0}")]
    Options(String),
}

impl From<EstimationError> for CalibError {
    fn from(e: EstimationError) -> Self {
        match e {
            EstimationError::NotPositiveDefinite(what) => {
                CalibError::Numerical(format!("{what} is not positive definite"))
            }
            EstimationError::CannotAlign(why) => CalibError::Unusable(why.to_string()),
        }
    }
}
