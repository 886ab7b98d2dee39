//! The design objective: the 1-σ the systematic filter would give each
//! parameter on a scheme, from the information it gains over each dwell
//! and each turn, computed from the scheme's motion alone.
//!
//! `calib::plan` answers the same question by simulating the run's
//! records and filtering them; that costs a pass over every record (0.6 s
//! for the 3.2 h scheme at 100 Hz), too slow to score thousands of
//! candidate schemes. Here the same filter (the same error dynamics,
//! parameter columns, noise densities, priors and start covariance) is
//! fed in larger pieces, using what the motion makes constant:
//!
//! - **At rest** the parameter columns are constant in time, so a window
//!   of any length is summarised exactly by their time moments (two Gauss
//!   points integrate the zeroth to third moments), and the filter steps
//!   through a dwell with a zero-velocity update at the end of each window.
//!   Next to a turn the velocity still carries what the turn did, and
//!   there the estimator's own 1 s windows matter: the first and last 10 s
//!   of a dwell are stepped in them. In between, windows of up to
//!   `dwell_window_s` (10 s) lose nothing measurable. With 10 s windows
//!   throughout, the misalignments came out 5–37 % worse than `plan`'s;
//!   with the split, every parameter is within 3.6 %
//!   (`tests/suite/design_objective.rs`).
//! - **In a turn** the columns follow the attitude, so the turn is cut
//!   into steps of at most 0.1 s and 1° of rotation, each evaluated at its
//!   midpoint from the trajectory's closed-form kinematics, and propagated
//!   in windows of at most 1 s without updates (the reference point is not
//!   known to rest while the unit turns).
//!
//! As in the estimator, the first and last half second of a dwell next to
//! a turn carry no update (the pre-scan's guard), and a still stretch
//! shorter than the pre-scan's shortest dwell is not a dwell.
//!
//! Effect states (`design --detect`) ride along beside the 24 as in
//! `calibrate --model`: each step's column is `estimation::effect_columns`'s,
//! read from the true motion around the step (the step and two
//! neighbours either side, as the walk reads records). At rest every
//! effect's column is constant but the drifts', which grow linearly in
//! time and so are still integrated exactly by the two Gauss points.

use nalgebra::{DMatrix, Matrix3, Vector3};

use crate::calib::CalibError;
use crate::estimation::effect_columns::{effect_column, EffectParameter, RecordMotion, NEIGHBOURS};
use crate::estimation::filter::{error_dynamics, SystematicFilter};
use crate::estimation::noise_model::NoiseModel;
use crate::estimation::priors::{initial_navigation_covariance, prior_sigma, Priors};
use crate::estimation::sensitivity::base_columns;
use crate::model::{N_PARAMS, PARAMETERS};
use crate::nav::attitude::rotvec_to_dcm;
use crate::nav::Site;
use crate::sim::trajectory::{Kinematics, Motion, Trajectory};
use crate::sim::Scheme;

/// What the objective holds fixed besides the scheme.
#[derive(Clone, Debug)]
pub struct ObjectiveSettings {
    pub site: Site,
    /// The sensor noise (SPEC §2, §2a) the estimator would assume.
    pub noise: NoiseModel,
    /// σ of a zero-velocity observation, m/s.
    pub zupt_sigma_mps: f64,
    /// The estimator's priors: its `prior_scale` at the grade the noise
    /// names.
    pub priors: Priors,
    /// The unit's start attitude: rotation vector in n, degrees.
    pub initial_attitude_deg: [f64; 3],
    /// Longest filter window at rest, s.
    pub dwell_window_s: f64,
    /// Guard at each end of a dwell next to motion, s.
    pub guard_s: f64,
    /// Shortest still stretch the pre-scan takes for a dwell, s.
    pub min_dwell_s: f64,
    /// Effect states carried beside the 24 parameters.
    pub effects: Vec<EffectParameter>,
}

/// The objective's answer for one scheme.
#[derive(Clone, Debug)]
pub struct Information {
    /// Predicted 1-σ of each parameter, SI, in `PARAMETERS` order, as the
    /// base calibration (without the effect states) would report it.
    pub sigma_si: Vec<f64>,
    pub duration_s: f64,
    /// Covariance of the effect states, SI, in `ObjectiveSettings::effects`
    /// order (empty without them).
    pub effect_covariance_si: DMatrix<f64>,
    /// Dwells long enough to be observed.
    pub observed_dwells: usize,
}

impl Information {
    /// σ of parameter `i` in its canonical unit.
    pub fn sigma_canonical(&self, i: usize) -> f64 {
        self.sigma_si[i] / PARAMETERS[i].si_per_unit
    }
}

/// Longest step in a turn, s, and largest rotation in one step, rad.
const TURN_STEP_S: f64 = 0.1;
const TURN_STEP_RAD: f64 = 1.0 * std::f64::consts::PI / 180.0;
/// Longest window in a turn, s (the estimator's window).
const TURN_WINDOW_S: f64 = 1.0;
/// Rest at each end of a dwell stepped in the estimator's own windows.
const FINE_REST_S: f64 = 10.0;

/// The step and its neighbours either side, sampled at their midpoints.
type Around = [Kinematics; 2 * NEIGHBOURS + 1];

/// Adds the parameter columns of a step of `h` seconds whose midpoint is
/// `tau` into the window and `t_mid` from the scheme's start, its motion
/// sampled at the midpoints of it and its neighbours (`around`, the step in
/// the middle); the effect columns of `effects` read from all of them.
fn add_step(
    kf: &mut SystematicFilter,
    around: &Around,
    (h, tau): (f64, f64),
    effects: &[EffectParameter],
    t_mid: f64,
) {
    let kin = &around[NEIGHBOURS];
    let dtheta = kin.omega_ib_b * h;
    let dv = kin.f_b * h;
    kf.add_record(tau, |cols| {
        base_columns(&kin.c_b_n, &dtheta, &dv, h, |i, rows, col| {
            cols.set(i, rows, &col)
        });
        if effects.is_empty() {
            return;
        }
        // The step and its neighbours as records of an error-free triad,
        // their increments from the mid-step rates.
        let motion = RecordMotion {
            dtheta: std::array::from_fn(|i| around[i].omega_ib_b * h),
            dv: std::array::from_fn(|i| around[i].f_b * h),
            dt: h,
            t_mid,
            // Planning has no temperature history: thermal states would
            // see none of their signature.
            delta_c: 0.0,
            rate_c_per_s: 0.0,
            accel_jacobian: Matrix3::identity(),
            accel_jacobian_inv: Matrix3::identity(),
            gyro_jacobian_inv: Matrix3::identity(),
        };
        for (j, &p) in effects.iter().enumerate() {
            let (rows, col_b) = effect_column(p, &motion);
            cols.set(N_PARAMS + j, rows, &(kin.c_b_n * col_b));
        }
    });
}

/// A resting window of length `t` starting `t0` from the scheme's start:
/// the constant columns at two Gauss points, exact for the zeroth to
/// third time moments.
fn add_rest(
    kf: &mut SystematicFilter,
    kin: &Kinematics,
    t0: f64,
    t: f64,
    effects: &[EffectParameter],
) {
    let offset = t / (2.0 * 3f64.sqrt());
    let still = [*kin; 2 * NEIGHBOURS + 1];
    for tau in [0.5 * t - offset, 0.5 * t + offset] {
        add_step(kf, &still, (0.5 * t, tau), effects, t0 + tau);
    }
}

/// The predicted σ of every parameter on `scheme`.
pub fn scheme_information(
    scheme: &Scheme,
    s: &ObjectiveSettings,
) -> Result<Information, CalibError> {
    let phi = Vector3::from(s.initial_attitude_deg).map(f64::to_radians);
    let c_b_n0: Matrix3<f64> = rotvec_to_dcm(&phi);
    let traj = Trajectory::new(scheme, &c_b_n0, &s.site).map_err(CalibError::Unusable)?;
    let mut scale = prior_sigma(s.priors);
    scale.extend(
        s.effects
            .iter()
            .map(|p| p.prior_sigma(s.priors.grade) * p.si_per_unit()),
    );
    let mut kf = SystematicFilter::new(
        error_dynamics(&s.site.omega_ie_n(), &s.site.f_rest_n()),
        &initial_navigation_covariance(&s.site, s.priors),
        &scale,
        &s.noise,
        traj.duration(),
        s.zupt_sigma_mps,
    );
    let mut walk = Walk {
        kf: &mut kf,
        effects: &s.effects,
        t: 0.0,
    };
    let segments = traj.segments();
    let mut observed_dwells = 0;
    for (k, seg) in segments.iter().enumerate() {
        let mid = 0.5 * (seg.t0 + seg.t1);
        walk.t = seg.t0;
        match seg.motion {
            Motion::Dwell => {
                let kin = traj.kinematics_in(k, mid);
                let after_motion = k > 0;
                let before_motion = k + 1 < segments.len();
                let lead = if after_motion { s.guard_s } else { 0.0 };
                let tail = if before_motion { s.guard_s } else { 0.0 };
                let length = seg.t1 - seg.t0;
                let observed = length - lead - tail;
                if length < s.min_dwell_s || observed <= 0.0 {
                    walk.rest_without_updates(&kin, length);
                } else {
                    observed_dwells += 1;
                    walk.rest_without_updates(&kin, lead);
                    // Fine windows where the velocity carries what the
                    // turn did; coarse ones in between.
                    let fine = (FINE_REST_S * 2.0).min(observed);
                    let coarse = observed - fine;
                    for (length, window) in [
                        (0.5 * fine, TURN_WINDOW_S),
                        (coarse, s.dwell_window_s),
                        (0.5 * fine, TURN_WINDOW_S),
                    ] {
                        walk.observe_rest(&kin, length, window)?;
                    }
                    walk.rest_without_updates(&kin, tail);
                }
            }
            Motion::Rotate { profile, .. } => walk.turn(&traj, k, profile.angle.abs()),
            Motion::Flip { profile, .. } => walk.turn(&traj, k, profile.angle.abs()),
        }
    }
    // The base calibration does not carry the effect states: its σ is that
    // of the 24 with the effects held.
    let sigma_si = kf.leading_parameter_sigma_si(N_PARAMS, traj.duration())?;
    let effect_covariance_si = if s.effects.is_empty() {
        DMatrix::zeros(0, 0)
    } else {
        let m = s.effects.len();
        kf.parameter_covariance_si(traj.duration())?
            .view((N_PARAMS, N_PARAMS), (m, m))
            .into_owned()
    };
    Ok(Information {
        sigma_si,
        duration_s: traj.duration(),
        effect_covariance_si,
        observed_dwells,
    })
}

/// The filter fed along the scheme, and where in it the feeding is.
struct Walk<'a> {
    kf: &'a mut SystematicFilter,
    effects: &'a [EffectParameter],
    /// Time from the scheme's start, s.
    t: f64,
}

impl Walk<'_> {
    /// Rest with a zero-velocity update at the end of every window of at
    /// most `window` seconds.
    fn observe_rest(
        &mut self,
        kin: &Kinematics,
        length: f64,
        window: f64,
    ) -> Result<(), CalibError> {
        if length <= 0.0 {
            return Ok(());
        }
        let n = (length / window).ceil().max(1.0);
        let t = length / n;
        for _ in 0..n as usize {
            add_rest(self.kf, kin, self.t, t, self.effects);
            self.kf.propagate(t, &kin.c_b_n);
            self.kf
                .update_zero_velocity(&Vector3::zeros(), &kin.c_b_n)?;
            self.kf.take_navigation_errors();
            self.t += t;
        }
        Ok(())
    }

    /// Rest without updates (a guard, or a stretch too short to be a
    /// dwell), in windows of at most a second as the estimator would step
    /// it.
    fn rest_without_updates(&mut self, kin: &Kinematics, length: f64) {
        if length <= 0.0 {
            return;
        }
        let n = (length / TURN_WINDOW_S).ceil().max(1.0);
        let t = length / n;
        for _ in 0..n as usize {
            add_rest(self.kf, kin, self.t, t, self.effects);
            self.kf.propagate(t, &kin.c_b_n);
            self.t += t;
        }
    }

    /// A turn or flip: steps of at most 0.1 s and 1° (2° of mean rate for
    /// a flip, whose S-curve peaks at twice it), windows of at most 1 s.
    fn turn(&mut self, traj: &Trajectory, k: usize, angle_rad: f64) {
        let seg = &traj.segments()[k];
        let length = seg.t1 - seg.t0;
        let n_windows = (length / TURN_WINDOW_S).ceil().max(1.0) as usize;
        let window = length / n_windows as f64;
        // A flip's S-curve peaks at twice its mean rate.
        let steps_total = (length / TURN_STEP_S)
            .ceil()
            .max(2.0 * angle_rad / TURN_STEP_RAD)
            .max(1.0);
        let per_window = (steps_total / n_windows as f64).ceil().max(1.0) as usize;
        let h = window / per_window as f64;
        let n_steps = n_windows * per_window;
        // Every step's midpoint kinematics, and with effects carried its
        // neighbours' beyond either end of the turn: each is computed once.
        let margin = if self.effects.is_empty() {
            0
        } else {
            NEIGHBOURS
        };
        let kins: Vec<Kinematics> = (0..n_steps + 2 * margin)
            .map(|i| {
                let step = i as f64 - margin as f64;
                let t = seg.t0 + (step + 0.5) * h;
                if (0.0..n_steps as f64).contains(&step) {
                    traj.kinematics_in(k, t)
                } else {
                    traj.kinematics(t)
                }
            })
            .collect();
        for w in 0..n_windows {
            let t_ws = seg.t0 + w as f64 * window;
            for j in 0..per_window {
                let tau = (j as f64 + 0.5) * h;
                let step = w * per_window + j;
                // Without effects only the middle one is read.
                let around: Around = std::array::from_fn(|i| {
                    kins[(step + margin + i)
                        .saturating_sub(NEIGHBOURS)
                        .min(kins.len() - 1)]
                });
                add_step(self.kf, &around, (h, tau), self.effects, t_ws + tau);
            }
            let last = kins[((w + 1) * per_window - 1 + margin).min(kins.len() - 1)];
            self.kf.propagate(window, &last.c_b_n);
        }
        self.t = seg.t1;
    }
}
