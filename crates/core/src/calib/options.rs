//! What a calibration can be asked to do: the estimator, its passes, the
//! update schedule, the segmentation and the priors.

use serde::{Deserialize, Serialize};

use super::effect_model::ErrorModel;
use super::run::EstimatorKind;
use super::segment::DetectOptions;
use crate::model::Grade;

pub use crate::estimation::NoiseDensity;

/// Tunable parts of the estimator. The defaults are what the accuracy
/// tests and benchmarks use.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EstimateOptions {
    pub estimator: EstimatorKind,
    /// The error model: the base 24 parameters, and any SPEC §3 effects
    /// carried as further states of the filter (for lines that know their
    /// units have them).
    pub model: ErrorModel,
    /// Passes with feedback into the compensation, at most. A unit near
    /// the paper's errors converges in two or three; an uncalibrated one
    /// (20× those errors: 1 % scale factors, a degree of attitude error per
    /// turn) is far off linear at first, each pass removing only 75–90 %
    /// of the error until the fourth, and converges in six.
    pub max_passes: u32,
    /// Stop once every parameter's correction is below this many σ.
    pub converged_sigma: f64,
    /// Propagation window and zero-velocity update interval, s.
    pub window_s: f64,
    /// σ of a zero-velocity observation, m/s: what the unit may really
    /// move at rest (table vibration), not a tuning knob for the noise.
    pub zupt_sigma_mps: f64,
    /// Also observe zero velocity while the unit turns. Right only when the
    /// turntable's axes pass through the unit's reference point (as in
    /// simulation); off by default, so off-centre tables and manual flips
    /// are safe. With it the filter gains the rotations' accelerometer
    /// information.
    pub zupt_in_motion: bool,
    pub detect: DetectOptions,
    /// The noise model; `None` measures it from the run.
    pub noise: Option<NoiseDensity>,
    /// The noise model the line holds for the unit (its
    /// characterisation), when the run's own is still fitted: the result
    /// then says whether the run's noise is still that model
    /// (`CalibrationNoise::reference`), a likelihood-ratio test over the
    /// fit's pass. Unlike `noise`, it changes no estimate.
    pub noise_reference: Option<NoiseDensity>,
    /// With the noise measured: fit its terms to the run's zero-velocity
    /// observations (`noise_fit`) and calibrate again under the fitted
    /// model.
    pub fit_noise: bool,
    /// Also fit the noise of a run whose dwells showed white noise alone
    /// when its innovations ask for wander (`noise_screen`).
    /// Off by default: a missing effect asks for wander too (a delay, a
    /// lever arm, a g-sensitivity were all absorbed by it, and the
    /// discrepancy workflow then named none), so the default keeps the
    /// check failing and says what wander would explain; a line turns
    /// it on for a unit whose misfit the workflow found no effect for.
    pub fit_unseen_wander: bool,
    /// Prior 1-σ of each parameter family as a multiple of the grade's
    /// typical magnitude (the seed paper's for navigation units).
    pub prior_scale: f64,
    /// The unit's grade; `None` takes it from the gyro noise the run
    /// shows (`Grade::of_gyro_noise`).
    pub grade: Option<Grade>,
    /// Run the least-squares cross-check after the filter.
    pub cross_check: bool,
    /// Add the in-run thermal states (model `+thermal`) to a run whose
    /// temperature column spans 3 °C or more; off, such a run's result
    /// warns and proposes them. The server turns it on: a line's worker
    /// has nobody to accept a proposal.
    pub thermal_auto: bool,
    /// Most points in the convergence history. 500 over a 3 h run is a
    /// point every 23 s, finer than any dwell, and wider than a plot.
    pub history_points: usize,
}

impl Default for EstimateOptions {
    fn default() -> Self {
        EstimateOptions {
            estimator: EstimatorKind::Kf,
            model: ErrorModel::base(),
            max_passes: 10,
            converged_sigma: 0.05,
            window_s: 1.0,
            zupt_sigma_mps: 1e-6,
            zupt_in_motion: false,
            detect: DetectOptions::default(),
            noise: None,
            noise_reference: None,
            fit_noise: true,
            fit_unseen_wander: false,
            prior_scale: 4.0,
            grade: None,
            cross_check: true,
            history_points: 500,
            thermal_auto: false,
        }
    }
}
