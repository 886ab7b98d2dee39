//! What every estimator assumes before it sees the run: the parameters'
//! prior σ, the navigation errors' covariance at the start, and the white
//! noise that drives the error model between observations.

use nalgebra::{Matrix3, Matrix6};

use crate::model::grade::Grade;
use crate::model::params::Group;
use crate::model::PARAMETERS;
use crate::nav::Site;

/// What the priors are made of: the unit's grade, and how many of its
/// typical magnitudes one prior σ spans.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Priors {
    pub scale: f64,
    pub grade: Grade,
    /// The start heading's σ when the run found it otherwise than by
    /// gyrocompassing its first dwell (`calib::heading`), rad.
    pub start_heading_sigma: Option<f64>,
}

/// Prior 1-σ of one parameter family, SI: `scale` times the grade's
/// magnitude for it (the seed paper's for navigation units).
pub fn family_prior(priors: Priors, group: Group) -> f64 {
    priors.scale * priors.grade.magnitude(group)
}

/// Prior 1-σ of the 24 parameters, SI.
pub fn prior_sigma(priors: Priors) -> Vec<f64> {
    PARAMETERS
        .iter()
        .map(|p| family_prior(priors, p.group))
        .collect()
}

/// Covariance of the navigation errors at the run's start. The attitude
/// left after alignment is what the residual biases imply (tilt ≈ δb_a/g,
/// heading ≈ δb_g,E/ω_ie,N); the bounds are three priors wide, so the
/// prior adds no information the run must supply. The unit starts at rest.
pub(crate) fn initial_navigation_covariance(site: &Site, priors: Priors) -> Matrix6<f64> {
    let tilt = (3.0 * family_prior(priors, Group::AccelBias) / site.gravity()).min(0.1);
    let heading = priors.start_heading_sigma.unwrap_or_else(|| {
        (3.0 * family_prior(priors, Group::GyroBias) / site.omega_ie_n().y).min(0.1)
    });
    let mut p0 = Matrix6::zeros();
    for (i, s) in [tilt, tilt, heading, 1e-4, 1e-4, 1e-4].iter().enumerate() {
        p0[(i, i)] = s * s;
    }
    p0
}

/// Information (inverse covariance) of the start attitude error under
/// `initial_navigation_covariance`; `None` if that were singular.
pub(crate) fn start_attitude_information(site: &Site, priors: Priors) -> Option<Matrix3<f64>> {
    initial_navigation_covariance(site, priors)
        .fixed_view::<3, 3>(0, 0)
        .into_owned()
        .try_inverse()
}

/// Spectral density of the white noise driving [φ; δv]: the gyro's angle
/// random walk on the attitude rows, the accelerometer's velocity random
/// walk on the velocity rows (rad/√s and m/s/√s, squared).
pub(crate) fn white_noise_density(arw: f64, vrw: f64) -> Matrix6<f64> {
    let mut qc = Matrix6::zeros();
    for i in 0..3 {
        qc[(i, i)] = arw * arw;
        qc[(3 + i, 3 + i)] = vrw * vrw;
    }
    qc
}
