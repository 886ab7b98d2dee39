//! The passes: each compensates the records with the estimate so far and
//! runs an estimator over them, and its correction is composed into the
//! estimate (CONTRACT §8.4), until the correction is small against its σ.

use super::error::CalibError;
use super::kf_pass::{filter_pass, Pass};
use super::lsq::lsq_pass;
use super::result::Convergence;
use super::run::{EstimatorKind, Progress};
use super::walk::{starting_point, PassContext};
use crate::model::{ErrorParameters, N_PARAMS};

/// Where the passes stand.
pub(super) struct Estimate {
    pub params: ErrorParameters,
    /// The effect states' estimates, SI, in the model's state order.
    pub effects: Vec<f64>,
    /// The last pass (its σ, history, residuals and model check).
    pub last: Pass,
    pub passes: u32,
    /// The largest correction of the last pass against its σ.
    pub last_worst: f64,
}

impl Estimate {
    /// The warning for an estimate still moving at the last pass.
    pub fn unsettled(&self, ctx: &PassContext) -> Option<String> {
        let conv = ctx.opts.converged_sigma;
        (ctx.opts.max_passes >= 2 && self.last_worst >= conv).then(|| {
            format!(
                "the estimate had not settled after {} passes: the last one still moved a \
                 parameter by {:.2}σ (more than {conv}σ)",
                self.passes, self.last_worst
            )
        })
    }
}

/// Runs passes from `from` (zero when `None`) until the correction is
/// below `converged_sigma` σ (after at least `min_passes`) or `budget`
/// passes ran; progress spans `[lo, lo + span)`. With `traced` every
/// filter pass keeps its windows (the last one's are what a noise fit
/// needs).
pub(super) fn run_passes(
    ctx: &PassContext,
    from: Option<Estimate>,
    budget: u32,
    min_passes: u32,
    traced: bool,
    (lo, span): (f64, f64),
    progress: &mut dyn FnMut(Progress),
) -> Result<Estimate, CalibError> {
    let opts = ctx.opts;
    let (mut params, mut effects, done) = match from {
        Some(s) => (s.params, s.effects, s.passes),
        None => (
            starting_point(ctx)?,
            vec![0.0; opts.model.states().len()],
            0,
        ),
    };
    let budget = budget.max(1);
    let mut pass = 0;
    loop {
        pass += 1;
        let stage = format!("{} pass {pass} of at most {budget}", opts.estimator.name());
        let base = lo + span * (pass - 1) as f64 / budget as f64;
        let mut report = |f: f64| {
            progress(Progress {
                fraction: base + span / budget as f64 * f,
                stage: stage.clone(),
            })
        };
        let p = match opts.estimator {
            EstimatorKind::Kf => filter_pass(ctx, &params, &effects, traced, &mut report)?,
            EstimatorKind::Lsq => lsq_as_pass(ctx, &params, &effects, &mut report)?,
        };
        // Composed, not added (CONTRACT §8.4).
        let mut delta = ErrorParameters::zero();
        delta.si.copy_from_slice(&p.delta[..N_PARAMS]);
        params = params.compose(&delta);
        for (e, d) in effects.iter_mut().zip(&p.delta[N_PARAMS..]) {
            *e += d;
        }
        let worst = p
            .delta
            .iter()
            .zip(p.sigma.iter())
            .map(|(d, s)| d.abs() / s)
            .fold(0.0, f64::max);
        if pass >= budget || (pass >= min_passes && worst < opts.converged_sigma) {
            return Ok(Estimate {
                params,
                effects,
                last: p,
                passes: done + pass,
                last_worst: worst,
            });
        }
    }
}

/// A least-squares solution in the form of a filter pass.
pub(super) fn lsq_as_pass(
    ctx: &PassContext,
    params: &ErrorParameters,
    effects: &[f64],
    progress: &mut dyn FnMut(f64),
) -> Result<Pass, CalibError> {
    let sol = lsq_pass(ctx, params, effects, progress)?;
    Ok(Pass {
        delta: sol.delta,
        sigma: sol.sigma,
        c_b_n0: sol.c_b_n0,
        history: Convergence::default(),
        dwell_residuals: Vec::new(),
        model_check: None,
        covariance: None,
        trace: None,
    })
}
