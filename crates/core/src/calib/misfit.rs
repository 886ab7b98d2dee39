//! What the model check reports: the shapes of misfit it tests for, the
//! scores beyond the bound, and the verdict on a run (SPEC §5
//! `model_check`). Plain data, shared by the check, the calibration result
//! and the server's review.

use serde::{Deserialize, Serialize};

/// Total false-alarm rate of the check on a run the model explains.
pub const FALSE_ALARM_RATE: f64 = 1e-3;

/// A shape of misfit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// A velocity step across the turn before the dwell: the misfit
    /// arose in motion.
    TurnStep,
    /// A constant velocity drift at rest in the dwell.
    Drift,
    /// A drift that grows or shrinks across the dwell.
    DriftChange,
    /// A drift that bends across the dwell.
    Curvature,
    /// The dwells' drifts growing over the run.
    TrendOverRun,
}

impl Shape {
    pub(crate) fn words(self) -> &'static str {
        match self {
            Shape::TurnStep => "velocity step across the turn (in motion)",
            Shape::Drift => "velocity drift at rest",
            Shape::DriftChange => "drift changing within the dwell",
            Shape::Curvature => "drift bending within the dwell",
            Shape::TrendOverRun => "drift growing over the run",
        }
    }
}

/// A navigation-frame axis (the zero-velocity residuals are in n).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NavAxis {
    E,
    N,
    U,
}

pub(crate) const NAV_AXES: [NavAxis; 3] = [NavAxis::E, NavAxis::N, NavAxis::U];

impl NavAxis {
    pub(crate) fn name(self) -> &'static str {
        match self {
            NavAxis::E => "east",
            NavAxis::N => "north",
            NavAxis::U => "up",
        }
    }
}

/// One score beyond the bound: where the model fails.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Misfit {
    pub shape: Shape,
    /// 1-based dwell number (the dwell the turn led into, for a step);
    /// absent for a trend over the run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dwell: Option<usize>,
    /// The stretch of the run, s.
    pub t_start: f64,
    pub t_end: f64,
    pub axis: NavAxis,
    /// The score: N(0, 1) under a model that explains the run.
    pub z: f64,
    /// The misfit in physical units where it has one: m/s for a step,
    /// m/s² for a drift.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
}

/// The verdict on one run (SPEC §5 `model_check`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelCheck {
    pub adequate: bool,
    /// Σ z² over every dwell shape and axis.
    pub statistic: f64,
    /// Its χ² quantile at half the false-alarm rate.
    pub threshold: f64,
    /// Number of scores in `statistic`.
    pub dof: usize,
    /// Largest |z| over the scores and the trends over the run.
    pub largest_z: f64,
    /// Its Bonferroni bound at half the false-alarm rate.
    pub largest_z_threshold: f64,
    pub false_alarm_rate: f64,
    pub method: String,
    /// The verdict and where the misfit lies, in words.
    pub summary: String,
    /// Every score beyond the bound, largest first (at most 20), or the
    /// largest few when only the χ² test fails.
    pub findings: Vec<Misfit>,
}
