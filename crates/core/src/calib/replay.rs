//! A filter pass kept as what the filter saw, window by window, so that
//! the same observations can be filtered again under another noise model
//! without walking the records again: the window's length, the attitude
//! at its end, its parameter input B (single precision: it only steers a
//! likelihood, never an estimate), and at a zero-velocity window the
//! velocity the navigation would have shown without the pass's feedback.
//!
//! The pass feeds the filter's navigation-error estimate back into the
//! navigation at every update. The error model being linear, the velocity
//! with the feedback undone is the navigated velocity plus every
//! correction made so far, carried forward by the navigation errors' own
//! transition; a filter that runs on those velocities without feedback
//! makes the same innovations as the pass would have made under its noise
//! model. 11 700 windows of a 3.2 h run with the base model keep about
//! 8 MB.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3, Vector6};

use super::error::CalibError;
use crate::estimation::filter::{SystematicFilter, WindowModel, FORGOTTEN_VELOCITY_SIGMA_MPS, NAV};

/// One window as the filter saw it.
struct WindowTrace {
    t: f64,
    c_b_n: Matrix3<f64>,
    /// B, 6 × n_p column-major, scaled parameters.
    b: Vec<f32>,
    /// The open-loop velocity at a zero-velocity window's end.
    zupt_v_n: Option<Vector3<f64>>,
    /// The pass forgot the velocity error before this window's update
    /// (`SystematicFilter::forget_velocity`).
    forgot_velocity: bool,
}

/// The windows of one pass, in order.
pub(crate) struct PassTrace {
    windows: Vec<WindowTrace>,
    n_p: usize,
    /// The corrections fed back so far, carried to the current window.
    feedback: Vector6<f64>,
    /// The pass's parameter estimate (scaled, the constant parts), once
    /// the pass is over.
    estimate: Option<DVector<f64>>,
    pass_log_likelihood: f64,
}

impl PassTrace {
    pub fn new(n_p: usize) -> Self {
        PassTrace {
            windows: Vec::new(),
            n_p,
            feedback: Vector6::zeros(),
            estimate: None,
            pass_log_likelihood: 0.0,
        }
    }

    /// Records a window after the filter propagated it (its input kept by
    /// [`SystematicFilter::keep_window_inputs`]); `v_n` is the navigated
    /// velocity at its end when the window ends in a zero-velocity update.
    /// Call [`PassTrace::fed_back`] after the update's correction.
    pub fn record(
        &mut self,
        kf: &mut SystematicFilter,
        t: f64,
        c_b_n: &Matrix3<f64>,
        v_n: Option<&Vector3<f64>>,
    ) {
        let b = kf
            .take_window_input()
            .unwrap_or_else(|| DMatrix::zeros(NAV, self.n_p));
        self.feedback = kf.navigation_transition(t) * self.feedback;
        let open_loop =
            v_n.map(|v| v + Vector3::new(self.feedback[3], self.feedback[4], self.feedback[5]));
        self.windows.push(WindowTrace {
            t,
            c_b_n: *c_b_n,
            forgot_velocity: false,
            b: b.iter().map(|x| *x as f32).collect(),
            zupt_v_n: open_loop,
        });
    }

    /// The correction (φ, δv) just fed back into the navigation.
    pub fn fed_back(&mut self, phi: &Vector3<f64>, dv: &Vector3<f64>) {
        for i in 0..3 {
            self.feedback[i] += phi[i];
            self.feedback[3 + i] += dv[i];
        }
    }

    /// Marks the window just recorded as one before whose update the pass
    /// forgot the velocity error.
    pub fn forgot_velocity(&mut self) {
        if let Some(w) = self.windows.last_mut() {
            w.forgot_velocity = true;
        }
    }

    /// The pass's parameter estimate (scaled), at its end.
    pub fn finish(&mut self, p_scaled: DVector<f64>, log_likelihood: f64) {
        self.estimate = Some(p_scaled);
        self.pass_log_likelihood = log_likelihood;
    }

    /// The marginal log-likelihood (parameters integrated out) replayed
    /// under `kf`'s noise model: under the pass's own model, the pass's.
    pub fn log_likelihood(&self, mut kf: SystematicFilter) -> Result<f64, CalibError> {
        for w in &self.windows {
            let b = DMatrix::from_iterator(NAV, self.n_p, w.b.iter().map(|x| *x as f64));
            kf.propagate_input(w.t, &w.c_b_n, &b);
            if w.forgot_velocity {
                kf.forget_velocity(FORGOTTEN_VELOCITY_SIGMA_MPS);
            }
            if let Some(v) = &w.zupt_v_n {
                kf.update_zero_velocity(v, &w.c_b_n)?;
            }
        }
        Ok(kf.log_likelihood()?)
    }

    /// The traced pass's own log-likelihood.
    #[cfg(test)]
    pub fn pass_log_likelihood(&self) -> f64 {
        self.pass_log_likelihood
    }

    /// The pass prepared for [`ProfileReplay::log_likelihood`]: every
    /// `decimation` windows merged into one, the parameters held at the
    /// pass's estimate and their effect taken out of the velocities, and
    /// each merged window's matrices made once. `kf` is a fresh filter of
    /// the pass's shape (any noise model: what is kept does not depend on
    /// it).
    pub fn profile(
        &self,
        mut kf: SystematicFilter,
        decimation: usize,
    ) -> Result<ProfileReplay, CalibError> {
        let p = self
            .estimate
            .as_ref()
            .ok_or_else(|| CalibError::Numerical("the traced pass left no estimate".into()))?;
        let mut effect = Vector6::zeros();
        let mut groups = Vec::with_capacity(self.windows.len() / decimation.max(1) + 1);
        for group in self.windows.chunks(decimation.max(1)) {
            let (t, b) = self.merged_input(&mut kf, group);
            let last = group.last().expect("chunks are not empty");
            let bp = &b * p;
            effect =
                kf.navigation_transition(t) * effect + Vector6::from_column_slice(bp.as_slice());
            let forgot_velocity = group.iter().any(|w| w.forgot_velocity);
            if forgot_velocity {
                effect.fixed_rows_mut::<3>(3).fill(0.0);
            }
            groups.push(ReplayWindow::new(
                &mut kf,
                t,
                &last.c_b_n,
                &b,
                forgot_velocity,
                last.zupt_v_n
                    .map(|v| v - Vector3::new(effect[3], effect[4], effect[5])),
            ));
        }
        Ok(ProfileReplay { windows: groups })
    }

    /// Consecutive windows merged into one: its length and its parameter
    /// input B, each window's carried on by the transitions after it
    /// (`kf` gives exp(F T); only the last window's update is kept).
    fn merged_input(
        &self,
        kf: &mut SystematicFilter,
        group: &[WindowTrace],
    ) -> (f64, DMatrix<f64>) {
        let mut b = DMatrix::zeros(NAV, self.n_p);
        let mut t = 0.0;
        for w in group {
            let phi = kf.navigation_transition(w.t);
            let bw = DMatrix::from_iterator(NAV, self.n_p, w.b.iter().map(|x| *x as f64));
            b = DMatrix::from_column_slice(NAV, NAV, phi.as_slice()) * b + bw;
            t += w.t;
        }
        (t, b)
    }
}

/// A traced pass prepared for likelihoods with the parameters known
/// ([`PassTrace::profile`]): what each merged window does to the
/// navigation errors, which no noise model changes, kept as matrices.
pub(crate) struct ProfileReplay {
    windows: Vec<ReplayWindow>,
}

/// One merged window of a [`ProfileReplay`].
struct ReplayWindow {
    t: f64,
    c_b_n: Matrix3<f64>,
    phi: Matrix6<f64>,
    /// The white noise's Q(T) for a unit density on each body axis: gyro
    /// x, y, z, then accelerometer x, y, z (Q is linear in the densities,
    /// and a noise model's white noise is diagonal in the body).
    q_per_axis: [Matrix6<f64>; 6],
    /// How a constant body bias moved the navigation errors over the
    /// window (the wander acts through it).
    coupling: Matrix6<f64>,
    forgot_velocity: bool,
    /// The velocity at a zero-velocity window's end, open loop and the
    /// parameters' effect taken out.
    zupt_v_n: Option<Vector3<f64>>,
}

impl ReplayWindow {
    fn new(
        kf: &mut SystematicFilter,
        t: f64,
        c_b_n: &Matrix3<f64>,
        b: &DMatrix<f64>,
        forgot_velocity: bool,
        zupt_v_n: Option<Vector3<f64>>,
    ) -> Self {
        let q_per_axis = std::array::from_fn(|axis| {
            // A unit density on one body axis, in n.
            let u = c_b_n.column(axis % 3);
            let unit_n = u * u.transpose();
            let zero = Matrix3::zeros();
            let (_, q) = if axis < 3 {
                kf.window_matrices(t, &unit_n, &zero)
            } else {
                kf.window_matrices(t, &zero, &unit_n)
            };
            q
        });
        ReplayWindow {
            t,
            c_b_n: *c_b_n,
            phi: kf.navigation_transition(t),
            q_per_axis,
            coupling: kf.bias_columns(b),
            forgot_velocity,
            zupt_v_n,
        }
    }
}

impl ProfileReplay {
    /// The log-likelihood of the pass's zero-velocity observations under
    /// `kf`'s noise model (a fresh filter of the pass's shape), the
    /// parameters held at the pass's estimate: their effect, carried by
    /// the navigation errors' transition, is out of the velocities, and
    /// `kf` filters only the navigation errors and the wander. Against
    /// the likelihood with the parameters integrated out this drops 24
    /// degrees of freedom of tens of thousands, and halves the cost.
    pub fn log_likelihood(&self, kf: SystematicFilter) -> Result<f64, CalibError> {
        let mut kf = kf.with_parameters_known();
        let noise = kf.noise();
        let density: [f64; 6] = std::array::from_fn(|axis| {
            let triad = if axis < 3 { &noise.gyro } else { &noise.accel };
            triad.white[axis % 3].powi(2)
        });
        for w in &self.windows {
            let mut q_white = Matrix6::zeros();
            for (q, d) in w.q_per_axis.iter().zip(density) {
                q_white += q * d;
            }
            kf.propagate_window(&WindowModel {
                phi: &w.phi,
                q_white: &q_white,
                coupling: &w.coupling,
                t: w.t,
            });
            if w.forgot_velocity {
                kf.forget_velocity(FORGOTTEN_VELOCITY_SIGMA_MPS);
            }
            if let Some(v) = &w.zupt_v_n {
                kf.update_zero_velocity(v, &w.c_b_n)?;
            }
        }
        Ok(kf.log_likelihood()?)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicBool;

    use nalgebra::{DVector, Vector3, Vector6};

    use super::PassTrace;
    use crate::calib::kf_pass::filter_pass;
    use crate::calib::prescan::scan_run;
    use crate::calib::sources::SliceSource;
    use crate::calib::walk::PassContext;
    use crate::calib::{EstimateOptions, NoiseDensity, RunInfo};
    use crate::estimation::filter::{SystematicFilter, FORGOTTEN_VELOCITY_SIGMA_MPS};
    use crate::model::{Effects, ErrorParameters};
    use crate::nav::Site;
    use crate::sim::{simulate, Noise, Scheme, SimConfig};

    /// Replaying a traced pass under its own noise model gives the pass's
    /// own likelihood: the feedback undone, the same innovations. What
    /// makes a likelihood over another noise model's replay mean anything.
    #[test]
    fn replay_under_the_pass_model_is_the_pass() {
        let mut noise = Noise::default_navigation_grade();
        noise.gyro_bias_instability_deg_h = 0.002;
        noise.accel_bias_instability_ug = 3.0;
        let cfg = SimConfig {
            site: Site::REFERENCE,
            sample_rate_hz: 20.0,
            scheme: Scheme::builtin("ten-position", 60.0).unwrap(),
            params: ErrorParameters::paper(),
            effects: Effects::none(),
            noise,
            initial_attitude_error_deg: [0.05, -0.05, 1.0],
            seed: 3,
            thermal: None,
            temperature: None,
        };
        let records: Vec<_> = simulate(&cfg).unwrap().collect();
        let source = SliceSource(&records);
        let run = RunInfo {
            site: cfg.site,
            sample_rate_hz: cfg.sample_rate_hz,
        };
        let opts = EstimateOptions {
            noise: Some(NoiseDensity {
                gyro_bias_instability_deg_h: 0.002,
                accel_bias_instability_ug: 3.0,
                ..NoiseDensity::white(0.0003, 5.0)
            }),
            ..EstimateOptions::default()
        };
        let cancel = AtomicBool::new(false);
        let scan = scan_run(&source, &run, &opts, &cancel).unwrap();
        let ctx = PassContext::new(&source, &run, &opts, &scan, &cancel);
        let pass = filter_pass(&ctx, &ErrorParameters::zero(), &[], true, &mut |_| {}).unwrap();
        let trace = pass.trace.unwrap();
        let kf = ctx.filter_for(&ctx.noise, opts.zupt_sigma_mps, &[]);
        let replayed = trace.log_likelihood(kf).unwrap();
        let own = trace.pass_log_likelihood();
        assert!(
            (replayed - own).abs() < 1e-6 * own.abs().max(1.0),
            "replayed {replayed}, pass {own}"
        );

        // The prepared profile replay, under another noise model (axes
        // unequal, another wander), is the replay written out window by
        // window.
        let mut trace = trace;
        trace.finish(DVector::from_element(trace.n_p, 0.3), 0.0);
        let mut other = ctx.noise;
        other.gyro.white = [2.0e-7, 0.5e-7, 1.0e-7];
        other.accel.white[1] *= 3.0;
        other.gyro.random_walk = [1e-9; 3];
        other.accel.instability = [0.0, 5e-5, 1e-5];
        for decimation in [1, 2, 3] {
            let filter = || ctx.filter_for(&other, opts.zupt_sigma_mps, &[]);
            let prepared = trace.profile(filter(), decimation).unwrap();
            let got = prepared.log_likelihood(filter()).unwrap();
            let want = profile_written_out(&trace, filter(), decimation);
            assert!(
                (got - want).abs() < 1e-9 * want.abs(),
                "decimation {decimation}: prepared {got}, written out {want}"
            );
        }
    }

    /// The profile likelihood as its definition reads: the parameters'
    /// effect carried and taken out window by window, the filter
    /// propagated from each merged window's input B, its matrices made
    /// for that window.
    fn profile_written_out(trace: &PassTrace, kf: SystematicFilter, decimation: usize) -> f64 {
        let mut kf = kf.with_parameters_known();
        let p = trace.estimate.as_ref().unwrap();
        let mut effect = Vector6::zeros();
        for group in trace.windows.chunks(decimation) {
            let (t, b) = trace.merged_input(&mut kf, group);
            let last = group.last().unwrap();
            let bp = &b * p;
            effect =
                kf.navigation_transition(t) * effect + Vector6::from_column_slice(bp.as_slice());
            kf.propagate_input(t, &last.c_b_n, &b);
            if group.iter().any(|w| w.forgot_velocity) {
                kf.forget_velocity(FORGOTTEN_VELOCITY_SIGMA_MPS);
                effect.fixed_rows_mut::<3>(3).fill(0.0);
            }
            if let Some(v) = &last.zupt_v_n {
                let v = v - Vector3::new(effect[3], effect[4], effect[5]);
                kf.update_zero_velocity(&v, &last.c_b_n).unwrap();
            }
        }
        kf.log_likelihood().unwrap()
    }
}
