//! The discrepancy workflow: where do the measured run and a
//! simulation of it from its own calibration disagree, which effect
//! outside the 24-parameter model explains it, and how much of the gap
//! is left once that effect is modelled.
//!
//! 1. Calibrate with the base model (`calib::estimate`).
//! 2. Reconstruct the scheme from the gyro data (`reconstruct`), simulate
//!    it from the calibration without noise, navigate the measured and
//!    the simulated run the same way and form the gap at nodes in the
//!    dwells (`gap`): each dwell's drift and each rotation's velocity
//!    step, with its covariance under noise alone.
//! 3. Fit every candidate effect's signature (simulated, one run per
//!    parameter) jointly with the base parameters; score by BIC; name the
//!    best when it beats "no effect" by a clear margin; say when two
//!    candidates cannot be told apart (and which turn would part them,
//!    `separate`); iterate until nothing significant remains (`select`,
//!    over the columns of `library`). The conclusion is a `Verdict`.
//! 4. The final calibration is the joint least-squares fit of the base
//!    parameters and the named effects, linearised at the base
//!    calibration (effects at these sizes are linear; the scale-factor
//!    asymmetry is linear in A). `assemble` turns the selection into the
//!    `report`, with where each step's gap lives (`localise`) and what
//!    the run could have seen (`detect`).
//!
//! No I/O: records come through `RecordSource`; `pipeline::diagnose_file`
//! is the file-backed entry point.

mod assemble;
pub mod candidates;
pub mod detect;
pub mod error;
pub mod gap;
mod library;
mod localise;
pub mod options;
pub mod plot;
pub mod reconstruct;
pub mod report;
mod select;
pub mod separate;
pub mod verdict;

use std::collections::BTreeMap;
use std::sync::atomic::AtomicBool;

use crate::calib::estimate::estimate_scanned;
use crate::calib::prescan::scan_run;
use crate::calib::priors::prior_sigma;
use crate::calib::walk::{align_start, PassContext};
use crate::calib::{Progress, RecordSource, RunInfo};
use crate::model::{Effects, ErrorParameters};
use candidates::unit_effect;
use gap::{GapProblem, SimSetup};
use library::Library;
use localise::stretch_kinds;

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
    let ctx = PassContext::new(source, run, &opts.estimate, &scan, cancel);
    let base_cal = estimate_scanned(&ctx, &mut |p| {
        progress(Progress {
            fraction: 0.4 * p.fraction,
            stage: format!("base calibration: {}", p.stage),
        })
    })?;
    fn stage(progress: &mut dyn FnMut(Progress), f: f64, s: &str) {
        progress(Progress {
            fraction: f,
            stage: s.to_string(),
        })
    }
    stage(progress, 0.4, "reconstructing the scheme");
    let canonical: BTreeMap<String, f64> = base_cal
        .parameters
        .iter()
        .map(|(k, v)| (k.clone(), v.value))
        .collect();
    let params = ErrorParameters::from_canonical(&canonical)
        .map_err(|e| DiagnoseError::Numerical(e.to_string()))?;
    let c_b_n0 = align_start(&ctx, &params.compensator())?;
    let recon = reconstruct::reconstruct(
        source,
        &scan,
        run.sample_rate_hz,
        &params.compensator(),
        &c_b_n0,
    )?;
    stage(progress, 0.45, "navigating the measured run");
    let nodes = gap::measured_nodes(&ctx, &params, &c_b_n0, &mut |_| {})?;

    let lib = Library::new();
    let unit_effects: Vec<Effects> = lib
        .candidates
        .iter()
        .flat_map(|c| (0..c.params.len()).map(move |j| unit_effect(c, j)))
        .collect();
    let setup = SimSetup {
        site: run.site,
        sample_rate_hz: run.sample_rate_hz,
        scheme: &recon.scheme,
        params,
        c_b_n0,
        cancel,
    };
    stage(progress, 0.5, "simulating the candidates' signatures");
    let sig = gap::signatures(&setup, &nodes, &unit_effects, &mut |f| {
        progress(Progress {
            fraction: 0.5 + 0.4 * f,
            stage: "simulating the candidates' signatures".into(),
        })
    })?;
    let problem = GapProblem::new(&ctx, &nodes, &sig, lib.n)?;
    let prior = prior_sigma(opts.estimate.prior_scale);
    stage(progress, 0.9, "selecting effects");

    let selection = select::select(&select::Selector {
        lib: &lib,
        problem: &problem,
        opts,
        params: &params,
        prior: &prior,
        ctx: &ctx,
        recon: &recon,
        c_b_n0,
    })?;
    let kinds = stretch_kinds(&nodes, &scan.segments);
    let report = assemble::report(
        assemble::Inputs {
            opts,
            lib: &lib,
            problem: &problem,
            nodes: &nodes,
            sig: &sig,
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

/// The candidates' names, in library order.
pub fn candidate_names() -> Vec<&'static str> {
    Library::new().candidates.iter().map(|c| c.name).collect()
}
