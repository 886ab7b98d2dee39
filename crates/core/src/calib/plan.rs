//! Covariance analysis before any data exists: the 1-σ the filter would
//! reach on a scheme with a given noise. It runs the very filter on a
//! noise-free simulated run of an error-free unit with the noise densities
//! imposed: the σ a Kalman filter reports depends on the motion and the
//! noise model, not on the measured values.
//!
//! The motion includes the start attitude: a turn about a navigation axis
//! (SPEC §4, `"frame": "nav"`) turns the unit about whatever body
//! direction that axis has at the start, so the same scheme excites
//! different parameters at another heading or tilt.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::error::CalibError;
use super::options::{EstimateOptions, NoiseDensity};
use super::run::EstimatorKind;
use super::sources::calibrate_simulated;
use crate::model::{Effects, ErrorParameters};
use crate::nav::Site;
use crate::sim::{Noise, Scheme, SimConfig};

/// What a plan is for.
#[derive(Clone, Debug)]
pub struct PlanInput {
    pub scheme: Scheme,
    pub site: Site,
    pub sample_rate_hz: f64,
    pub noise: NoiseDensity,
    /// The unit's attitude at the start as `simulate` takes it: the
    /// rotation vector φ in n, degrees, with C_b^n(0) = exp([φ×]) (a
    /// heading of ψ is [0, 0, ψ]).
    pub initial_attitude_error_deg: [f64; 3],
}

/// Predicted 1-σ of one parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlannedSigma {
    pub sigma: f64,
    pub unit: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub scheme: String,
    pub duration_s: f64,
    pub parameters: BTreeMap<String, PlannedSigma>,
    /// Parameters the scheme leaves poorly observable.
    pub warnings: Vec<String>,
}

impl PlanInput {
    /// The run a plan analyses: the scheme simulated for an error-free
    /// unit without noise (the noise enters as the densities imposed).
    pub fn noise_free_run(&self) -> SimConfig {
        SimConfig {
            site: self.site,
            sample_rate_hz: self.sample_rate_hz,
            scheme: self.scheme.clone(),
            params: ErrorParameters::zero(),
            effects: Effects::none(),
            noise: Noise::default(),
            initial_attitude_error_deg: self.initial_attitude_error_deg,
            seed: 0,
            thermal: None,
            temperature: None,
        }
    }
}

pub fn plan(input: &PlanInput, opts: &EstimateOptions) -> Result<Plan, CalibError> {
    let cfg = input.noise_free_run();
    let opts = EstimateOptions {
        estimator: EstimatorKind::Kf,
        max_passes: 1,
        noise: Some(input.noise),
        cross_check: false,
        ..opts.clone()
    };
    let result = calibrate_simulated(&cfg, &opts)?;
    Ok(Plan {
        scheme: input.scheme.name.clone(),
        duration_s: result.duration_s,
        parameters: result
            .parameters
            .into_iter()
            .map(|(name, p)| {
                (
                    name,
                    PlannedSigma {
                        sigma: p.sigma,
                        unit: p.unit,
                    },
                )
            })
            .collect(),
        warnings: result.warnings,
    })
}
