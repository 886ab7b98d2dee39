//! The calibration driver: passes of alignment and an estimator over the
//! scanned run, each pass compensating the data with the estimate of the
//! one before (the SPEC §2 compensation, docs/CONTRACT.md), until the
//! correction is small against its σ; then the cross-check with the other
//! estimator, and the result. Passes, because a single open-loop pass
//! fails at the paper's error sizes (CONTRACT §8.2); each correction is
//! composed into the compensation, not added (§8.4).

use std::sync::atomic::AtomicBool;

use super::effect_model::Effect;
use super::error::CalibError;
use super::kf_pass::{kf_pass, Pass};
use super::lsq::lsq_pass;
use super::options::EstimateOptions;
use super::prescan::{first_dwell, scan_run};
use super::priors::prior_sigma;
use super::result::{
    AlignmentReport, CalibrationResult, Convergence, CrossCheck, CrossCheckEntry, ParameterEstimate,
};
use super::run::{EstimatorKind, Progress, RecordSource, RunInfo};
use super::temperature::{TemperatureCurve, THERMAL_SPAN_C};
use super::thermal_states::{is_thermal, run_thermal};
use super::walk::PassContext;
use crate::model::units::{DEG_PER_RT_H, UG_PER_RT_HZ};
use crate::model::{ErrorParameters, N_PARAMS, PARAMETERS};
use crate::nav::attitude::euler_from_dcm;

/// A parameter is reported poorly observable when its σ after the run is
/// above this fraction of its prior: the run has not halved the prior's
/// uncertainty, so much of the estimate is the prior's.
const POORLY_OBSERVABLE: f64 = 0.5;

/// Fewer dwells than this are warned about: the seed paper's scheme, for
/// which the 24-parameter model was set up, has ten positions.
const MULTI_POSITION_DWELLS: usize = 10;

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
    estimate_scanned(
        &PassContext::new(source, run, opts, &scan, cancel).with_temperature(temperature),
        progress,
    )
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
/// scan for its own passes).
pub(crate) fn estimate_scanned(
    ctx: &PassContext,
    progress: &mut dyn FnMut(Progress),
) -> Result<CalibrationResult, CalibError> {
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
    let mut params = ErrorParameters::zero();
    let effect_states = opts.model.states();
    // The effects' estimates (SI, state order), composed like the base
    // parameters: each pass removes them from the records and estimates
    // what is left.
    let mut effects = vec![0.0; effect_states.len()];
    let max_passes = opts.max_passes.max(1);
    let mut last: Option<Pass> = None;
    let mut passes = 0;
    // Largest correction of the last pass against its σ: the estimate is
    // the linearisation point's only once this is small.
    let mut last_worst = f64::INFINITY;
    // The cross-check is one more pass; reserve its share of the progress.
    let share = if opts.cross_check { 0.8 } else { 0.9 };
    for pass in 1..=max_passes {
        passes = pass;
        let base = 0.05 + share * (pass - 1) as f64 / max_passes as f64;
        let span = share / max_passes as f64;
        let stage = format!(
            "{} pass {pass} of at most {max_passes}",
            opts.estimator.name()
        );
        let mut report = |f: f64| {
            progress(Progress {
                fraction: base + span * f,
                stage: stage.clone(),
            })
        };
        let p = match opts.estimator {
            EstimatorKind::Kf => kf_pass(ctx, &params, &effects, &mut report)?,
            EstimatorKind::Lsq => lsq_as_pass(ctx, &params, &effects, &mut report)?,
        };
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
        last = Some(p);
        last_worst = worst;
        if pass >= 2 && worst < opts.converged_sigma {
            break;
        }
    }
    let mut last = last.ok_or_else(|| CalibError::Numerical("no pass ran".into()))?;
    let unsettled = (max_passes >= 2 && last_worst >= opts.converged_sigma).then(|| {
        format!(
            "the estimate had not settled after {passes} passes: the last one still moved a \
             parameter by {last_worst:.2}σ (more than {}σ)",
            opts.converged_sigma
        )
    });

    let cross_check = if opts.cross_check {
        let stage = "cross-check".to_string();
        let mut report = |f: f64| {
            progress(Progress {
                fraction: 0.85 + 0.1 * f,
                stage: stage.clone(),
            })
        };
        // The other estimator, linearised at this one's answer.
        let other = match opts.estimator {
            EstimatorKind::Kf => lsq_as_pass(ctx, &params, &effects, &mut report)?,
            EstimatorKind::Lsq => kf_pass(ctx, &params, &effects, &mut report)?,
        };
        let (kf_sigma, lsq_sigma) = match opts.estimator {
            EstimatorKind::Kf => (&last.sigma, &other.sigma),
            EstimatorKind::Lsq => (&other.sigma, &last.sigma),
        };
        let mut d = ErrorParameters::zero();
        d.si.copy_from_slice(&other.delta[..N_PARAMS]);
        let other_params = params.compose(&d);
        let (kf_p, lsq_p) = match opts.estimator {
            EstimatorKind::Kf => (&params, &other_params),
            EstimatorKind::Lsq => (&other_params, &params),
        };
        let check = cross_check_report(kf_p, kf_sigma, lsq_p, lsq_sigma);
        if opts.estimator == EstimatorKind::Lsq {
            last.dwell_residuals = other.dwell_residuals;
            last.history = other.history;
            last.model_check = other.model_check;
        }
        Some(check)
    } else {
        None
    };
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

    let prior = prior_sigma(opts.prior_scale);
    let mut warnings: Vec<String> = unsettled.into_iter().collect();
    let mut poorly_observable = Vec::new();
    let mut parameters = std::collections::BTreeMap::new();
    for (i, info) in PARAMETERS.iter().enumerate() {
        let sigma = last.sigma[i];
        if sigma > POORLY_OBSERVABLE * prior[i] {
            poorly_observable.push(info.name.to_string());
            warnings.push(format!(
                "{} is poorly observable on this run's scheme: its σ is {:.0}% of the prior",
                info.name,
                100.0 * sigma / prior[i]
            ));
        }
        parameters.insert(
            info.name.to_string(),
            ParameterEstimate {
                value: params.canonical(i),
                sigma: sigma / info.si_per_unit,
                unit: info.unit.to_string(),
            },
        );
    }
    if let Some(curve) = ctx.temperature.as_ref() {
        let span = curve.span_c();
        if span >= THERMAL_SPAN_C && !opts.model.has(Effect::Thermal) {
            warnings.push(format!(
                "the unit's temperature spanned {span:.1} °C during the run, and its parameters \
                 move with it: calibrate with thermal states (`--thermal`, model {}) to estimate \
                 their coefficients",
                opts.model.and(Effect::Thermal)
            ));
        }
    }
    let mut effect_estimates = std::collections::BTreeMap::new();
    for (j, state) in effect_states.iter().enumerate() {
        let sigma = last.sigma[N_PARAMS + j];
        let prior_si = state.prior_sigma() * state.si_per_unit();
        if sigma > POORLY_OBSERVABLE * prior_si {
            poorly_observable.push(state.name());
            warnings.push(format!(
                "{} is poorly observable on this run's scheme: its σ is {:.0}% of the prior",
                state.name(),
                100.0 * sigma / prior_si
            ));
        }
        if is_thermal(*state) {
            continue;
        }
        effect_estimates.insert(
            state.name(),
            ParameterEstimate {
                value: effects[j] / state.si_per_unit(),
                sigma: sigma / state.si_per_unit(),
                unit: state.unit().to_string(),
            },
        );
    }
    if let Some(check) = &cross_check {
        for name in &check.flagged {
            warnings.push(format!(
                "{name}: the filter and the least-squares cross-check differ by more than 3 combined σ"
            ));
        }
    }
    warnings.extend(scan.gaps.iter().map(|g| g.warning(&scan.segments)));
    let n_dwells = scan.dwells().count();
    if n_dwells < MULTI_POSITION_DWELLS {
        warnings.push(format!(
            "only {n_dwells} dwells found; the base model needs a multi-position scheme"
        ));
    }
    let thermal = match (opts.model.has(Effect::Thermal), ctx.temperature.as_ref()) {
        (true, Some(curve)) => {
            let covariance = last.covariance.as_ref().ok_or_else(|| {
                CalibError::Numerical("the thermal states' pass kept no covariance".into())
            })?;
            let t = curve.summary();
            Some(run_thermal(
                &params,
                &effect_states,
                &effects,
                covariance,
                [t.min_c, t.max_c],
            ))
        }
        _ => None,
    };
    let (roll, pitch, heading) = euler_from_dcm(&last.c_b_n0);
    let dwell1 = first_dwell(scan)?;
    progress(Progress {
        fraction: 1.0,
        stage: "done".into(),
    });
    Ok(CalibrationResult {
        estimator: opts.estimator.name().into(),
        model: opts.model.to_string(),
        parameters,
        effects: effect_estimates,
        warnings,
        poorly_observable,
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
    })
}

/// A least-squares solution in the form of a filter pass.
fn lsq_as_pass(
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
    })
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
