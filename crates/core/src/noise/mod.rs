//! Noise analysis: the overlapping Allan deviation of every gyro and
//! accelerometer axis over the run's dwells (or over a whole static run),
//! and the noise terms identified from it: quantization, white noise
//! (ARW, VRW), bias instability, and rate or acceleration random walk.
//!
//! The caller finds the stretches at rest (the pipeline with the
//! estimator's pre-scan, `calib::prescan`; the estimator itself over its
//! own dwells), so this module names nothing of `calib` and the estimator
//! can build on it. One read of the records accumulates the Allan sums
//! over the records inside the stretches (`allan`, each cluster's rate over
//! its own records' intervals), in memory bounded by the longest τ, and
//! finds each axis's pulse quantum (`quantum`). Each curve is then read
//! against the model (`channel`): a weighted non-negative fit (`fit`) with
//! Q held where a quantum was found, each term's σ or bound from the
//! curve's covariance (`covariance`), the bands where the curve departs
//! from the model and their likely cause (`departures`); `term` and
//! `report` write it in reporting units.
//!
//! "Bias instability" is B of IEEE Std 952/1293: the flicker floor of the
//! Allan deviation is √(2 ln 2/π)·B ≈ 0.664·B, so B is that floor divided
//! by 0.664, not the minimum of the curve itself.

pub mod allan;
mod analyse;
pub mod channel;
pub mod covariance;
pub mod departures;
pub mod edf;
pub mod fit;
pub mod quantum;
pub mod report;
pub mod term;

use serde::{Deserialize, Serialize};

pub use analyse::{analyse, Stretches};
pub use report::{AccelNoise, GyroNoise, NoiseReport, Span, Triad};
pub use term::{Term, TermStatus};

/// Errors of a noise analysis.
#[derive(Debug, thiserror::Error)]
pub enum NoiseError {
    /// The records could not be read; the message names where.
    #[error("{0}")]
    Source(String),
    #[error("cancelled")]
    Cancelled,
    /// No dwell (or run) long enough to analyse.
    #[error(
        "no stretch at rest long enough for a noise analysis: the longest is {longest_s:.1} s, \
         at least {needed_s:.1} s is needed"
    )]
    TooShort { longest_s: f64, needed_s: f64 },
    /// The run cannot be analysed as recorded (no records, …).
    #[error("run not usable: {0}")]
    Unusable(String),
    /// The options ask for what the analysis does not do.
    #[error("options: {0}")]
    Options(String),
}

/// How the analysis runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NoiseOptions {
    /// What the caller's stretches are: the dwells, or the whole run
    /// (the pipeline finds them accordingly).
    pub span: Span,
    /// The longest τ as a fraction of the longest stretch. At 1/5 the
    /// longest dwell still holds three fifths of its length in terms;
    /// beyond it a dwell gives a handful of degrees of freedom and the
    /// curve is noise.
    pub max_tau_fraction: f64,
    /// Cluster sizes to a decade of τ (at least 4, finer than octaves).
    pub points_per_decade: usize,
    /// The largest cluster, records: the memory bound (2 of them per
    /// channel, 8 bytes each) for very long static runs.
    pub max_cluster_records: usize,
    /// The fewest τ points the fit accepts.
    pub min_points: usize,
}

impl Default for NoiseOptions {
    fn default() -> Self {
        NoiseOptions {
            span: Span::Dwells,
            max_tau_fraction: 0.2,
            points_per_decade: 10,
            max_cluster_records: 1 << 19,
            min_points: 8,
        }
    }
}

impl NoiseOptions {
    pub fn validate(&self) -> Result<(), NoiseError> {
        if !(self.max_tau_fraction > 0.0 && self.max_tau_fraction <= 0.5) {
            return Err(NoiseError::Options(format!(
                "max_tau_fraction {} must be in (0, 0.5]",
                self.max_tau_fraction
            )));
        }
        if !(4..=100).contains(&self.points_per_decade) {
            return Err(NoiseError::Options(format!(
                "points_per_decade {} must be in 4..=100",
                self.points_per_decade
            )));
        }
        if self.max_cluster_records == 0 || self.min_points < 4 {
            return Err(NoiseError::Options(
                "max_cluster_records must be positive and min_points at least 4".into(),
            ));
        }
        Ok(())
    }
}
