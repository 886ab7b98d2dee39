//! The calibration driver: passes of alignment and an estimator over the
//! scanned run, each pass compensating the data with the estimate of the
//! one before (the SPEC §2 compensation, docs/CONTRACT.md), until the
//! correction is small against its σ; then the cross-check with the other
//! estimator, and the result. Passes, because a single open-loop pass
//! fails at the paper's error sizes (CONTRACT §8.2); each correction is
//! composed into the compensation, not added (§8.4).

use std::sync::atomic::AtomicBool;

use super::effect_model::{Effect, ErrorModel};
use super::error::CalibError;
use super::kf_pass::{effect_terms, filter_pass, kf_pass, Pass};
use super::noise_fit::{fit_noise, FreeTerm, NoiseFit};
use super::noise_measure::measure_noise;
use super::noise_screen::{may_wander_unseen, settle_white_model};
use super::options::EstimateOptions;
use super::passes::{lsq_as_pass, run_passes, Estimate};
use super::prescan::{first_dwell, scan_run};
use super::report::{
    effect_table, parameter_table, run_warnings, thermal_result, thermal_span_warning, Findings,
};
use super::result::{
    AlignmentReport, CalibrationNoise, CalibrationResult, CrossCheck, CrossCheckEntry, NoiseSource,
};
use super::run::{EstimatorKind, Progress, RecordSource, RunInfo};
use super::temperature::{TemperatureCurve, THERMAL_SPAN_C};
use super::walk::PassContext;
use crate::estimation::noise_model::NoiseModel;
use crate::model::units::{DEG_PER_RT_H, UG_PER_RT_HZ};
use crate::model::{ErrorParameters, N_PARAMS, PARAMETERS};
use crate::nav::attitude::euler_from_dcm;

/// The two estimators disagree on a parameter when they differ by more
/// than this many combined σ (a 3σ difference happens by chance about
/// once in 370 parameters).
const CROSS_CHECK_SIGMA: f64 = 3.0;

/// Calibrates a run: the one entry point the CLI and the server call.
pub fn estimate(
    source: &dyn RecordSource,
    run: &RunInfo,
    opts: &EstimateOptions,
    progress: &mut dyn FnMut(Progress),
    cancel: &AtomicBool,
) -> Result<CalibrationResult, CalibError> {
    progress(Progress {
        fraction: 0.0,
        stage: "scanning the run".into(),
    });
    let temperature = source.temperature()?;
    let opts = &with_thermal_states(opts, temperature.as_ref())?;
    let scan = scan_run(source, run, opts, cancel)?;
    let ctx = PassContext::new(source, run, opts, &scan, cancel)
        .with_temperature(temperature)
        .with_run_heading()?;
    Ok(estimate_scanned(&ctx, progress)?.result)
}

/// A calibration and the noise model its last passes ran under (given,
/// measured, or fitted to the run).
pub(crate) struct Calibrated {
    pub result: CalibrationResult,
    pub noise: NoiseModel,
}

/// The run's own noise model (`noise_measure`: one more streaming read,
/// the Allan curves over the dwells and the pulse quanta) measured on a
/// second thread while the first pass runs under the pre-scan's white
/// densities: on a white run the two models are the same and the read
/// costs no time; on a real sensor's run the passes that follow take the
/// measured model from where the first left them.
fn measure_beside_first_pass(
    ctx: &PassContext,
    progress: &mut dyn FnMut(Progress),
) -> Result<(NoiseModel, Estimate), CalibError> {
    let (source, run, scan, cancel) = (ctx.source, ctx.run, ctx.scan, ctx.cancel);
    let share = first_pass_share(ctx.opts);
    std::thread::scope(|s| {
        let measuring = s.spawn(move || measure_noise(source, run, scan, cancel));
        let head = run_passes(ctx, None, 1, 1, false, (0.05, share), progress);
        let measured = measuring
            .join()
            .map_err(|_| CalibError::Numerical("the noise measurement panicked".into()))?;
        Ok((measured?, head?))
    })
}

/// The options a run is calibrated with: thermal states need the run's
/// temperature column; `thermal_auto` adds them to a run whose
/// temperature spans [`THERMAL_SPAN_C`] or more (with the filter).
fn with_thermal_states(
    opts: &EstimateOptions,
    temperature: Option<&TemperatureCurve>,
) -> Result<EstimateOptions, CalibError> {
    let mut opts = opts.clone();
    let spanned = temperature.is_some_and(|c| c.span_c() >= THERMAL_SPAN_C);
    if opts.model.has(Effect::Thermal) {
        if temperature.is_none() {
            return Err(CalibError::Options(format!(
                "model {} carries thermal states, which follow the unit's temperature through \
                 the run: this run has no temperature column (SPEC §3a); a soaked run's \
                 parameters at several temperatures make a thermal model with `sinscal thermal`",
                opts.model
            )));
        }
    } else if opts.thermal_auto && spanned && opts.estimator == EstimatorKind::Kf {
        // Only the filter carries effect states; the least squares alone
        // keeps the base model and the result proposes the states.
        opts.model = opts.model.and(Effect::Thermal);
    }
    Ok(opts)
}

/// Calibrates a run already scanned (the discrepancy workflow keeps the
/// scan for its own passes): under the options' noise model when they
/// give one, else under the run's own, measured and, where it holds §2a
/// terms, fitted.
pub(crate) fn estimate_scanned(
    ctx: &PassContext,
    progress: &mut dyn FnMut(Progress),
) -> Result<Calibrated, CalibError> {
    check_scanned(ctx)?;
    match ctx.opts.noise {
        Some(_) => estimate_from(ctx, None, progress),
        None => {
            let (measured, head) = measure_beside_first_pass(ctx, progress)?;
            estimate_or_restart(&ctx.with_noise(measured), ctx, Some(head), progress)
        }
    }
}

/// The base model's calibration of a scanned run for the discrepancy
/// workflow. A run whose dwells show no §2a term is calibrated as
/// `calibrate` does (the dwells' white reading stands). Otherwise the
/// noise model is fitted with every SPEC §3 effect as states (and the
/// thermal states where the temperature spans), and the base model runs
/// under it, held: fitted under the base model alone, the noise takes up
/// what a missing effect leaves in the innovations (on a real unit a
/// g-sensitivity at twice the size the run reports detectable fitted the
/// ARW at 0.00077 deg/√h instead of 0.00040, a gyro drift a bias
/// instability of 0.0032 deg/h; a white unit on a 20 °C ramp fitted 4×
/// its ARW), and the workflow would find nothing left to name.
pub(crate) fn estimate_base_for_diagnosis(
    ctx: &PassContext,
    progress: &mut dyn FnMut(Progress),
) -> Result<Calibrated, CalibError> {
    let opts = ctx.opts;
    if opts.noise.is_some() || !opts.fit_noise || opts.estimator != EstimatorKind::Kf {
        return estimate_scanned(ctx, progress);
    }
    check_scanned(ctx)?;
    let measured = measure_noise(ctx.source, ctx.run, ctx.scan, ctx.cancel)?;
    if measured.is_white() {
        return estimate_scanned(ctx, progress);
    }
    let probe_opts = with_every_effect(opts, ctx.temperature.as_ref())?;
    let probe_ctx = ctx.with_options(&probe_opts).with_noise(measured);
    let mut probe_progress = |p: Progress| {
        progress(Progress {
            fraction: 0.5 * p.fraction,
            ..p
        })
    };
    let probe = estimate_or_restart(&probe_ctx, ctx, None, &mut probe_progress)?;
    let held = EstimateOptions {
        fit_noise: false,
        ..opts.clone()
    };
    let held_ctx = ctx.with_options(&held).with_noise(probe.noise);
    let mut base = estimate_or_restart(&held_ctx, ctx, None, &mut |p| {
        progress(Progress {
            fraction: 0.5 + 0.5 * p.fraction,
            ..p
        })
    })?;
    // The model was fitted, by the probe.
    base.result.noise_model = probe.result.noise_model;
    Ok(base)
}

/// [`estimate_from`], started again from the base model's converged
/// answer when its passes run away. From zero (or from one pass), a
/// consumer unit's errors (biases to 1 deg/s, mountings to 3°) are far
/// outside the linear range: with some thirty loosely held effect states
/// at once (the discrepancy workflow's probe) the passes ran away on 7 of
/// 20 hand-turned consumer runs, each correction thousands of its σ and
/// growing until the parameters' information lost definiteness (`cargo
/// bench --bench grades -- 20 --grade consumer --diagnose`), where the
/// base model and each effect alone converge. `white` is the context the
/// first pass runs in (the pre-scan's white densities).
fn estimate_or_restart(
    ctx: &PassContext,
    white: &PassContext,
    head: Option<Estimate>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Calibrated, CalibError> {
    match estimate_from(ctx, head, progress) {
        Err(CalibError::Numerical(_)) => {
            let restart = converged_base_head(ctx, white, progress)?;
            estimate_from(ctx, Some(restart), progress)
        }
        other => other,
    }
}

/// The base model's passes run to convergence under `ctx`'s noise model,
/// as `calibrate` walks them (one pass under `white`'s densities first:
/// from zero under a consumer unit's measured wander, the base model's own
/// passes ran away on 1 of those 20 runs), with `ctx`'s every effect
/// state at zero: where its own passes start again.
fn converged_base_head(
    ctx: &PassContext,
    white: &PassContext,
    progress: &mut dyn FnMut(Progress),
) -> Result<Estimate, CalibError> {
    let base_opts = EstimateOptions {
        model: ErrorModel::base(),
        ..ctx.opts.clone()
    };
    let white = white.with_options(&base_opts);
    let range = (0.05, first_pass_share(&base_opts));
    let head = run_passes(&white, None, 1, 1, false, range, progress)?;
    let noisy = white.with_noise(ctx.noise);
    let budget = base_opts.max_passes;
    let base = run_passes(&noisy, Some(head), budget, 1, false, range, progress)?;
    // The restarted passes count afresh: the head is a starting point,
    // not passes spent on the model.
    Ok(Estimate {
        effects: vec![0.0; ctx.opts.model.states().len()],
        passes: 0,
        ..base
    })
}

/// The options with every SPEC §3 effect as filter states, and the
/// thermal states where the run's temperature spans.
fn with_every_effect(
    opts: &EstimateOptions,
    temperature: Option<&TemperatureCurve>,
) -> Result<EstimateOptions, CalibError> {
    let mut every = with_thermal_states(
        &EstimateOptions {
            thermal_auto: true,
            ..opts.clone()
        },
        temperature,
    )?;
    for e in Effect::ALL.into_iter().filter(|e| *e != Effect::Thermal) {
        every.model = every.model.and(e);
    }
    Ok(every)
}

/// What a scanned run must hold before any pass: two dwells at least, and
/// effect states only with the filter.
fn check_scanned(ctx: &PassContext) -> Result<(), CalibError> {
    let (opts, scan) = (ctx.opts, ctx.scan);
    first_dwell(scan)?;
    // One attitude observes the gravity and Earth-rate projections on one
    // set of axes only: the filter would converge to the prior and report
    // it as a calibration.
    let dwells = scan.dwells().count();
    if dwells < 2 {
        return Err(CalibError::Unusable(format!(
            "the run holds {dwells} dwell: a calibration needs the unit at rest in at least two attitudes, with a turn between them"
        )));
    }
    if opts.estimator == EstimatorKind::Lsq && !opts.model.is_base() {
        return Err(CalibError::Options(format!(
            "model {} carries effect states, which only the filter estimates (estimator kf)",
            opts.model
        )));
    }
    Ok(())
}

/// The progress one pass takes of the passes' share.
fn first_pass_share(opts: &EstimateOptions) -> f64 {
    passes_share(opts) / f64::from(opts.max_passes.max(1))
}

/// The progress the passes take: the cross-check is one more pass, and
/// keeps its own share.
fn passes_share(opts: &EstimateOptions) -> f64 {
    if opts.cross_check {
        0.8
    } else {
        0.9
    }
}

/// The passes from `head` (a first pass already run, or none), the noise
/// fit when the run asks for one, the cross-check, and the result.
fn estimate_from(
    ctx: &PassContext,
    head: Option<Estimate>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Calibrated, CalibError> {
    let (opts, scan) = (ctx.opts, ctx.scan);
    let effect_states = opts.model.states();
    let share = passes_share(opts);
    // At least two passes: the first linearises at zero, the second at
    // the first's answer.
    let (budget, min_passes, lo) = match &head {
        Some(h) => (
            opts.max_passes.saturating_sub(h.passes).max(1),
            2u32.saturating_sub(h.passes).max(1),
            0.05 + first_pass_share(opts),
        ),
        None => (opts.max_passes, 2, 0.05),
    };
    let span = share - (lo - 0.05);
    // A model to be fitted needs the last pass's trace: every pass keeps
    // one (each replaces the one before), so no pass is run only for it.
    let mut source = noise_source(ctx);
    // A white model's last pass is kept too, for the screen below. (An
    // in-run thermal model is fitted over a pass of its own.)
    let screened = may_wander_unseen(ctx);
    let traced = (source == NoiseSource::Fitted || screened) && !opts.model.has(Effect::Thermal);
    let mut est = run_passes(ctx, head, budget, min_passes, traced, (lo, span), progress)?;
    let unseen = if screened {
        settle_white_model(ctx, &mut est, &mut source)?
    } else {
        None
    };
    let fitted_ctx;
    let (ctx, est, fit) = if source == NoiseSource::Fitted {
        let range = (0.05 + 0.5 * share, 0.5 * share);
        let (c, e, fit) = refit_noise(ctx, est, range, progress)?;
        fitted_ctx = c;
        (&fitted_ctx, e, Some(fit))
    } else {
        (ctx, est, None)
    };
    let fit_evaluations = fit.as_ref().map(|f| f.evaluations);
    let reference = fit.as_ref().and_then(|f| f.reference);
    let unsettled = est.unsettled(ctx);
    let (params, effects, passes, mut last) = (est.params, est.effects, est.passes, est.last);
    let cross_check = cross_check_phase(ctx, &params, &effects, &mut last, progress)?;
    // The least squares alone makes no zero-velocity innovations: one
    // filter pass at its answer gives the model check every result carries.
    if last.model_check.is_none() {
        let mut report = |_: f64| {};
        last.model_check = kf_pass(ctx, &params, &effects, &mut report)?.model_check;
    }
    progress(Progress {
        fraction: 0.95,
        stage: "reporting".into(),
    });

    let mut findings = Findings {
        warnings: unsettled.into_iter().collect(),
        ..Findings::default()
    };
    findings
        .warnings
        .extend(unseen.as_ref().map(|u| u.warning()));
    if let Some(fit) = &fit {
        findings.warnings.extend(fit.warnings(ctx.grade));
    } else if opts.noise_reference.is_some() {
        let how = match source {
            NoiseSource::Given => "given",
            NoiseSource::Measured => "white, measured from the dwells",
            NoiseSource::Fitted => "fitted without a trace",
        };
        findings.warnings.push(format!(
            "the noise model held for the unit was not tested: it is tested against a model \
             fitted to the run (one whose dwells show pulses or a wandering bias), and this \
             run's model was {how}"
        ));
    }
    let parameters = parameter_table(&params, &last, ctx.priors(), &mut findings);
    findings.warnings.extend(thermal_span_warning(ctx));
    let effect_estimates = effect_table(
        &effect_states,
        &effects,
        &last,
        ctx.priors().grade,
        &mut findings,
    );
    findings
        .warnings
        .extend(run_warnings(ctx, cross_check.as_ref()));
    let thermal = thermal_result(ctx, &params, &effect_states, &effects, &last)?;
    let (roll, pitch, heading) = euler_from_dcm(&last.c_b_n0);
    let dwell1 = first_dwell(scan)?;
    progress(Progress {
        fraction: 1.0,
        stage: "done".into(),
    });
    let result = CalibrationResult {
        estimator: opts.estimator.into(),
        model: opts.model.clone(),
        parameters,
        effects: effect_estimates,
        warnings: findings.warnings,
        poorly_observable: findings.poorly_observable,
        grade: Some(ctx.grade),
        passes,
        records: scan.n_records,
        duration_s: scan.t_end - scan.t_begin,
        alignment: AlignmentReport {
            roll_deg: roll.to_degrees(),
            pitch_deg: pitch.to_degrees(),
            heading_deg: heading.to_degrees(),
            duration_s: dwell1.t_end - dwell1.t_start,
        },
        noise_arw_deg_rt_h: ctx.arw / DEG_PER_RT_H,
        noise_vrw_ug_rt_hz: ctx.vrw / UG_PER_RT_HZ,
        noise_model: Some(CalibrationNoise {
            source,
            model: ctx.noise.report(),
            fit_evaluations,
            reference,
            unseen_wander: unseen,
        }),
        segments: scan.segments.clone(),
        gaps: scan.gaps.iter().map(|g| g.report()).collect(),
        dwell_residuals: last.dwell_residuals,
        convergence: last.history,
        cross_check,
        model_check: last.model_check,
        // From the column; a soaked run's metadata states it, and the
        // caller that read the metadata fills it.
        temperature: ctx.temperature.as_ref().map(TemperatureCurve::summary),
        thermal,
        scheme_coverage: None,
    };
    Ok(Calibrated {
        result,
        noise: ctx.noise,
    })
}

/// The other estimator, linearised at this one's answer, and the report
/// of where the two disagree (`None` when not asked for). Where the least
/// squares is the primary, the filter pass run here gives the result its
/// residuals, convergence and model check.
fn cross_check_phase(
    ctx: &PassContext,
    params: &ErrorParameters,
    effects: &[f64],
    last: &mut Pass,
    progress: &mut dyn FnMut(Progress),
) -> Result<Option<CrossCheck>, CalibError> {
    let opts = ctx.opts;
    if !opts.cross_check {
        return Ok(None);
    }
    let stage = "cross-check".to_string();
    let mut report = |f: f64| {
        progress(Progress {
            fraction: 0.85 + 0.1 * f,
            stage: stage.clone(),
        })
    };
    let other = match opts.estimator {
        EstimatorKind::Kf => lsq_as_pass(ctx, params, effects, &mut report)?,
        EstimatorKind::Lsq => kf_pass(ctx, params, effects, &mut report)?,
    };
    let mut d = ErrorParameters::zero();
    d.si.copy_from_slice(&other.delta[..N_PARAMS]);
    let other_params = params.compose(&d);
    let check = match opts.estimator {
        EstimatorKind::Kf => cross_check_report(params, &last.sigma, &other_params, &other.sigma),
        EstimatorKind::Lsq => cross_check_report(&other_params, &other.sigma, params, &last.sigma),
    };
    if opts.estimator == EstimatorKind::Lsq {
        last.dwell_residuals = other.dwell_residuals;
        last.history = other.history;
        last.model_check = other.model_check;
    }
    Ok(Some(check))
}

/// Whether the noise model the passes ran under stands or is fitted to
/// the run. A given model stands. A measured one is fitted when it holds
/// any §2a term (pulses or a wandering bias): the dwells' curves only start
/// those. A white one stands unless the run's innovations ask for wander
/// (`unseen_wander`, judged after the passes) and a fit of it is asked
/// for (`fit_unseen_wander`): a missing effect asks for wander too, and a
/// fit would read it as noise.
fn noise_source(ctx: &PassContext) -> NoiseSource {
    let opts = ctx.opts;
    if opts.noise.is_some() {
        NoiseSource::Given
    } else if opts.fit_noise && opts.estimator == EstimatorKind::Kf && !ctx.noise.is_white() {
        NoiseSource::Fitted
    } else {
        NoiseSource::Measured
    }
}

/// Fits the noise model to the innovations of the last pass (`noise_fit`,
/// over its trace), then runs the passes again under it:
/// the context with the fitted model, the new estimate and the fit.
fn refit_noise<'a>(
    ctx: &PassContext<'a>,
    mut est: Estimate,
    (lo, span): (f64, f64),
    progress: &mut dyn FnMut(Progress),
) -> Result<(PassContext<'a>, Estimate, NoiseFit), CalibError> {
    progress(Progress {
        fraction: lo,
        stage: "fitting the noise model to the run".into(),
    });
    let fit = if ctx.opts.model.has(Effect::Thermal) {
        fit_noise_with_curvature(ctx, &est)?
    } else {
        let trace = est
            .last
            .trace
            .take()
            .ok_or_else(|| CalibError::Numerical("the pass kept no trace".into()))?;
        let scale = effect_terms(&ctx.opts.model, &est.effects, ctx.priors().grade).scale;
        fit_noise(ctx, &trace, &scale, &ctx.noise, &FreeTerm::SETTLED)?
    };
    let fitted = ctx.with_noise(fit.model);
    let range = (lo + 0.2 * span, 0.8 * span);
    let est = run_passes(
        &fitted,
        Some(est),
        ctx.opts.max_passes,
        1,
        false,
        range,
        progress,
    )?;
    Ok((fitted, est, fit))
}

/// The noise fit of an in-run thermal calibration: over the trace of one
/// more pass from `est` that also carries the quadratic thermal states
/// (`Effect::ThermalCurvature`). Fitted under the linear states alone,
/// the wander takes up a curvature they lack (a 0.1 µg/°C² accelerometer
/// bias on a 40 °C ramp went unflagged in half the runs), and the model
/// check, which judges the linear model under the fitted noise, would be
/// left nothing to see; with them the check flags it from 0.02 µg/°C² in
/// every seed (FIGURES, Thermal). With no curvature in the run the extra
/// states are noise.
fn fit_noise_with_curvature(ctx: &PassContext, est: &Estimate) -> Result<NoiseFit, CalibError> {
    let opts = EstimateOptions {
        model: ctx.opts.model.and(Effect::ThermalCurvature),
        ..ctx.opts.clone()
    };
    // The pass runs under the white part of the start model: under the
    // start's wander (read from the dwells, where a curvature drifts like
    // a random walk) its estimate leaves wander-shaped residuals at which
    // the fit, holding that estimate, again prefers the wander.
    let probe = ctx
        .with_options(&opts)
        .with_noise(ctx.noise.without_wander());
    // The model's states come first in `Effect` order, the curvature's
    // last: the estimate so far, then zeros.
    let mut effects = est.effects.clone();
    effects.resize(opts.model.states().len(), 0.0);
    let pass = filter_pass(&probe, &est.params, &effects, true, &mut |_| {})?;
    let trace = pass
        .trace
        .ok_or_else(|| CalibError::Numerical("the curvature pass kept no trace".into()))?;
    let scale = effect_terms(&opts.model, &effects, ctx.priors().grade).scale;
    fit_noise(&probe, &trace, &scale, &ctx.noise, &FreeTerm::SETTLED)
}

/// Compares the two estimators parameter by parameter.
fn cross_check_report(
    kf: &ErrorParameters,
    kf_sigma: &[f64],
    lsq: &ErrorParameters,
    lsq_sigma: &[f64],
) -> CrossCheck {
    let mut entries = Vec::with_capacity(N_PARAMS);
    let mut flagged = Vec::new();
    for (i, info) in PARAMETERS.iter().enumerate() {
        let combined = (kf_sigma[i].powi(2) + lsq_sigma[i].powi(2)).sqrt();
        let nd = (kf.si[i] - lsq.si[i]).abs() / combined;
        let flag = nd > CROSS_CHECK_SIGMA;
        if flag {
            flagged.push(info.name.to_string());
        }
        entries.push(CrossCheckEntry {
            name: info.name.to_string(),
            kf: kf.canonical(i),
            lsq: lsq.canonical(i),
            lsq_sigma: lsq_sigma[i] / info.si_per_unit,
            normalized_difference: nd,
            flagged: flag,
        });
    }
    CrossCheck {
        method: "velocity-error-rate least squares over dwell stretches and rotation steps".into(),
        entries,
        flagged,
    }
}
