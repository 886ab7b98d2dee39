//! The discrepancy workflow: where do the measured run and a
//! simulation of it from its own calibration disagree, which effect
//! outside the 24-parameter model explains it, and how much of the gap
//! is left once that effect is modelled.
//!
//! 1. Calibrate with the base model (`calib::estimate`).
//! 2. Navigate the measured run from the calibration, open loop, and form
//!    the gap at nodes in the dwells (`gap`): each dwell's drift and each
//!    turn's velocity step, with its covariance under noise alone. On the
//!    same walk, accumulate every candidate effect's columns from the
//!    motion the run measured (`estimation::effect_columns`): no model of
//!    the scheme is needed, so hand flips and tilted axes are diagnosed
//!    like table turns. The scheme is reconstructed (`reconstruct`) only
//!    to describe the run and pace a proposed probe turn.
//! 3. Fit every candidate effect's signature jointly with the base
//!    parameters; score by BIC; name the
//!    best when it beats "no effect" by a clear margin; say when two
//!    candidates cannot be told apart (and which turn would part them,
//!    `separate`); iterate until nothing significant remains (`select`,
//!    over the columns of `library`). The conclusion is a `Verdict`.
//! 4. The final calibration is the joint least-squares fit of the base
//!    parameters and the named effects, refitted once about their fitted
//!    values (`refit`: a large effect moves the base calibration the gap
//!    was linearised about). `assemble` turns the selection into the
//!    `report`, with where each step's gap lives (`localise`) and what
//!    the run could have seen (`detect`).
//!
//! A run whose temperature column spans a few °C also offers `thermal`
//! (SPEC §3a): its columns follow the run's own ΔT(t) and Ṫ(t).
//!
//! No I/O: records come through `RecordSource`; `pipeline::diagnose_file`
//! is the file-backed entry point.

pub mod adopt;
mod assemble;
pub mod candidates;
pub mod detect;
pub mod error;
pub mod gap;
mod gap_wander;
mod library;
mod localise;
pub mod options;
pub mod plot;
pub mod reconstruct;
mod refit;
pub mod report;
mod select;
pub mod separate;
pub mod verdict;

use std::collections::BTreeMap;
use std::sync::atomic::AtomicBool;

use crate::calib::estimate::estimate_base_for_diagnosis;
use crate::calib::plan::PlanInput;
use crate::calib::prescan::scan_run;
use crate::calib::sources::SimSource;
use crate::calib::temperature::THERMAL_SPAN_C;
use crate::calib::walk::{align_start, PassContext};
use crate::calib::{EstimateOptions, Progress, RecordSource, RunInfo};
use crate::estimation::priors::prior_sigma;
use crate::model::ErrorParameters;
use gap::GapProblem;
use library::Library;
use localise::stretch_kinds;

pub use adopt::NotAdoptable;
pub use error::DiagnoseError;
pub use options::DiagnoseOptions;
pub use report::{
    CandidateScore, DiagnoseReport, DiagnoseStep, EffectEstimate, GapSeries, Localisation,
    SegmentGap,
};
pub use verdict::{Remainder, Verdict};

/// Diagnoses a run: the one entry point the CLI and the server call
/// (through `pipeline::diagnose_file`).
pub fn diagnose(
    source: &dyn RecordSource,
    run: &RunInfo,
    opts: &DiagnoseOptions,
    progress: &mut dyn FnMut(Progress),
    cancel: &AtomicBool,
) -> Result<DiagnoseReport, DiagnoseError> {
    progress(Progress {
        fraction: 0.0,
        stage: "base calibration: scanning the run".into(),
    });
    let scan = scan_run(source, run, &opts.estimate, cancel)?;
    let temperature = source.temperature()?;
    let thermal = temperature
        .as_ref()
        .is_some_and(|c| c.span_c() >= THERMAL_SPAN_C);
    let ctx = PassContext::new(source, run, &opts.estimate, &scan, cancel)
        .with_temperature(temperature)
        .with_run_heading()?;
    let base = estimate_base_for_diagnosis(&ctx, &mut |p| {
        progress(Progress {
            fraction: 0.4 * p.fraction,
            stage: format!("base calibration: {}", p.stage),
        })
    })?;
    // The gap is weighed under the noise model the calibration ran under:
    // on a real unit, its wander and its white densities without pulses.
    let ctx = ctx.with_noise(base.noise);
    let base_cal = base.result;
    fn stage(progress: &mut dyn FnMut(Progress), f: f64, s: &str) {
        progress(Progress {
            fraction: f,
            stage: s.to_string(),
        })
    }
    stage(progress, 0.4, "describing the run's turns");
    let canonical: BTreeMap<String, f64> = base_cal
        .parameters
        .iter()
        .map(|(k, v)| (k.clone(), v.value))
        .collect();
    let params = ErrorParameters::from_canonical(&canonical)
        .map_err(|e| DiagnoseError::Numerical(e.to_string()))?;
    let c_b_n0 = align_start(&ctx, &params.compensator())?;
    // Only describes the run and sets the pace of a proposed probe turn:
    // a run whose turns fit no scheme (by hand, about tilted axes) is
    // diagnosed all the same.
    let recon = match reconstruct::reconstruct(
        source,
        &scan,
        run.sample_rate_hz,
        &params.compensator(),
        &c_b_n0,
    ) {
        Ok(r) => Ok(r),
        Err(DiagnoseError::Scheme(why)) => Err(why),
        Err(e) => return Err(e),
    };

    let lib = Library::new(thermal);
    let cols = gap::GapColumns::of(&lib.candidates);
    stage(
        progress,
        0.45,
        "navigating the run with every candidate's columns",
    );
    let nodes = gap::measured_nodes(&ctx, &params, &c_b_n0, &cols.states, &[], &mut |f| {
        progress(Progress {
            fraction: 0.45 + 0.45 * f,
            stage: "navigating the run with every candidate's columns".into(),
        })
    })?;
    let problem = GapProblem::new(&ctx, &nodes, cols.delay)?;
    let prior = prior_sigma(ctx.priors());
    stage(progress, 0.9, "selecting effects");

    let selection = select::select(&select::Selector {
        lib: &lib,
        problem: &problem,
        opts,
        params: &params,
        prior: &prior,
        ctx: &ctx,
        recon: recon.as_ref().ok(),
        c_b_n_end: nodes.c_b_n_end,
    })?;
    let (params, selection) = if selection.named.is_empty() {
        (params, selection)
    } else {
        stage(progress, 0.95, "refitting about the named effects");
        refit::relinearise(&ctx, &lib, &cols, &params, &prior, opts, selection)?
    };
    let kinds = stretch_kinds(&nodes, &scan.segments);
    let report = assemble::report(
        assemble::Inputs {
            opts,
            lib: &lib,
            problem: &problem,
            nodes: &nodes,
            kinds: &kinds,
            t0: scan.t_begin,
            t_total: scan.t_end - scan.t_begin,
            sample_rate_hz: run.sample_rate_hz,
            base_cal,
            params: &params,
            prior: &prior,
            recon,
        },
        selection,
    );
    stage(progress, 1.0, "done");
    Ok(report)
}

/// What a run of a scheme would name, before any data exists: the
/// detection thresholds of a diagnosis of a noise-free simulated run of
/// an error-free unit with the noise densities imposed (as `calib::plan`
/// does for the parameters' σ). The thresholds come from the fit's
/// information, which depends on the motion and the noise model, not on
/// the measured values; a noise-free run's gap is zero, so the dispersion
/// is the noise's own.
pub fn thresholds_before_data(
    input: &PlanInput,
    cancel: &AtomicBool,
) -> Result<Vec<detect::DetectionThreshold>, DiagnoseError> {
    let cfg = input.noise_free_run();
    let defaults = DiagnoseOptions::default();
    let opts = DiagnoseOptions {
        estimate: EstimateOptions {
            noise: Some(input.noise),
            ..defaults.estimate.clone()
        },
        ..defaults
    };
    let run = RunInfo {
        site: input.site,
        sample_rate_hz: input.sample_rate_hz,
    };
    let report = diagnose(&SimSource(cfg), &run, &opts, &mut |_| {}, cancel)?;
    Ok(report.detectable)
}

/// The candidates' names, in library order (`thermal` last, offered for
/// runs whose temperature moves).
pub fn candidate_names() -> Vec<&'static str> {
    Library::new(true)
        .candidates
        .iter()
        .map(|c| c.name)
        .collect()
}
