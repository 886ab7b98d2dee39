//! What can stop the discrepancy workflow.

use crate::calib::CalibError;

/// Errors of the discrepancy workflow.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// The run's scheme cannot be reconstructed or simulated.
    #[error("scheme: {0}")]
    Scheme(String),
    #[error("numerical failure: {0}")]
    Numerical(String),
}
