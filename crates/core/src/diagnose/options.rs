//! What the discrepancy workflow can be asked to do: the base
//! calibration's options and the thresholds of the selection.

use serde::{Deserialize, Serialize};

use crate::calib::EstimateOptions;

/// Tunable parts of the workflow.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DiagnoseOptions {
    /// The base calibration's options.
    pub estimate: EstimateOptions,
    /// A candidate is named when its BIC beats the current model's by
    /// more than this (10 is "very strong" evidence on the Kass–Raftery
    /// scale: a likelihood ratio above e⁵ after the parameter charge).
    pub bic_threshold: f64,
    /// The gap is significant when its χ² exceeds its expectation under
    /// noise by this many σ of χ².
    pub significance_sigma: f64,
    /// Most effects added.
    pub max_effects: usize,
    /// Most points of each series in the report.
    pub series_points: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            estimate: EstimateOptions {
                cross_check: false,
                ..EstimateOptions::default()
            },
            bic_threshold: 10.0,
            significance_sigma: 3.0,
            max_effects: 4,
            series_points: 1000,
        }
    }
}
