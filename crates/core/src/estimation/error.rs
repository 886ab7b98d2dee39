//! What stops the toolkit: typed, so that a caller can tell a matrix that
//! lost definiteness from a run that cannot be aligned.

/// Errors of the estimation toolkit.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EstimationError {
    /// A covariance or information matrix that must be positive definite
    /// is not (named).
    #[error("numerical failure: {0} is not positive definite")]
    NotPositiveDefinite(&'static str),
    /// The first dwell does not fix the attitude (why).
    #[error("run not usable: {0}")]
    CannotAlign(&'static str),
}
