//! Acceptance: a product type's limits and the verdict on a calibration
//! result (accepted, rejected with the limits it fails, or needs review
//! with the reasons). Pure logic on numbers the result carries; the
//! server stores and serves what it returns.
//!
//! - `limits`: [`ProductLimits`] per canonical parameter (|value|, σ,
//!   repeatability), read from JSON with the field at fault named;
//! - `verdict`: [`Verdict`] and [`judge`], the rules of CONTRACT §6a.

pub mod limits;
pub mod verdict;

pub use limits::{LimitError, LimitKind, ParameterLimits, ProductLimits};
pub use verdict::{
    judge, Evidence, FailedLimit, ParameterCheck, Product, ReviewReason, Verdict, VerdictStatus,
    REPEATABILITY_RUNS,
};
