//! One pass of the systematic filter: alignment, then the filter over the
//! compensated run with zero-velocity updates in the dwells, and what the
//! pass leaves for the result (the estimate, its history, the dwells'
//! post-fit residuals and the model check).

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::effect_model::ErrorModel;
use super::error::CalibError;
use super::model_check::{CheckAccumulator, ModelCheck};
use super::prescan::dwell_at;
use super::replay::PassTrace;
use super::result::{Convergence, DwellResidual};
use super::segment::SegmentKind;
use super::walk::{align_start, walk, PassContext};
use crate::estimation::effect_columns::EffectTerms;
use crate::estimation::filter::{Innovation, FORGOTTEN_VELOCITY_SIGMA_MPS};
use crate::model::{ErrorParameters, Grade, N_PARAMS, PARAMETERS};

/// Sums over one dwell's zero-velocity innovations, from which the
/// post-fit residual ȳ − M p̂ follows for the final estimate p̂ without
/// storing the innovations: Σ(y_i − m_i·p)² = Σy_i² − 2 p·Σy_i m_i + pᵀ(Σ m_i m_iᵀ)p.
struct DwellAccumulator {
    n: usize,
    sum_y: Vector3<f64>,
    sum_y2: Vector3<f64>,
    sum_m: DMatrix<f64>,
    sum_ym: DMatrix<f64>,
    sum_mm: [DMatrix<f64>; 3],
}

impl DwellAccumulator {
    fn new(n_p: usize) -> Self {
        DwellAccumulator {
            n: 0,
            sum_y: Vector3::zeros(),
            sum_y2: Vector3::zeros(),
            sum_m: DMatrix::zeros(3, n_p),
            sum_ym: DMatrix::zeros(3, n_p),
            sum_mm: std::array::from_fn(|_| DMatrix::zeros(n_p, n_p)),
        }
    }

    fn add(&mut self, innov: &Innovation) {
        let y = innov.y_bar;
        self.n += 1;
        self.sum_y += y;
        self.sum_y2 += y.component_mul(&y);
        self.sum_m += &innov.m;
        for i in 0..3 {
            let col = innov.m.row(i).transpose();
            for k in 0..col.len() {
                self.sum_ym[(i, k)] += y[i] * col[k];
            }
            self.sum_mm[i].ger(1.0, &col, &col, 1.0);
        }
    }

    /// RMS and mean of the post-fit innovations per axis.
    fn post_fit(&self, p: &DVector<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let n = self.n.max(1) as f64;
        let mp = &self.sum_m * p;
        let mut rms = Vector3::zeros();
        let mut mean = Vector3::zeros();
        for i in 0..3 {
            let cross = self.sum_ym.row(i).dot(&p.transpose());
            let quad = (p.transpose() * &self.sum_mm[i] * p)[(0, 0)];
            rms[i] = ((self.sum_y2[i] - 2.0 * cross + quad) / n).max(0.0).sqrt();
            mean[i] = (self.sum_y[i] - mp[i]) / n;
        }
        (rms, mean)
    }
}

/// The walk's effect terms for `model` with the effects at `effects` (SI,
/// state order) taken out of the records: each state in units of its
/// prior σ at `grade`.
pub(super) fn effect_terms(model: &ErrorModel, effects: &[f64], grade: Grade) -> EffectTerms {
    let states = model.states();
    let scale = states
        .iter()
        .map(|s| s.prior_sigma(grade) * s.si_per_unit())
        .collect();
    let removed = states
        .iter()
        .copied()
        .zip(effects.iter().copied())
        .filter(|(_, v)| *v != 0.0)
        .collect();
    EffectTerms {
        states,
        scale,
        removed,
    }
}

/// The result of one filter pass.
pub(super) struct Pass {
    /// Residual parameter estimate, SI: the base 24, then the effect
    /// states of the model.
    pub delta: Vec<f64>,
    pub sigma: Vec<f64>,
    pub c_b_n0: Matrix3<f64>,
    pub history: Convergence,
    pub dwell_residuals: Vec<DwellResidual>,
    /// Whether the model explains the pass's zero-velocity residuals.
    pub model_check: Option<ModelCheck>,
    /// The parameters' covariance, SI, in `delta`'s order (the filter's;
    /// the in-run thermal result needs each value's correlation with its
    /// coefficient).
    pub covariance: Option<DMatrix<f64>>,
    /// The pass's windows, when asked for (a noise model fitted to them).
    pub trace: Option<PassTrace>,
}

/// One pass of alignment and the filter over the records compensated with
/// `params`, with the model's effect states (`ctx.opts.model`) as further
/// states and the effects at `effects` (SI, state order) removed first.
pub(super) fn kf_pass(
    ctx: &PassContext,
    params: &ErrorParameters,
    effects: &[f64],
    progress: &mut dyn FnMut(f64),
) -> Result<Pass, CalibError> {
    filter_pass(ctx, params, effects, false, progress)
}

/// [`kf_pass`], keeping the windows as a [`PassTrace`] when `traced`.
pub(super) fn filter_pass(
    ctx: &PassContext,
    params: &ErrorParameters,
    effects: &[f64],
    traced: bool,
    progress: &mut dyn FnMut(f64),
) -> Result<Pass, CalibError> {
    let comp = params.compensator();
    let c_b_n0 = align_start(ctx, &comp)?;
    let terms = effect_terms(&ctx.opts.model, effects, ctx.priors().grade);

    let mut kf = ctx.filter_with_effects(ctx.opts.zupt_sigma_mps, &terms.scale);
    let n_p = kf.n_params();
    let mut trace = traced.then(|| {
        kf.keep_window_inputs();
        PassTrace::new(n_p)
    });

    let n_windows = (ctx.scan.n_records as usize).div_ceil(ctx.window()).max(1);
    // One slot kept for the last window, so the history never exceeds
    // `history_points`.
    let every = n_windows
        .div_ceil(ctx.opts.history_points.saturating_sub(1).max(1))
        .max(1);
    let mut history = Convergence {
        names: PARAMETERS.iter().map(|p| p.name.to_string()).collect(),
        ..Default::default()
    };
    let mut dwell_acc: Vec<DwellAccumulator> = (0..ctx.scan.segments.len())
        .map(|_| DwellAccumulator::new(n_p))
        .collect();
    let mut check = CheckAccumulator::new(&ctx.scan.segments, n_p);

    let mut was_observed = true;
    walk(ctx, &comp, &c_b_n0, &mut kf, &terms, progress, |kf, w| {
        let d0 = dwell_at(&ctx.scan.segments, w.t_start);
        let dwell = d0.filter(|_| d0 == dwell_at(&ctx.scan.segments, w.t_end));
        let observed = dwell.is_some() || ctx.opts.zupt_in_motion;
        let c_b_n = w.nav.c_b_n();
        if let Some(t) = trace.as_mut() {
            let v_n = observed.then_some(&w.nav.v_n);
            t.record(kf, w.t_end - w.t_start, &c_b_n, v_n);
        }
        // A rest after a motion whose velocity the model cannot follow:
        // the attitude carried through it informs the parameters, its
        // velocity does not (`Grade::trusts_motion_velocity`).
        if observed && !was_observed && !ctx.grade.trusts_motion_velocity() {
            kf.forget_velocity(FORGOTTEN_VELOCITY_SIGMA_MPS);
            if let Some(t) = trace.as_mut() {
                t.forgot_velocity();
            }
        }
        was_observed = observed;
        if observed {
            let innov = kf.update_zero_velocity(&w.nav.v_n, &c_b_n)?;
            if let Some(d) = dwell {
                dwell_acc[d].add(&innov);
                check.add(d, 0.5 * (w.t_start + w.t_end), &innov)?;
            }
            let (phi, dv) = kf.take_navigation_errors();
            if let Some(t) = trace.as_mut() {
                t.fed_back(&phi, &dv);
            }
            w.nav.correct(&phi, &dv, &Vector3::zeros());
            w.corrected = true;
        }
        if w.index % every == 0 || w.index + 1 == n_windows {
            let (d, s) = kf.parameters(w.t_end - ctx.scan.t_begin)?;
            history.t.push(w.t_end);
            history.value.push(
                (0..N_PARAMS)
                    .map(|i| ((params.si[i] + d[i]) / PARAMETERS[i].si_per_unit) as f32)
                    .collect(),
            );
            history.sigma.push(
                (0..N_PARAMS)
                    .map(|i| (s[i] / PARAMETERS[i].si_per_unit) as f32)
                    .collect(),
            );
        }
        Ok(())
    })?;

    let run_s = ctx.scan.duration_s();
    let (delta, sigma) = kf.parameters(run_s)?;
    if sigma.iter().any(|s| !s.is_finite()) || delta.iter().any(|d| !d.is_finite()) {
        return Err(CalibError::Numerical("the filter diverged".into()));
    }
    let p_hat = kf.scaled_estimate()?;
    if let Some(t) = trace.as_mut() {
        t.finish(p_hat.clone(), kf.log_likelihood()?);
    }
    let mut dwell_residuals = Vec::new();
    for (i, seg) in ctx.scan.segments.iter().enumerate() {
        if seg.kind == SegmentKind::Dwell {
            let (rms, mean) = dwell_acc[i].post_fit(&p_hat);
            dwell_residuals.push(DwellResidual {
                dwell: dwell_residuals.len() + 1,
                t_start: seg.t_start,
                t_end: seg.t_end,
                rms_mps: rms.into(),
                drift_mps2: (mean / ctx.opts.window_s).into(),
            });
        }
    }
    let model_check = Some(check.finish(&p_hat, &dwell_residuals));
    Ok(Pass {
        delta,
        sigma,
        c_b_n0,
        history,
        dwell_residuals,
        model_check,
        covariance: Some(kf.parameter_covariance_si(run_s)?),
        trace,
    })
}
