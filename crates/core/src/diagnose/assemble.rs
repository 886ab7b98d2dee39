//! From the selection to the report: each step in figures and words with
//! where its gap lives, the final calibration (the base calibration with
//! the fitted corrections and the named effects), the gap series, and what
//! the run could have seen.

use nalgebra::Vector3;

use super::detect;
use super::gap::{GapFit, GapProblem, Nodes};
use super::library::{effect_estimates, explanation, Library};
use super::localise::{localise, segment_gaps, StretchKind};
use super::options::DiagnoseOptions;
use super::reconstruct::Reconstruction;
use super::report::{DiagnoseReport, DiagnoseStep, GapSeries};
use super::select::{Outcome, Selection, SelectionStep};
use crate::calib::{CalibrationResult, Effect, ErrorModel, ParameterEstimate, ResultEstimator};
use crate::model::{ErrorParameters, PARAMETERS};

/// Everything the report is assembled from.
pub(crate) struct Inputs<'a> {
    pub opts: &'a DiagnoseOptions,
    pub lib: &'a Library,
    pub problem: &'a GapProblem,
    pub nodes: &'a Nodes,
    pub kinds: &'a [StretchKind],
    /// The run's start (start of the first record's interval) and length, s.
    pub t0: f64,
    pub t_total: f64,
    pub sample_rate_hz: f64,
    /// The base calibration, as a result and as parameters, and the
    /// priors that scale the fits' base corrections.
    pub base_cal: CalibrationResult,
    pub params: &'a ErrorParameters,
    pub prior: &'a [f64],
    /// The run's turns as a scheme, or why they are not one.
    pub recon: Result<Reconstruction, String>,
}

/// The report.
pub(crate) fn report(inp: Inputs, sel: Selection) -> DiagnoseReport {
    let lib = inp.lib;
    let mut warnings = Vec::new();
    if sel.stopped_at_max {
        warnings.push(sel.verdict.to_string());
    }
    if let Err(why) = &inp.recon {
        warnings.push(format!(
            "the run's turns are not described as a scheme: {why}"
        ));
    }
    let left = &sel.current;
    warnings.extend(sel.verdict.beyond_the_gap_model(left.chi2, left.dof));
    let steps: Vec<DiagnoseStep> = sel.steps.iter().map(|s| step(&inp, &sel, s)).collect();
    let final_expl = explanation(lib, inp.params, inp.prior, &sel.current, &sel.named);
    let calibration = final_calibration(&inp, &sel, &final_expl.params);
    let effects = final_expl.effects;
    let series = series(&inp, &sel);
    let detectable = detectable(&inp, &sel, &steps, &mut warnings);
    let (first_fit, current) = (&sel.first_fit, &sel.current);
    let floor = first_fit.noise_floor_rms();
    let excess = |rms: f64| (rms * rms - floor * floor).max(0.0).sqrt();
    DiagnoseReport {
        named: lib.effects_of(&sel.named),
        named_candidates: sel
            .named
            .iter()
            .map(|&c| lib.candidates[c].name.to_string())
            .collect(),
        verdict: sel.verdict.clone(),
        gap_rms_before: first_fit.gap_rms(),
        gap_rms_after: current.gap_rms(),
        noise_floor_rms: floor,
        gap_excess_before: excess(first_fit.gap_rms()),
        gap_excess_after: excess(current.gap_rms()),
        z_before: first_fit.z(),
        z_after: current.z(),
        detectable,
        segments_before: segment_gaps(first_fit, inp.nodes, inp.kinds, inp.t0),
        segments_after: segment_gaps(current, inp.nodes, inp.kinds, inp.t0),
        calibration,
        effects,
        base_calibration: inp.base_cal,
        scheme: inp.recon.ok(),
        steps,
        series,
        warnings,
    }
}

/// One step in figures and words.
fn step(inp: &Inputs, sel: &Selection, s: &SelectionStep) -> DiagnoseStep {
    let fit = &s.fit;
    let segs = segment_gaps(fit, inp.nodes, inp.kinds, inp.t0);
    let localisation = localise(
        fit,
        inp.nodes,
        inp.kinds,
        &segs,
        inp.t0,
        inp.t_total,
        inp.opts.significance_sigma,
    );
    let mut out = DiagnoseStep {
        model: inp.lib.effects_of(&s.model),
        gap_rms: fit.gap_rms(),
        noise_floor_rms: fit.noise_floor_rms(),
        chi2: fit.chi2,
        dof: fit.dof,
        z: fit.z(),
        significant: s.significant,
        candidates: s.scores.clone(),
        localisation,
        named: None,
        indistinguishable: Vec::new(),
        separating_turns: Vec::new(),
        decision: String::new(),
    };
    match &s.outcome {
        Outcome::NothingFurther => {
            out.decision = if s.significant {
                "the gap exceeds the noise but no candidate explains it".into()
            } else {
                "no significant effect".into()
            };
        }
        Outcome::Named { score } => {
            let best = &s.scores[*score];
            out.named = Some(best.effect.clone());
            out.decision = format!(
                "named {} (dBIC {:.1}, probability {:.3})",
                best.effect, best.delta_bic, best.probability
            );
        }
        Outcome::Ambiguous { rivals, turns } => {
            out.indistinguishable = rivals.clone();
            out.separating_turns = turns.clone();
            out.decision = sel.verdict.to_string();
        }
    }
    out
}

/// The final calibration: `final_params` (the base corrections composed
/// into the base calibration) with their σ, and the effects as fitted.
fn final_calibration(
    inp: &Inputs,
    sel: &Selection,
    final_params: &ErrorParameters,
) -> CalibrationResult {
    let (lib, prior, current, named) = (inp.lib, inp.prior, &sel.current, &sel.named);
    let mut calibration = inp.base_cal.clone();
    for (i, info) in PARAMETERS.iter().enumerate() {
        calibration.parameters.insert(
            info.name.to_string(),
            ParameterEstimate {
                value: final_params.canonical(i),
                sigma: current.base_sigma[i] * prior[i] / info.si_per_unit,
                unit: info.unit.to_string(),
            },
        );
    }
    let mut model = ErrorModel::base();
    for &c in named {
        let effect = Effect::from_name(lib.candidates[c].effect);
        model = model.and(effect.expect("a candidate's effect is a model effect (tested)"));
        for e in effect_estimates(lib, current, c) {
            calibration.effects.insert(
                e.name,
                ParameterEstimate {
                    value: e.value,
                    sigma: e.sigma,
                    unit: e.unit,
                },
            );
        }
    }
    calibration.model = model;
    calibration.estimator = ResultEstimator::KfThenGapFit;
    calibration.cross_check = None;
    calibration.dwell_residuals.clear();
    calibration.convergence = Default::default();
    // The filter's check judged the base model; with effects named, the
    // gap after the refit is the check of the model reported here.
    if !named.is_empty() {
        calibration.model_check = None;
    }
    calibration
}

/// The node residuals before and after, and the open-loop velocity
/// less the named effects' contribution along the run's motion.
fn series(inp: &Inputs, sel: &Selection) -> GapSeries {
    let (nodes, n) = (inp.nodes, inp.opts.series_points);
    let to3 = |v: Vector3<f64>| -> [f64; 3] { v.into() };
    let node_t: Vec<f64> = nodes.t[1..].iter().map(|t| t - inp.t0).collect();
    let res_v = |f: &GapFit| -> Vec<[f64; 3]> {
        f.residual
            .iter()
            .map(|r| to3(r.fixed_rows::<3>(3).into_owned()))
            .collect()
    };
    let dt = 1.0 / inp.sample_rate_hz;
    let named_cols = inp.lib.columns_of(&sel.named);
    let ol: Vec<(f64, [f64; 3], [f64; 3])> = nodes
        .series
        .iter()
        .enumerate()
        .map(|(i, (k, v))| {
            let before = *v;
            let mut after = before;
            for (pos, &col) in named_cols.iter().enumerate() {
                after -= nodes.series_e[i].column(col) * sel.current.theta[pos];
            }
            (*k as f64 * dt, to3(before), to3(after))
        })
        .collect();
    let ol = decimate(&ol, n);
    GapSeries {
        t: decimate(&node_t, n),
        before: decimate(&res_v(&sel.first_fit), n),
        after: decimate(&res_v(&sel.current), n),
        open_loop_t: ol.iter().map(|x| x.0).collect(),
        open_loop_before: ol.iter().map(|x| x.1).collect(),
        open_loop_after: ol.iter().map(|x| x.2).collect(),
    }
}

/// What the run could see, against the last step's dispersion: from one
/// fit carrying every effect column, their joint information. A failure
/// there costs the thresholds, not the diagnosis.
fn detectable(
    inp: &Inputs,
    sel: &Selection,
    steps: &[DiagnoseStep],
    warnings: &mut Vec<String>,
) -> Vec<detect::DetectionThreshold> {
    let (lib, current) = (inp.lib, &sel.current);
    let dispersion = steps
        .last()
        .and_then(|s| s.candidates.first())
        .map_or((current.chi2 / current.dof).max(1.0), |c| c.dispersion);
    let columns: Vec<detect::Column> = lib
        .candidates
        .iter()
        .enumerate()
        .map(|(c, candidate)| detect::Column {
            candidate,
            columns: lib.columns(c),
        })
        .collect();
    match inp.problem.fit(&(0..lib.n).collect::<Vec<_>>()) {
        Ok(all) => {
            let visibility = detect::Visibility::from_covariance(
                &all.theta_cov,
                dispersion,
                current.n_obs() as f64,
            );
            (0..lib.candidates.len())
                .flat_map(|c| {
                    detect::thresholds(&columns, c, &sel.named, &visibility, inp.opts.bic_threshold)
                })
                .collect()
        }
        Err(e) => {
            warnings.push(format!("no detection thresholds: {e}"));
            Vec::new()
        }
    }
}

/// Keeps at most `n` evenly spaced items.
fn decimate<T: Clone>(v: &[T], n: usize) -> Vec<T> {
    if v.len() <= n || n == 0 {
        return v.to_vec();
    }
    let step = v.len().div_ceil(n);
    v.iter().step_by(step).cloned().collect()
}
