//! What `sinscal diagnose` reports: the steps of the selection with their
//! scores and where the gap lives, the gaps per segment, the series, the
//! final calibration, and the report's readable summary.

use serde::{Deserialize, Serialize};

use super::detect::{self, DetectionThreshold};
use super::reconstruct::Reconstruction;
use super::separate::SeparatingTurn;
use super::verdict::Verdict;
use crate::calib::CalibrationResult;
use crate::model::Effects;

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
    pub separating_turns: Vec<SeparatingTurn>,
    pub decision: String,
}

/// Gap time series: node residuals (m/s) before and after, and the open-
/// loop velocity at 1 Hz (decimated), which at rest is the gap.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GapSeries {
    /// Node times from the run's start, s.
    pub t: Vec<f64>,
    pub before: Vec<[f64; 3]>,
    pub after: Vec<[f64; 3]>,
    pub open_loop_t: Vec<f64>,
    /// Navigated from the base calibration.
    pub open_loop_before: Vec<[f64; 3]>,
    /// The same less the named effects' contribution.
    pub open_loop_after: Vec<[f64; 3]>,
}

/// What `sinscal diagnose` produces.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagnoseReport {
    /// Effects added, in order (SPEC §3 names).
    pub named: Vec<String>,
    /// The parameterisation of each (candidate names, same order).
    pub named_candidates: Vec<String>,
    /// What the workflow concluded; serialised as its sentence ("named:
    /// …", "no significant effect", "unexplained: no candidate fits" or
    /// "ambiguous: …").
    pub verdict: Verdict,
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
    pub detectable: Vec<DetectionThreshold>,
    /// The final calibration (SPEC §5 result with the effect parameters).
    pub calibration: CalibrationResult,
    /// The named effects in SPEC §3 JSON form.
    pub effects: Effects,
    /// The base-model calibration the workflow started from.
    pub base_calibration: CalibrationResult,
    /// The run's turns described as a scheme, when they can be (turns
    /// about body or navigation axes); the diagnosis itself does not
    /// need it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scheme: Option<Reconstruction>,
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
        if let Some(scheme) = &self.scheme {
            let _ = writeln!(
                o,
                "reconstructed scheme: {} rotations",
                scheme.rotations.len()
            );
        }
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
