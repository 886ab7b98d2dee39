//! The bias wander of a real unit (SPEC §2a) in the gap: each stretch's
//! mean of each wandering bias axis is one more unknown, with the joint
//! Gaussian prior the noise model gives the means of all stretches.
//!
//! Under white noise alone, a wandering bias reads as a gap no constant
//! parameter explains, and the workflow would name an effect on every
//! real unit. The stretch means carry the wander where it acts (a bias
//! held over each stretch, through the stretch's own bias columns), and
//! their prior (the double integral of each component's autocovariance,
//! `WanderComponent::window_mean_covariance`) says how far they may move
//! apart: so the gap's expectation under noise alone, its dispersion and
//! the detection thresholds all count the wander as noise. Holding the
//! bias over a stretch misses only its variation inside the stretch,
//! which for the bank's fastest components behaves as white noise within
//! 25 % of its size.

use nalgebra::DMatrix;

use crate::calib::NoiseModel;
use crate::estimation::wander::{wander_components, WanderComponent};

/// Relative variance added to every stretch mean: the slow components'
/// means over neighbouring stretches are nearly equal, and a floor this
/// small keeps their covariance invertible without loosening it.
const MEAN_FLOOR: f64 = 1e-6;

/// The wander's unknowns and their prior.
pub(crate) struct WanderPrior {
    /// The bias axes that wander (0..3 gyro, 3..6 accelerometer).
    pub axes: Vec<usize>,
    /// Per wandering axis, the information (inverse covariance) of its
    /// stretch means, each in units of its parameter's prior σ.
    pub information: Vec<DMatrix<f64>>,
}

impl WanderPrior {
    /// The prior of `noise`'s wander over stretches `windows` (start, end
    /// in seconds from the run's start) of a run of `run_s` seconds, with
    /// `prior_sigma` the base parameters' prior σ; `None` when no bias
    /// wanders.
    pub fn new(
        noise: &NoiseModel,
        windows: &[(f64, f64)],
        run_s: f64,
        prior_sigma: &[f64],
    ) -> Option<Self> {
        if !noise.wanders() {
            return None;
        }
        let components = wander_components(noise, run_s);
        let mut axes = Vec::new();
        let mut information = Vec::new();
        for axis in 0..6 {
            let own: Vec<&WanderComponent> = components.iter().filter(|c| c.axis == axis).collect();
            if own.is_empty() {
                continue;
            }
            let scale = prior_sigma[crate::model::bias_parameter(axis)];
            let cov = stretch_mean_covariance(&own, windows) / (scale * scale);
            information.push(inverse(cov)?);
            axes.push(axis);
        }
        Some(WanderPrior { axes, information })
    }

    /// Unknowns per stretch.
    pub fn per_stretch(&self) -> usize {
        self.axes.len()
    }

    /// uᵀ I u over the stretch means `u` (stretch-major, axis-minor).
    pub fn prior_cost(&self, u: &[f64]) -> f64 {
        let n = self.per_stretch();
        self.information
            .iter()
            .enumerate()
            .map(|(a, info)| {
                let x = nalgebra::DVector::from_iterator(
                    info.nrows(),
                    (0..info.nrows()).map(|k| u[k * n + a]),
                );
                (x.transpose() * info * &x)[(0, 0)]
            })
            .sum()
    }
}

/// Covariance of the components' summed means over every pair of
/// windows, with the floor on the diagonal.
fn stretch_mean_covariance(
    components: &[&WanderComponent],
    windows: &[(f64, f64)],
) -> DMatrix<f64> {
    let s = windows.len();
    let mut cov = DMatrix::from_fn(s, s, |k, l| {
        components
            .iter()
            .map(|c| c.window_mean_covariance(windows[k], windows[l]))
            .sum()
    });
    let largest = (0..s).map(|k| cov[(k, k)]).fold(0.0, f64::max);
    for k in 0..s {
        cov[(k, k)] += MEAN_FLOOR * largest;
    }
    cov
}

fn inverse(cov: DMatrix<f64>) -> Option<DMatrix<f64>> {
    Some(cov.cholesky()?.inverse())
}
