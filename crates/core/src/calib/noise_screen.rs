//! The wander a run's dwells could not show: a screen of a white model's
//! last pass for the bias wander its innovations ask for.
//!
//! A bias random walk of a few µg/√h or 1e-4 deg/h/√h lies under the
//! white noise at every τ a 600 s dwell offers, so the dwells' Allan
//! curves measure a white model; over a 3 h run the same walk moves the
//! velocity far beyond that model's σ. A missing effect (a delay, a lever
//! arm, a g-sensitivity) asks for wander too, so a positive screen is by
//! default a warning, and the fit follows only when asked
//! (`EstimateOptions::fit_unseen_wander`).

use super::effect_model::Effect;
use super::error::CalibError;
use super::kf_pass::effect_terms;
use super::noise_fit::{FreeTerm, DECIMATION, KEEP_WANDER_LN_L};
use super::passes::Estimate;
use super::replay::PassTrace;
use super::result::{NoiseSource, UnseenWanderReport};
use super::run::EstimatorKind;
use super::walk::PassContext;
use crate::estimation::noise_model::NoiseModel;

/// The sizes, as factors on a typical unit's ([`FreeTerm::nominal`]), at
/// which [`unseen_wander`] tries each wander term.
const PROBE_FACTORS: [f64; 3] = [0.3, 1.0, 3.0];

/// A wander term that raises the likelihood of a white model's pass: the
/// term, its size in a datasheet's units (`unit`) and the rise of ln L.
#[derive(Clone, Copy, Debug)]
pub(crate) struct UnseenWander {
    term: FreeTerm,
    size: f64,
    unit: &'static str,
    gain_ln_l: f64,
}

impl UnseenWander {
    /// What a result reports of it, `fitted` or not.
    pub fn report(&self, fitted: bool) -> UnseenWanderReport {
        UnseenWanderReport {
            term: self.term.name().to_string(),
            size: self.size,
            unit: self.unit.to_string(),
            gain_ln_l: self.gain_ln_l,
            fitted,
        }
    }
}

impl UnseenWanderReport {
    /// What a result says of it.
    pub(crate) fn warning(&self) -> String {
        let what = format!(
            "the run's innovations ask for wander its dwells do not show ({} of {:.2} {} raises ln L by {:.1})",
            self.term, self.size, self.unit, self.gain_ln_l
        );
        if self.fitted {
            format!("{what}: the noise model is fitted to the run, as asked; an effect missing from the model would be read as this wander")
        } else {
            format!("{what}: if the discrepancy workflow names no effect for the misfit, calibrate with the unseen wander fitted (`--fit-unseen-wander`)")
        }
    }
}

/// Whether a run whose dwells showed white noise alone still asks for
/// wander: the likelihood of the pass's innovations under `white` with one
/// wander term added, at a few sizes about a typical unit's, beats the
/// white model's by more than the one-term level; the likeliest such term.
/// A bias random walk of a few µg/√h hides under the white noise at every
/// τ a 600 s dwell offers, but over the 3 h of a run it moves the velocity
/// by several times the white model's σ (the check's χ² 480–1 030 for
/// 301). A test at fixed sizes is a screen, not the fit: where the full
/// fit follows, each term must earn its place again.
fn unseen_wander(
    ctx: &PassContext,
    trace: &PassTrace,
    effect_scale: &[f64],
    white: &NoiseModel,
) -> Result<Option<UnseenWander>, CalibError> {
    let filter = |m: &NoiseModel| ctx.filter_for(m, ctx.opts.zupt_sigma_mps, effect_scale);
    let replay = trace.profile(filter(white), DECIMATION)?;
    let still = replay.log_likelihood(filter(white))?;
    let mut best: Option<UnseenWander> = None;
    for term in FreeTerm::SETTLED.iter().filter(|t| t.may_vanish()) {
        for factor in PROBE_FACTORS {
            let mut m = *white;
            *term.values(&mut m) = [factor * term.nominal(ctx.grade); 3];
            let gain_ln_l = replay.log_likelihood(filter(&m))? - still;
            if gain_ln_l > best.map_or(KEEP_WANDER_LN_L, |b| b.gain_ln_l) {
                let (typical, unit) = term.typical(ctx.grade);
                best = Some(UnseenWander {
                    term: *term,
                    size: factor * typical,
                    unit,
                    gain_ln_l,
                });
            }
        }
    }
    Ok(best)
}

/// A white model's passes screened (`screen_unseen_wander`; the source
/// is measured, `may_wander_unseen`): `source` becomes fitted when the screen finds wander and its fit is asked for,
/// else the pass's trace, kept only for the screen, is let go. What the
/// screen found, as the result reports it.
pub(super) fn settle_white_model(
    ctx: &PassContext,
    est: &mut Estimate,
    source: &mut NoiseSource,
) -> Result<Option<UnseenWanderReport>, CalibError> {
    let unseen = screen_unseen_wander(ctx, est)?;
    let fit = unseen.is_some() && ctx.opts.fit_unseen_wander;
    if fit {
        *source = NoiseSource::Fitted;
    } else {
        est.last.trace = None;
    }
    Ok(unseen.map(|u| u.report(fit)))
}

/// The wander a white model's last pass asks for (`unseen_wander`), when
/// its check failed or a fit of it is asked for.
fn screen_unseen_wander(
    ctx: &PassContext,
    est: &Estimate,
) -> Result<Option<UnseenWander>, CalibError> {
    let failed = est.last.model_check.as_ref().is_some_and(|c| !c.adequate);
    let Some(trace) = est.last.trace.as_ref() else {
        return Ok(None);
    };
    if !(failed || ctx.opts.fit_unseen_wander) {
        return Ok(None);
    }
    let scale = effect_terms(&ctx.opts.model, &est.effects, ctx.priors().grade).scale;
    unseen_wander(ctx, trace, &scale, &ctx.noise)
}

/// Whether a white model the dwells measured is screened for wander
/// they could not show (`unseen_wander`, when its check fails or a fit
/// of it is asked for): a filter's model, measured and not given, and
/// not an in-run thermal one (whose noise fit runs a pass of its own).
pub(super) fn may_wander_unseen(ctx: &PassContext) -> bool {
    let opts = ctx.opts;
    opts.fit_noise
        && opts.estimator == EstimatorKind::Kf
        && opts.noise.is_none()
        && ctx.noise.is_white()
        && !opts.model.has(Effect::Thermal)
}
