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
//!    candidates cannot be told apart; iterate until nothing significant
//!    remains.
//! 4. The final calibration is the joint least-squares fit of the base
//!    parameters and the named effects, linearised at the base
//!    calibration (effects at these sizes are linear; the scale-factor
//!    asymmetry is linear in A).
//!
//! No I/O: records come through `RecordSource`; `pipeline::diagnose_file`
//! is the file-backed entry point.

pub mod candidates;
pub mod detect;
pub mod gap;
pub mod plot;
pub mod reconstruct;
pub mod separate;

use std::collections::BTreeMap;
use std::sync::atomic::AtomicBool;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::calib::estimate::estimate_scanned;
use crate::calib::prescan::scan_run;
use crate::calib::walk::{align_start, PassContext};
use crate::calib::{
    CalibError, CalibrationResult, EstimateOptions, ParameterEstimate, Progress, RecordSource,
    RunInfo, SegmentKind,
};
use crate::model::{Effects, ErrorParameters, PARAMETERS};
use candidates::{library, unit_effect, Candidate};
use gap::{GapFit, GapProblem, Nodes, SimSetup};
use reconstruct::Reconstruction;

/// Errors of the discrepancy workflow.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// The run's scheme cannot be reconstructed or simulated.
    #[error("scheme: {0}")]
    Scheme(String),
    #[error("numerical failure: {0}")]
    Numerical(String),
}

/// Tunable parts of the workflow.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DiagnoseOptions {
    /// The base calibration's options.
    pub estimate: EstimateOptions,
    /// A candidate is named when its BIC beats the current model's by
    /// more than this (10 is "very strong" evidence on the Kass–Raftery
    /// scale: a likelihood ratio above e⁵ after the parameter charge).
    pub bic_threshold: f64,
    /// The gap is significant when its χ² exceeds its expectation under
    /// noise by this many σ of χ².
    pub significance_sigma: f64,
    /// Most effects added.
    pub max_effects: usize,
    /// Most points of each series in the report.
    pub series_points: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            estimate: EstimateOptions {
                cross_check: false,
                ..EstimateOptions::default()
            },
            bic_threshold: 10.0,
            significance_sigma: 3.0,
            max_effects: 4,
            series_points: 1000,
        }
    }
}

/// A fitted effect parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EffectEstimate {
    pub name: String,
    pub value: f64,
    pub sigma: f64,
    pub unit: String,
}

/// One candidate's score at one step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CandidateScore {
    /// SPEC §3 name.
    pub effect: String,
    /// The parameterisation (e.g. `accel_lever_arm_full`).
    pub candidate: String,
    pub n_params: usize,
    /// Drop of the weighted residual cost when the candidate is added.
    pub delta_chi2: f64,
    /// The scale Δχ² is judged against: χ²/dof left by the step's
    /// best-fitting candidate, at least 1 (the same for every candidate).
    pub dispersion: f64,
    /// Δχ²/dispersion − k ln n: positive favours the candidate.
    pub delta_bic: f64,
    /// Posterior probability among "no further effect" and the candidates
    /// (BIC weights).
    pub probability: f64,
    pub params: Vec<EffectEstimate>,
}

/// Where the gap lives.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Localisation {
    /// Excess χ² (χ² − its expectation) in rotation steps and in dwells.
    pub excess_rotations: f64,
    pub excess_dwells: f64,
    /// Per navigation axis (E, N, U): mean squared velocity residual over
    /// its expectation (1 under noise alone).
    pub axis_ratio: [f64; 3],
    /// Mean normalised excess of the dwell stretches in the first and
    /// second half of the run.
    pub excess_first_half: f64,
    pub excess_second_half: f64,
    /// Segments whose gap exceeds the noise (by `significance_sigma`).
    pub segments: Vec<String>,
    pub summary: String,
}

/// The gap of one segment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentGap {
    /// `dwell` or `rotation`.
    pub kind: String,
    /// 1-based number among the run's dwells or rotations.
    pub index: usize,
    pub t_start: f64,
    pub t_end: f64,
    /// Velocity residual (E, N, U): a dwell's drift summed over its
    /// stretches, a rotation's step, m/s.
    pub gap_mps: [f64; 3],
    /// Its 1-σ under noise alone, m/s.
    pub sigma_mps: [f64; 3],
    /// The segment's share of the step's χ² and of its expectation under
    /// noise alone: summed over the segments they give the step's.
    pub chi2: f64,
    pub dof: f64,
}

/// One iteration: the gap of the current model and what was decided.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagnoseStep {
    /// Effects in the model when the gap was measured.
    pub model: Vec<String>,
    pub gap_rms: f64,
    pub noise_floor_rms: f64,
    pub chi2: f64,
    /// Expected χ² under noise alone.
    pub dof: f64,
    /// (χ² − dof)/√(2 dof).
    pub z: f64,
    pub significant: bool,
    pub candidates: Vec<CandidateScore>,
    pub localisation: Localisation,
    /// The effect named at this step, if any.
    pub named: Option<String>,
    /// Candidates that fit as well as the best and cannot be told apart.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub indistinguishable: Vec<String>,
    /// For each of them, the turn that would part it from the best.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub separating_turns: Vec<separate::SeparatingTurn>,
    pub decision: String,
}

/// Gap time series: node residuals (m/s) before and after, and the open-
/// loop velocity difference measured − simulated at 1 Hz (decimated).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GapSeries {
    /// Node times from the run's start, s.
    pub t: Vec<f64>,
    pub before: Vec<[f64; 3]>,
    pub after: Vec<[f64; 3]>,
    pub open_loop_t: Vec<f64>,
    /// Measured − simulated from the base calibration.
    pub open_loop_before: Vec<[f64; 3]>,
    /// The same less the named effects' simulated contribution.
    pub open_loop_after: Vec<[f64; 3]>,
}

/// What `sinscal diagnose` produces.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagnoseReport {
    /// Effects added, in order (SPEC §3 names).
    pub named: Vec<String>,
    /// The parameterisation of each (candidate names, same order).
    pub named_candidates: Vec<String>,
    /// "named: …", "no significant effect", "unexplained: no candidate
    /// fits" or "ambiguous: …".
    pub verdict: String,
    pub gap_rms_before: f64,
    pub gap_rms_after: f64,
    pub noise_floor_rms: f64,
    /// The gap's excess over the noise floor, √(rms² − floor²), before
    /// and after, m/s.
    pub gap_excess_before: f64,
    pub gap_excess_after: f64,
    pub z_before: f64,
    pub z_after: f64,
    /// What the run could see: for every candidate, the smallest effect
    /// it would have named, and not called ambiguous, beyond the named
    /// effects (each quantity along its most visible direction, and each
    /// parameter alone).
    #[serde(default)]
    pub detectable: Vec<detect::DetectionThreshold>,
    /// The final calibration (SPEC §5 result with the effect parameters).
    pub calibration: CalibrationResult,
    /// The named effects in SPEC §3 JSON form.
    pub effects: Effects,
    /// The base-model calibration the workflow started from.
    pub base_calibration: CalibrationResult,
    pub scheme: Reconstruction,
    pub steps: Vec<DiagnoseStep>,
    pub segments_before: Vec<SegmentGap>,
    pub segments_after: Vec<SegmentGap>,
    pub series: GapSeries,
    pub warnings: Vec<String>,
}

impl DiagnoseReport {
    /// A readable summary.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut o = String::new();
        let _ = writeln!(o, "verdict: {}", self.verdict);
        if !self.detectable.is_empty() {
            let seen = detect::describe(&self.detectable);
            if self.named.is_empty() {
                let _ = writeln!(o, "{}; this run would have named {seen}", self.verdict);
            } else {
                let _ = writeln!(
                    o,
                    "beyond the named effects this run would have named {seen}"
                );
            }
        }
        let _ = writeln!(
            o,
            "gap RMS {:.3e} m/s before, {:.3e} m/s after; noise floor {:.3e} m/s; z {:.1} -> {:.1}",
            self.gap_rms_before,
            self.gap_rms_after,
            self.noise_floor_rms,
            self.z_before,
            self.z_after
        );
        let _ = writeln!(
            o,
            "reconstructed scheme: {} rotations",
            self.scheme.rotations.len()
        );
        for (i, s) in self.steps.iter().enumerate() {
            let _ = writeln!(
                o,
                "step {}: model base-24{}; gap {:.3e} m/s (floor {:.3e}), chi2 {:.1} for {:.1} expected (z {:.1})",
                i + 1,
                s.model.iter().map(|m| format!("+{m}")).collect::<String>(),
                s.gap_rms,
                s.noise_floor_rms,
                s.chi2,
                s.dof,
                s.z
            );
            let _ = writeln!(o, "  where: {}", s.localisation.summary);
            let mut c = s.candidates.clone();
            c.sort_by(|a, b| b.delta_bic.total_cmp(&a.delta_bic));
            for cs in &c {
                let _ = writeln!(
                    o,
                    "  {:<22} k={:<2} dchi2 {:>10.1}  dBIC {:>10.1}  p {:.3}",
                    cs.candidate, cs.n_params, cs.delta_chi2, cs.delta_bic, cs.probability
                );
            }
            let _ = writeln!(o, "  -> {}", s.decision);
        }
        let _ = writeln!(o, "final calibration:");
        o.push_str(&self.calibration.table());
        o
    }
}

/// Index of every effect parameter of the library, flattened.
struct Library {
    candidates: Vec<Candidate>,
    /// First flattened index of each candidate.
    offset: Vec<usize>,
    n: usize,
}

impl Library {
    fn new() -> Self {
        let candidates = library();
        let mut offset = Vec::new();
        let mut n = 0;
        for c in &candidates {
            offset.push(n);
            n += c.params.len();
        }
        Library {
            candidates,
            offset,
            n,
        }
    }

    fn columns(&self, c: usize) -> std::ops::Range<usize> {
        self.offset[c]..self.offset[c] + self.candidates[c].params.len()
    }
}

/// The effect estimates of candidate `c` in `fit`.
fn effect_estimates(lib: &Library, fit: &GapFit, c: usize) -> Vec<EffectEstimate> {
    let cand = &lib.candidates[c];
    lib.columns(c)
        .enumerate()
        .filter_map(|(j, col)| {
            let pos = fit.effects.iter().position(|&e| e == col)?;
            let size = cand.params[j].signature_size;
            Some(EffectEstimate {
                name: cand.params[j].name.clone(),
                value: fit.theta[pos] * size,
                sigma: fit.theta_sigma[pos] * size,
                unit: cand.params[j].unit.clone(),
            })
        })
        .collect()
}

/// Where a turn appended to the run would start (the scheme's last
/// attitude) and how it would run (the scheme's median rate, acceleration
/// and dwell).
fn probe_context<'a>(
    ctx: &PassContext<'a>,
    recon: &Reconstruction,
    params: &'a ErrorParameters,
    c_b_n0: &nalgebra::Matrix3<f64>,
) -> Result<separate::ProbeContext<'a>, DiagnoseError> {
    let trajectory = crate::sim::trajectory::Trajectory::new(&recon.scheme, c_b_n0, &ctx.run.site)
        .map_err(DiagnoseError::Scheme)?;
    let median = |mut v: Vec<f64>, default: f64| -> f64 {
        if v.is_empty() {
            return default;
        }
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let rate_dps = median(recon.rotations.iter().map(|r| r.rate_dps).collect(), 10.0);
    let accel_dps2 = median(recon.rotations.iter().map(|r| r.accel_dps2).collect(), 10.0);
    let dwell_s = median(
        recon
            .scheme
            .steps
            .iter()
            .filter_map(|s| match s {
                crate::sim::scheme::Step::Dwell { dwell_s } => Some(*dwell_s),
                _ => None,
            })
            .collect(),
        300.0,
    );
    Ok(separate::ProbeContext {
        site: ctx.run.site,
        sample_rate_hz: ctx.run.sample_rate_hz,
        c_b_n_start: trajectory.c_b_n_end(),
        compensation: params,
        rate_dps,
        accel_dps2,
        dwell_s,
        arw: ctx.arw,
        vrw: ctx.vrw,
        cancel: ctx.cancel,
    })
}

/// What a fit says the sensor is: the base calibration `params` with the
/// fit's base corrections composed in, and the effects of candidates
/// `cands` at their fitted values.
fn explanation(
    lib: &Library,
    params: &ErrorParameters,
    prior: &[f64],
    fit: &GapFit,
    cands: &[usize],
) -> separate::Explanation {
    let mut delta = ErrorParameters::zero();
    for ((d, b), s) in delta.si.iter_mut().zip(&fit.base).zip(prior) {
        *d = b * s;
    }
    let mut effects = Effects::none();
    for &c in cands {
        let values: Vec<f64> = effect_estimates(lib, fit, c)
            .iter()
            .map(|e| e.value)
            .collect();
        candidates::add_effect(&mut effects, lib.candidates[c].name, &values);
    }
    separate::Explanation {
        params: params.compose(&delta),
        effects,
    }
}

/// What each stretch between nodes is: a piece of dwell d or the rotation
/// step out of dwell d (d the ordinal among dwells, 0-based).
#[derive(Clone, Copy, PartialEq, Eq)]
enum StretchKind {
    Dwell(usize),
    Rotation(usize),
}

fn stretch_kinds(nodes: &Nodes, segments: &[crate::calib::RunSegment]) -> Vec<StretchKind> {
    let ordinal: Vec<usize> = segments
        .iter()
        .scan(0usize, |n, s| {
            let o = *n;
            if s.kind == SegmentKind::Dwell {
                *n += 1;
            }
            Some(o)
        })
        .collect();
    (0..nodes.t.len() - 1)
        .map(|k| {
            let (a, b) = (nodes.segment[k], nodes.segment[k + 1]);
            if a == b {
                StretchKind::Dwell(ordinal[a])
            } else {
                StretchKind::Rotation(ordinal[a])
            }
        })
        .collect()
}

fn segment_gaps(fit: &GapFit, nodes: &Nodes, kinds: &[StretchKind], t0: f64) -> Vec<SegmentGap> {
    let mut out: Vec<SegmentGap> = Vec::new();
    for (k, kind) in kinds.iter().enumerate() {
        let (name, index) = match kind {
            StretchKind::Dwell(d) => ("dwell", d + 1),
            StretchKind::Rotation(d) => ("rotation", d + 1),
        };
        let r = fit.residual[k];
        let c = &fit.residual_cov[k];
        let new = !matches!(out.last(), Some(s) if s.kind == name && s.index == index);
        if new {
            out.push(SegmentGap {
                kind: name.into(),
                index,
                t_start: nodes.t[k] - t0,
                t_end: nodes.t[k + 1] - t0,
                gap_mps: [0.0; 3],
                sigma_mps: [0.0; 3],
                chi2: 0.0,
                dof: 0.0,
            });
        }
        let s = out.last_mut().expect("pushed above");
        s.t_end = nodes.t[k + 1] - t0;
        for i in 0..3 {
            s.gap_mps[i] += r[3 + i];
            s.sigma_mps[i] += c[(3 + i, 3 + i)];
        }
        // The stretch's share of the run's χ², in the run's own weight.
        // Not each component over its own residual variance: the fitted
        // node attitudes leave the attitude rows with a variance that is
        // a difference of nearly equal numbers, zero or below it, and a
        // rounding-sized residual over it gave χ² of 1e270.
        s.chi2 += fit.stretch_chi2[k];
        s.dof += fit.stretch_dof[k];
    }
    for s in &mut out {
        for v in &mut s.sigma_mps {
            *v = v.max(0.0).sqrt();
        }
    }
    out
}

fn localise(
    fit: &GapFit,
    nodes: &Nodes,
    kinds: &[StretchKind],
    segs: &[SegmentGap],
    t0: f64,
    t_total: f64,
    z_sig: f64,
) -> Localisation {
    let mut loc = Localisation::default();
    let (mut first, mut n_first, mut second, mut n_second) = (0.0, 0usize, 0.0, 0usize);
    let mut axis_num = [0.0; 3];
    let mut axis_den = [0.0; 3];
    for (k, kind) in kinds.iter().enumerate() {
        let r = fit.residual[k];
        let c = &fit.residual_cov[k];
        let (chi2, exp) = (fit.stretch_chi2[k], fit.stretch_dof[k]);
        for i in 0..3 {
            axis_num[i] += r[3 + i] * r[3 + i];
            axis_den[i] += c[(3 + i, 3 + i)].max(0.0);
        }
        match kind {
            StretchKind::Rotation(_) => loc.excess_rotations += chi2 - exp,
            StretchKind::Dwell(_) => {
                loc.excess_dwells += chi2 - exp;
                let tm = 0.5 * (nodes.t[k] + nodes.t[k + 1]) - t0;
                if tm < 0.5 * t_total {
                    first += (chi2 - exp) / exp.max(1.0);
                    n_first += 1;
                } else {
                    second += (chi2 - exp) / exp.max(1.0);
                    n_second += 1;
                }
            }
        }
    }
    for i in 0..3 {
        loc.axis_ratio[i] = axis_num[i] / axis_den[i].max(f64::MIN_POSITIVE);
    }
    loc.excess_first_half = first / n_first.max(1) as f64;
    loc.excess_second_half = second / n_second.max(1) as f64;
    for s in segs {
        let dof = s.dof.max(1.0);
        if (s.chi2 - dof) / (2.0 * dof).sqrt() > z_sig {
            loc.segments.push(format!(
                "{} {} ({:.0}-{:.0} s): gap [{:.2e}, {:.2e}, {:.2e}] m/s vs sigma [{:.1e}, {:.1e}, {:.1e}]",
                s.kind,
                s.index,
                s.t_start,
                s.t_end,
                s.gap_mps[0],
                s.gap_mps[1],
                s.gap_mps[2],
                s.sigma_mps[0],
                s.sigma_mps[1],
                s.sigma_mps[2]
            ));
        }
    }
    let total = loc.excess_rotations.max(0.0) + loc.excess_dwells.max(0.0);
    let mut parts = Vec::new();
    if total <= 0.0 || loc.segments.is_empty() {
        parts.push("no segment stands out of the noise".to_string());
    } else {
        let rot = loc.excess_rotations.max(0.0) / total;
        parts.push(if rot > 0.7 {
            format!("during rotations ({:.0}% of the excess)", 100.0 * rot)
        } else if rot < 0.3 {
            format!("during dwells ({:.0}% of the excess)", 100.0 * (1.0 - rot))
        } else {
            format!(
                "in rotations and dwells alike ({:.0}% in rotations)",
                100.0 * rot
            )
        });
        let names = ["east", "north", "up"];
        let worst = (0..3)
            .max_by(|&a, &b| loc.axis_ratio[a].total_cmp(&loc.axis_ratio[b]))
            .unwrap_or(0);
        parts.push(format!(
            "axes E/N/U at {:.1}/{:.1}/{:.1}x the noise variance (mostly {})",
            loc.axis_ratio[0], loc.axis_ratio[1], loc.axis_ratio[2], names[worst]
        ));
        let (a, b) = (loc.excess_first_half, loc.excess_second_half);
        parts.push(if b > 2.0 * a.max(0.5) {
            "growing with time".to_string()
        } else {
            "not growing with time".to_string()
        });
        parts.push(format!("{} segments stand out", loc.segments.len()));
    }
    loc.summary = parts.join("; ");
    loc
}

/// Keeps at most `n` evenly spaced items.
fn decimate<T: Clone>(v: &[T], n: usize) -> Vec<T> {
    if v.len() <= n || n == 0 {
        return v.to_vec();
    }
    let step = v.len().div_ceil(n);
    v.iter().step_by(step).cloned().collect()
}

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
    let prior = crate::calib::priors::prior_sigma(opts.estimate.prior_scale);
    stage(progress, 0.9, "selecting effects");

    let kinds = stretch_kinds(&nodes, &scan.segments);
    let t0 = scan.t_begin;
    let t_total = scan.t_end - scan.t_begin;
    let mut named: Vec<usize> = Vec::new();
    let mut steps: Vec<DiagnoseStep> = Vec::new();
    let mut warnings = Vec::new();
    let verdict: String;
    let cols_of =
        |named: &[usize]| -> Vec<usize> { named.iter().flat_map(|&c| lib.columns(c)).collect() };
    let first_fit = problem.fit(&[])?;
    let mut current = first_fit.clone();
    loop {
        let n_obs = current.n_obs() as f64;
        let significant = current.z() > opts.significance_sigma;
        let mut scores = Vec::new();
        let mut fits = Vec::new();
        for (c, cand) in lib.candidates.iter().enumerate() {
            // One parameterisation per effect: a nested one would repeat
            // columns already fitted.
            if named
                .iter()
                .any(|&n| lib.candidates[n].effect == cand.effect)
            {
                continue;
            }
            let mut with = named.clone();
            with.push(c);
            fits.push((c, problem.fit(&cols_of(&with))?));
        }
        // Quasi-likelihood: when even the best-fitting candidate leaves the
        // gap far above the noise, that misfit, not the noise, is the scale
        // against which every improvement is judged, so a candidate that
        // explains a sliver of an unexplained gap is not named. One scale
        // for all candidates: each its own would rank two that explain
        // the same gap by the last digits of their residuals (lever arms
        // along the accelerometers' own axes and the cross-axis arms that
        // give the same velocity steps once the reference point is moved
        // differ by a few units of χ² on an improvement of 10⁴).
        let dispersion = fits
            .iter()
            .map(|(_, f)| f.chi2 / f.dof)
            .fold(f64::INFINITY, f64::min)
            .max(1.0);
        for (c, fit) in &fits {
            let cand = &lib.candidates[*c];
            let k = cand.params.len() as f64;
            let d_chi2 = current.objective - fit.objective;
            scores.push(CandidateScore {
                effect: cand.effect.to_string(),
                candidate: cand.name.to_string(),
                n_params: cand.params.len(),
                delta_chi2: d_chi2,
                dispersion,
                delta_bic: d_chi2 / dispersion - k * n_obs.ln(),
                probability: 0.0,
                params: effect_estimates(&lib, fit, *c),
            });
        }
        // BIC weights against "no further effect" (ΔBIC = 0).
        let m = scores.iter().map(|s| s.delta_bic).fold(0.0, f64::max);
        let norm: f64 = (-m / 2.0).exp()
            + scores
                .iter()
                .map(|s| ((s.delta_bic - m) / 2.0).exp())
                .sum::<f64>();
        for s in &mut scores {
            s.probability = ((s.delta_bic - m) / 2.0).exp() / norm;
        }
        let segs = segment_gaps(&current, &nodes, &kinds, t0);
        let localisation = localise(
            &current,
            &nodes,
            &kinds,
            &segs,
            t0,
            t_total,
            opts.significance_sigma,
        );
        let mut step = DiagnoseStep {
            model: named
                .iter()
                .map(|&c| lib.candidates[c].effect.to_string())
                .collect(),
            gap_rms: current.gap_rms(),
            noise_floor_rms: current.noise_floor_rms(),
            chi2: current.chi2,
            dof: current.dof,
            z: current.z(),
            significant,
            candidates: scores.clone(),
            localisation,
            named: None,
            indistinguishable: Vec::new(),
            separating_turns: Vec::new(),
            decision: String::new(),
        };
        let best = scores
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.delta_bic.total_cmp(&b.1.delta_bic));
        // Once an effect is named, look further only while the gap is
        // significant. The fit is linear about a base calibration that had
        // absorbed the named effect; what a large effect leaves of second
        // order is a few tens of χ² that a candidate can take up (a 0.02
        // deg/h/h drift left 30–36 for the scale asymmetry, a quarter of
        // that at half the drift), well below the omnibus test's 3σ.
        let wanted = named.is_empty() || significant;
        let Some((bi, best)) = best.filter(|(_, b)| wanted && b.delta_bic > opts.bic_threshold)
        else {
            verdict = if significant && named.is_empty() {
                "unexplained: no candidate fits".into()
            } else if significant {
                format!(
                    "named: {}; unexplained: no candidate fits the rest",
                    step.model.join(", ")
                )
            } else if named.is_empty() {
                "no significant effect".into()
            } else {
                format!(
                    "named: {}; no significant effect remains",
                    step.model.join(", ")
                )
            };
            step.decision = if significant {
                "the gap exceeds the noise but no candidate explains it".into()
            } else {
                "no significant effect".into()
            };
            steps.push(step);
            break;
        };
        // Rivals: candidates of another effect that are credible on their
        // own and that the data does not reject in favour of the best. A
        // rival is rejected when, fitted on top of it, the best's columns
        // would still earn a name (the encompassing test for non-nested
        // models); otherwise the rival explains all the best explains and
        // the scheme cannot tell them apart, whichever scores higher.
        let (best_c, best_fit) = &fits[bi];
        let k_best = best.n_params as f64;
        let mut rivals: Vec<(usize, f64)> = Vec::new();
        for (oi, other) in scores.iter().enumerate() {
            if oi == bi || other.delta_bic < opts.bic_threshold || other.effect == best.effect {
                continue;
            }
            let (oc, other_fit) = &fits[oi];
            let both: Vec<usize> = named.iter().copied().chain([*oc, *best_c]).collect();
            let union = problem.fit(&cols_of(&both))?;
            let dispersion = (union.chi2 / union.dof).max(1.0);
            let best_beyond =
                (other_fit.objective - union.objective) / dispersion - k_best * n_obs.ln();
            if best_beyond <= opts.bic_threshold {
                rivals.push((oi, best_beyond));
            }
        }
        if !rivals.is_empty() {
            // Each explanation with its own fitted parameters, probed on
            // the turns the scheme could add.
            let probe = probe_context(&ctx, &recon, &params, &c_b_n0)?;
            let with = |c: usize| -> Vec<usize> { named.iter().copied().chain([c]).collect() };
            let best_expl = explanation(&lib, &params, &prior, best_fit, &with(*best_c));
            let mut hints = Vec::new();
            for &(oi, best_beyond) in &rivals {
                let (rc, rival_fit) = &fits[oi];
                let rival = &scores[oi];
                let rival_expl = explanation(&lib, &params, &prior, rival_fit, &with(*rc));
                let turn = separate::separating_turn(
                    &probe,
                    [&best.candidate, &rival.candidate],
                    &best_expl,
                    &rival_expl,
                )?;
                let why = format!(
                    "{} vs {} (dBIC {:.1} vs {:.1}; fitted on top of {}, {} scores dBIC {:.1})",
                    best.effect,
                    rival.effect,
                    best.delta_bic,
                    rival.delta_bic,
                    rival.effect,
                    best.effect,
                    best_beyond
                );
                hints.push(match &turn {
                    Some(t) => format!("{why}: add a {}", t.describe()),
                    None => format!(
                        "{why}: no single body-axis turn parts them; {}",
                        candidates::separating_motion(&best.effect, &rival.effect)
                    ),
                });
                step.separating_turns.extend(turn);
            }
            let rival_effects: Vec<String> = rivals
                .iter()
                .map(|&(oi, _)| scores[oi].effect.clone())
                .collect();
            verdict = format!(
                "ambiguous: {} and {} cannot be told apart on this scheme ({})",
                best.effect,
                rival_effects.join(", "),
                hints.join("; ")
            );
            step.indistinguishable = rival_effects;
            step.decision = verdict.clone();
            steps.push(step);
            break;
        }
        step.named = Some(best.effect.clone());
        step.decision = format!(
            "named {} (dBIC {:.1}, probability {:.3})",
            best.effect, best.delta_bic, best.probability
        );
        steps.push(step);
        named.push(*best_c);
        current = best_fit.clone();
        if named.len() >= opts.max_effects {
            verdict = format!(
                "named: {}; stopped at {} effects",
                named
                    .iter()
                    .map(|&c| lib.candidates[c].effect)
                    .collect::<Vec<_>>()
                    .join(", "),
                opts.max_effects
            );
            warnings.push(verdict.clone());
            break;
        }
    }

    // The final calibration: base corrections composed into the base
    // calibration, the effects as fitted.
    let final_expl = explanation(&lib, &params, &prior, &current, &named);
    let final_params = final_expl.params;
    let mut calibration = base_cal.clone();
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
    let effects = final_expl.effects;
    let mut model = "base-24".to_string();
    for &c in &named {
        model.push('+');
        model.push_str(lib.candidates[c].effect);
        for e in effect_estimates(&lib, &current, c) {
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
    calibration.estimator = "kf, then gap least squares with effect states".into();
    calibration.cross_check = None;
    calibration.dwell_residuals.clear();
    calibration.convergence = Default::default();
    // The filter's check judged the base model; with effects named, the
    // gap after the refit is the check of the model reported here.
    if !named.is_empty() {
        calibration.model_check = None;
    }

    // Series.
    let to3 = |v: Vector3<f64>| -> [f64; 3] { v.into() };
    let node_t: Vec<f64> = nodes.t[1..].iter().map(|t| t - t0).collect();
    let res_v = |f: &GapFit| -> Vec<[f64; 3]> {
        f.residual
            .iter()
            .map(|r| to3(r.fixed_rows::<3>(3).into_owned()))
            .collect()
    };
    let dt = 1.0 / run.sample_rate_hz;
    let named_cols = cols_of(&named);
    let ol: Vec<(f64, [f64; 3], [f64; 3])> = nodes
        .series
        .iter()
        .enumerate()
        .map(|(i, (k, v))| {
            let before = v - sig.series_sim[i];
            let mut after = before;
            for (pos, &col) in named_cols.iter().enumerate() {
                after -= sig.series[col][i] * current.theta[pos];
            }
            (*k as f64 * dt, to3(before), to3(after))
        })
        .collect();
    let ol = decimate(&ol, opts.series_points);
    let series = GapSeries {
        t: decimate(&node_t, opts.series_points),
        before: decimate(&res_v(&first_fit), opts.series_points),
        after: decimate(&res_v(&current), opts.series_points),
        open_loop_t: ol.iter().map(|x| x.0).collect(),
        open_loop_before: ol.iter().map(|x| x.1).collect(),
        open_loop_after: ol.iter().map(|x| x.2).collect(),
    };

    // What the run could see, against the last step's dispersion: from
    // one fit carrying every effect column, their joint information. A
    // failure there costs the thresholds, not the diagnosis.
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
    let detectable = match problem.fit(&(0..lib.n).collect::<Vec<_>>()) {
        Ok(all) => {
            let visibility = detect::Visibility::from_covariance(
                &all.theta_cov,
                dispersion,
                current.n_obs() as f64,
            );
            (0..lib.candidates.len())
                .flat_map(|c| {
                    detect::thresholds(&columns, c, &named, &visibility, opts.bic_threshold)
                })
                .collect()
        }
        Err(e) => {
            warnings.push(format!("no detection thresholds: {e}"));
            Vec::new()
        }
    };
    let floor = first_fit.noise_floor_rms();
    let excess = |rms: f64| (rms * rms - floor * floor).max(0.0).sqrt();
    stage(progress, 1.0, "done");
    Ok(DiagnoseReport {
        named: named
            .iter()
            .map(|&c| lib.candidates[c].effect.to_string())
            .collect(),
        named_candidates: named
            .iter()
            .map(|&c| lib.candidates[c].name.to_string())
            .collect(),
        verdict,
        gap_rms_before: first_fit.gap_rms(),
        gap_rms_after: current.gap_rms(),
        noise_floor_rms: floor,
        gap_excess_before: excess(first_fit.gap_rms()),
        gap_excess_after: excess(current.gap_rms()),
        z_before: first_fit.z(),
        z_after: current.z(),
        detectable,
        segments_before: segment_gaps(&first_fit, &nodes, &kinds, t0),
        segments_after: segment_gaps(&current, &nodes, &kinds, t0),
        calibration,
        effects,
        base_calibration: base_cal,
        scheme: recon,
        steps,
        series,
        warnings,
    })
}

/// The candidates' names, in library order.
pub fn candidate_names() -> Vec<&'static str> {
    Library::new().candidates.iter().map(|c| c.name).collect()
}
