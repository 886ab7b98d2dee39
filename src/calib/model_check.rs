//! The model check: does the 24-parameter model explain the run?
//!
//! A Kalman filter whose model is right turns its measurements into
//! innovations that are white with the covariance it predicts. Here the
//! two-stage filter's bias-free innovation less the parameter part,
//! ȳ_k − M_k p, is white with covariance S_k (the bias-free filter's) for
//! the true parameters p; with the final estimate p̂ in place of p the
//! fit removes 24 of many thousand degrees of freedom, which only makes
//! the test below a little conservative. Whitened by the Cholesky factor
//! of S_k, each zero-velocity window gives three independent N(0, 1)
//! draws under a right model, whatever the dwell, the axis or the time.
//!
//! What an unmodelled effect leaves is not white noise but shapes: a
//! velocity step across a turn (lever arms, a channel delay, an
//! asymmetric scale factor), a velocity drift at rest that the constant
//! parameters cannot give in that attitude (g-sensitivity, a bias that
//! changes), a drift that changes within a dwell or over the run. So the
//! residuals of every dwell are projected, per navigation axis, on four
//! orthonormalised shapes: the first window after the turn that led into
//! the dwell (the step), the dwell's mean (the drift at rest), and its
//! Legendre slope and curvature in time. Under a right model these are
//! independent N(0, 1) scores. Two tests share the false-alarm rate:
//! Σ z² against its χ² quantile (many small misfits, e.g. a drift seen in
//! every dwell), and the largest |z| against its Bonferroni bound (one
//! large misfit, e.g. one turn). A third family, the drift's trend over
//! the run per axis, says whether the misfit grows with time.
//!
//! The noise densities are the ones the filter ran with (measured from
//! the run's dwells unless given), so "what the noise explains" is the
//! run's own noise.

use nalgebra::{Cholesky, DMatrix, DVector, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::filter::Innovation;
use super::result::DwellResidual;
use super::segment::{RunSegment, SegmentKind};

/// Total false-alarm rate of the check on a run the model explains.
pub const FALSE_ALARM_RATE: f64 = 1e-3;

/// Fewest zero-velocity windows in a dwell for its shapes to be tested.
const MIN_WINDOWS: usize = 8;

/// The shapes a dwell's residuals are tested for, in the order they are
/// orthonormalised (each is what is left after the ones before).
const SHAPES: [Shape; 4] = [
    Shape::TurnStep,
    Shape::Drift,
    Shape::DriftChange,
    Shape::Curvature,
];

/// A shape of misfit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// A velocity step across the turn before the dwell: the misfit
    /// arose in motion.
    TurnStep,
    /// A constant velocity drift at rest in the dwell.
    Drift,
    /// A drift that grows or shrinks across the dwell.
    DriftChange,
    /// A drift that bends across the dwell.
    Curvature,
    /// The dwells' drifts growing over the run.
    TrendOverRun,
}

impl Shape {
    fn words(self) -> &'static str {
        match self {
            Shape::TurnStep => "velocity step across the turn (in motion)",
            Shape::Drift => "velocity drift at rest",
            Shape::DriftChange => "drift changing within the dwell",
            Shape::Curvature => "drift bending within the dwell",
            Shape::TrendOverRun => "drift growing over the run",
        }
    }
}

/// A navigation-frame axis (the zero-velocity residuals are in n).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NavAxis {
    E,
    N,
    U,
}

const NAV_AXES: [NavAxis; 3] = [NavAxis::E, NavAxis::N, NavAxis::U];

impl NavAxis {
    fn name(self) -> &'static str {
        match self {
            NavAxis::E => "east",
            NavAxis::N => "north",
            NavAxis::U => "up",
        }
    }
}

/// One score beyond the bound: where the model fails.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Misfit {
    pub shape: Shape,
    /// 1-based dwell number (the dwell the turn led into, for a step);
    /// absent for a trend over the run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dwell: Option<usize>,
    /// The stretch of the run, s.
    pub t_start: f64,
    pub t_end: f64,
    pub axis: NavAxis,
    /// The score: N(0, 1) under a model that explains the run.
    pub z: f64,
    /// The misfit in physical units where it has one: m/s for a step,
    /// m/s² for a drift.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
}

/// The verdict on one run (SPEC §5 `model_check`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelCheck {
    pub adequate: bool,
    /// Σ z² over every dwell shape and axis.
    pub statistic: f64,
    /// Its χ² quantile at half the false-alarm rate.
    pub threshold: f64,
    /// Number of scores in `statistic`.
    pub dof: usize,
    /// Largest |z| over the scores and the trends over the run.
    pub largest_z: f64,
    /// Its Bonferroni bound at half the false-alarm rate.
    pub largest_z_threshold: f64,
    pub false_alarm_rate: f64,
    pub method: String,
    /// The verdict and where the misfit lies, in words.
    pub summary: String,
    /// Every score beyond the bound, largest first (at most 20), or the
    /// largest few when only the χ² test fails.
    pub findings: Vec<Misfit>,
}

/// Sums over one dwell's whitened zero-velocity residuals, projected on
/// the shapes; the final estimate is applied at the end.
struct DwellSums {
    /// 1-based dwell number.
    dwell: usize,
    t_start: f64,
    t_end: f64,
    /// Whether a turn led into the dwell (the first dwell has none).
    after_turn: bool,
    windows: usize,
    /// Σ φ φᵀ over the windows.
    gram: DMatrix<f64>,
    /// Σ φ_j ỹ_i: row j·3 + i.
    y: DVector<f64>,
    /// Σ φ_j M̃_i: row j·3 + i.
    m: DMatrix<f64>,
    /// The first window's raw residual, for the step's size in m/s.
    first_y: Vector3<f64>,
    first_m: DMatrix<f64>,
}

/// Collects a pass's zero-velocity innovations for the check.
pub struct CheckAccumulator {
    /// Indexed by segment; `None` for motions.
    dwells: Vec<Option<DwellSums>>,
}

impl CheckAccumulator {
    pub fn new(segments: &[RunSegment], n_params: usize) -> Self {
        let mut number = 0;
        let dwells = segments
            .iter()
            .enumerate()
            .map(|(i, s)| {
                (s.kind == SegmentKind::Dwell).then(|| {
                    number += 1;
                    let k = SHAPES.len();
                    DwellSums {
                        dwell: number,
                        t_start: s.t_start,
                        t_end: s.t_end,
                        after_turn: i > 0,
                        windows: 0,
                        gram: DMatrix::zeros(k, k),
                        y: DVector::zeros(3 * k),
                        m: DMatrix::zeros(3 * k, n_params),
                        first_y: Vector3::zeros(),
                        first_m: DMatrix::zeros(3, n_params),
                    }
                })
            })
            .collect();
        CheckAccumulator { dwells }
    }

    /// Adds the innovation of a zero-velocity window inside segment
    /// `segment`, `t_mid` the window's middle.
    pub fn add(
        &mut self,
        segment: usize,
        t_mid: f64,
        innov: &Innovation,
    ) -> Result<(), super::CalibError> {
        let Some(Some(d)) = self.dwells.get_mut(segment) else {
            return Ok(());
        };
        // S = L Lᵀ; L⁻¹ whitens (a positive definite S has an invertible L).
        let l_inv: Matrix3<f64> = Cholesky::new(innov.s)
            .and_then(|c| c.l().try_inverse())
            .ok_or_else(|| {
                super::CalibError::Numerical(
                    "innovation covariance is not positive definite".into(),
                )
            })?;
        let y_w = l_inv * innov.y_bar;
        let l_inv_d = DMatrix::from_column_slice(3, 3, l_inv.as_slice());
        let m_w = &l_inv_d * &innov.m;
        let span = (d.t_end - d.t_start).max(f64::EPSILON);
        let u = (2.0 * (t_mid - d.t_start) / span - 1.0).clamp(-1.0, 1.0);
        let first = d.windows == 0;
        let phi = [
            if first && d.after_turn { 1.0 } else { 0.0 },
            1.0,
            u,
            0.5 * (3.0 * u * u - 1.0),
        ];
        if first {
            d.first_y = innov.y_bar;
            d.first_m.copy_from(&innov.m);
        }
        d.windows += 1;
        for (j, pj) in phi.iter().enumerate() {
            if *pj == 0.0 {
                continue;
            }
            for (k, pk) in phi.iter().enumerate() {
                d.gram[(j, k)] += pj * pk;
            }
            for i in 0..3 {
                d.y[3 * j + i] += pj * y_w[i];
                for c in 0..m_w.ncols() {
                    d.m[(3 * j + i, c)] += pj * m_w[(i, c)];
                }
            }
        }
        Ok(())
    }

    /// The check for the final estimate `p_scaled` (the filter's scaled
    /// parameter estimate). `residuals` give the drift sizes in m/s².
    pub fn finish(&self, p_scaled: &DVector<f64>, residuals: &[DwellResidual]) -> ModelCheck {
        let mut scores: Vec<Misfit> = Vec::new();
        // Per dwell and axis: the drift's score, for the trend over the run.
        let mut drift_scores: Vec<(f64, Vector3<f64>)> = Vec::new();
        for d in self.dwells.iter().flatten() {
            if d.windows < MIN_WINDOWS {
                continue;
            }
            let active: Vec<usize> = (0..SHAPES.len())
                .filter(|&j| j != 0 || d.after_turn)
                .collect();
            let k = active.len();
            let gram = DMatrix::from_fn(k, k, |a, b| d.gram[(active[a], active[b])]);
            let Some(chol) = Cholesky::new(gram) else {
                continue;
            };
            let post_fit = &d.y - &d.m * p_scaled;
            let drift = residuals.iter().find(|r| r.dwell == d.dwell);
            let mut drift_z = Vector3::zeros();
            for (i, axis) in NAV_AXES.iter().enumerate() {
                let b = DVector::from_fn(k, |a, _| post_fit[3 * active[a] + i]);
                let z = chol
                    .l()
                    .solve_lower_triangular(&b)
                    .unwrap_or_else(|| DVector::zeros(k));
                for (a, &j) in active.iter().enumerate() {
                    let shape = SHAPES[j];
                    // The misfit in physical units, where the shape has one.
                    let physical = match shape {
                        Shape::TurnStep => {
                            Some((d.first_y[i] - (d.first_m.row(i) * p_scaled)[(0, 0)], "m/s"))
                        }
                        Shape::Drift => drift.map(|r| (r.drift_mps2[i], "m/s^2")),
                        _ => None,
                    };
                    if shape == Shape::Drift {
                        drift_z[i] = z[a];
                    }
                    scores.push(Misfit {
                        shape,
                        dwell: Some(d.dwell),
                        t_start: d.t_start,
                        t_end: d.t_end,
                        axis: *axis,
                        z: z[a],
                        size: physical.map(|p| p.0),
                        unit: physical.map(|p| p.1.to_string()),
                    });
                }
            }
            drift_scores.push((0.5 * (d.t_start + d.t_end), drift_z));
        }
        let trends = trend_over_run(&drift_scores);
        judge(scores, trends)
    }
}

/// Per axis, the dwells' drift scores regressed on the dwells' times: a
/// fixed unit-norm combination of independent N(0, 1) scores, so N(0, 1).
fn trend_over_run(drifts: &[(f64, Vector3<f64>)]) -> Vec<Misfit> {
    if drifts.len() < 3 {
        return Vec::new();
    }
    let n = drifts.len() as f64;
    let t_mean = drifts.iter().map(|d| d.0).sum::<f64>() / n;
    let norm = drifts
        .iter()
        .map(|d| (d.0 - t_mean).powi(2))
        .sum::<f64>()
        .sqrt();
    if norm <= 0.0 {
        return Vec::new();
    }
    let (t0, t1) = (drifts[0].0, drifts[drifts.len() - 1].0);
    NAV_AXES
        .iter()
        .enumerate()
        .map(|(i, axis)| Misfit {
            shape: Shape::TrendOverRun,
            dwell: None,
            t_start: t0,
            t_end: t1,
            axis: *axis,
            z: drifts.iter().map(|d| (d.0 - t_mean) / norm * d.1[i]).sum(),
            size: None,
            unit: None,
        })
        .collect()
}

/// The two tests, and the verdict in words.
fn judge(scores: Vec<Misfit>, trends: Vec<Misfit>) -> ModelCheck {
    let dof = scores.len();
    let statistic: f64 = scores.iter().map(|s| s.z * s.z).sum();
    let half = 0.5 * FALSE_ALARM_RATE;
    let threshold = if dof > 0 {
        quantile::chi2_upper(dof as f64, half)
    } else {
        0.0
    };
    let n_max = (dof + trends.len()).max(1);
    let z_bound = quantile::normal_upper(half / n_max as f64 / 2.0);
    let mut all: Vec<Misfit> = scores.into_iter().chain(trends).collect();
    all.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
    let largest_z = all.first().map_or(0.0, |m| m.z.abs());
    let chi2_fails = dof > 0 && statistic > threshold;
    let max_fails = largest_z > z_bound;
    let adequate = !(chi2_fails || max_fails);
    let mut findings: Vec<Misfit> = all
        .iter()
        .filter(|m| m.z.abs() > z_bound)
        .take(20)
        .cloned()
        .collect();
    if !adequate && findings.is_empty() {
        // Only the sum fails: many misfits, none large alone. Name the
        // largest few, which are where it is most.
        findings = all.iter().take(5).cloned().collect();
    }
    let mut check = ModelCheck {
        adequate,
        statistic,
        threshold,
        dof,
        largest_z,
        largest_z_threshold: z_bound,
        false_alarm_rate: FALSE_ALARM_RATE,
        method: "whitened zero-velocity residuals per dwell and navigation axis, projected on \
                 turn step, drift, drift change and curvature; χ² sum and largest |z|, each at \
                 half the false-alarm rate"
            .into(),
        summary: String::new(),
        findings,
    };
    check.summary = summarise(&check, &all);
    check
}

/// The verdict in words: the figures, then the findings grouped by shape;
/// `all` is every score, largest first.
fn summarise(check: &ModelCheck, all: &[Misfit]) -> String {
    use std::fmt::Write;
    let (statistic, threshold, dof) = (check.statistic, check.threshold, check.dof);
    let (largest_z, z_bound) = (check.largest_z, check.largest_z_threshold);
    let findings = &check.findings;
    let mut s = String::new();
    let figures = format!(
        "χ² {statistic:.0} over {dof} scores (threshold {threshold:.0}); largest |z| \
         {largest_z:.1} (threshold {z_bound:.1})"
    );
    if check.adequate {
        let _ = write!(
            s,
            "adequate: the residuals are what the run's noise explains ({figures})"
        );
        return s;
    }
    let _ = write!(
        s,
        "inadequate: the 24-parameter model does not explain this run ({figures})."
    );
    // Group the misfits beyond the bound (or the few named) by shape.
    let shapes = [
        Shape::TurnStep,
        Shape::Drift,
        Shape::DriftChange,
        Shape::Curvature,
        Shape::TrendOverRun,
    ];
    for shape in shapes {
        let of: Vec<&Misfit> = findings.iter().filter(|m| m.shape == shape).collect();
        let Some(top) = of.first() else { continue };
        let mut axes: Vec<&str> = Vec::new();
        for m in &of {
            if !axes.contains(&m.axis.name()) {
                axes.push(m.axis.name());
            }
        }
        let _ = write!(s, " {}: ", shape.words());
        if shape == Shape::TrendOverRun {
            let _ = write!(s, "{} (z {:.1})", axes.join(", "), top.z);
        } else {
            let mut dwells: Vec<usize> = of.iter().filter_map(|m| m.dwell).collect();
            dwells.sort_unstable();
            dwells.dedup();
            let which = if shape == Shape::TurnStep {
                "turns into dwells"
            } else {
                "dwells"
            };
            let _ = write!(
                s,
                "{which} {} on {}; largest in dwell {} ({:.0}–{:.0} s), {}, z {:.1}",
                list(&dwells),
                axes.join(", "),
                top.dwell.unwrap_or(0),
                top.t_start,
                top.t_end,
                top.axis.name(),
                top.z
            );
            if let (Some(size), Some(unit)) = (top.size, top.unit.as_deref()) {
                let _ = write!(s, ", {size:.2e} {unit}");
            }
        }
        s.push('.');
    }
    // Growing with time or not, from the trend scores whether or not they
    // passed the bound.
    let trend = all
        .iter()
        .filter(|m| m.shape == Shape::TrendOverRun)
        .map(|m| m.z.abs())
        .fold(0.0, f64::max);
    if trend > z_bound {
        let _ = write!(
            s,
            " The misfit grows with time over the run (trend z {trend:.1})."
        );
    } else {
        let _ = write!(s, " It does not grow with time over the run.");
    }
    s.push_str(" To name the missing effect, run `sinscal diagnose`.");
    s
}

/// "3, 5, 7–9".
fn list(v: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1] == v[j] + 1 {
            j += 1;
        }
        parts.push(if j > i + 1 {
            format!("{}–{}", v[i], v[j])
        } else if j == i + 1 {
            format!("{}, {}", v[i], v[j])
        } else {
            v[i].to_string()
        });
        i = j + 1;
    }
    parts.join(", ")
}

/// Upper quantiles of the normal and χ² distributions.
pub mod quantile {
    /// z with P(Z > z) = p for a standard normal Z, 0 < p < 1 (Acklam's
    /// rational approximation, relative error below 1.2e-9).
    pub fn normal_upper(p: f64) -> f64 {
        -normal_lower(p)
    }

    /// z with P(Z < z) = p.
    pub fn normal_lower(p: f64) -> f64 {
        const A: [f64; 6] = [
            -3.969683028665376e1,
            2.209460984245205e2,
            -2.759285104469687e2,
            1.383_577_518_672_69e2,
            -3.066479806614716e1,
            2.506628277459239,
        ];
        const B: [f64; 5] = [
            -5.447609879822406e1,
            1.615858368580409e2,
            -1.556989798598866e2,
            6.680131188771972e1,
            -1.328068155288572e1,
        ];
        const C: [f64; 6] = [
            -7.784894002430293e-3,
            -3.223964580411365e-1,
            -2.400758277161838,
            -2.549732539343734,
            4.374664141464968,
            2.938163982698783,
        ];
        const D: [f64; 4] = [
            7.784695709041462e-3,
            3.224671290700398e-1,
            2.445134137142996,
            3.754408661907416,
        ];
        let p = p.clamp(1e-300, 1.0 - 1e-16);
        let tail = |q: f64| {
            (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
                / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
        };
        if p < 0.02425 {
            tail((-2.0 * p.ln()).sqrt())
        } else if p > 1.0 - 0.02425 {
            -tail((-2.0 * (1.0 - p).ln()).sqrt())
        } else {
            let q = p - 0.5;
            let r = q * q;
            (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
                / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
        }
    }

    /// x with P(χ²_k > x) = p (Wilson–Hilferty: within 1 % of the exact
    /// quantile for k ≥ 10 at the tails used here).
    pub fn chi2_upper(k: f64, p: f64) -> f64 {
        let z = normal_upper(p);
        let h = 2.0 / (9.0 * k);
        k * (1.0 - h + z * h.sqrt()).powi(3)
    }
}

#[cfg(test)]
mod tests {
    use super::quantile::*;
    use super::*;

    #[test]
    fn quantiles_match_tabulated_values() {
        // Standard tables: z_{0.975} = 1.959964, z_{0.9995} = 3.290527,
        // z at 1e-6 upper = 4.753424.
        assert!((normal_upper(0.025) - 1.959964).abs() < 1e-5);
        assert!((normal_upper(0.0005) - 3.290527).abs() < 1e-5);
        assert!((normal_upper(1e-6) - 4.753424).abs() < 1e-5);
        assert!((normal_lower(0.5)).abs() < 1e-12);
        // χ² upper 0.001 quantiles: k = 100 → 149.449, k = 200 → 267.541.
        assert!((chi2_upper(100.0, 1e-3) / 149.449 - 1.0).abs() < 0.005);
        assert!((chi2_upper(200.0, 1e-3) / 267.541 - 1.0).abs() < 0.005);
    }

    #[test]
    fn ranges_are_listed_compactly() {
        assert_eq!(list(&[1, 2, 3, 5, 7, 8]), "1–3, 5, 7, 8");
        assert_eq!(list(&[4]), "4");
    }

    fn misfit(shape: Shape, dwell: usize, z: f64) -> Misfit {
        Misfit {
            shape,
            dwell: Some(dwell),
            t_start: 100.0 * dwell as f64,
            t_end: 100.0 * dwell as f64 + 90.0,
            axis: NavAxis::N,
            z,
            size: None,
            unit: None,
        }
    }

    #[test]
    fn scores_of_the_noise_pass_and_a_large_step_fails() {
        // 40 scores at ±1: χ² 40, nothing large.
        let noise: Vec<Misfit> = (0..40)
            .map(|i| misfit(Shape::Drift, i + 1, if i % 2 == 0 { 1.0 } else { -1.0 }))
            .collect();
        assert!(judge(noise.clone(), Vec::new()).adequate);
        let mut one = noise;
        one.push(misfit(Shape::TurnStep, 7, 9.0));
        let check = judge(one, Vec::new());
        assert!(!check.adequate);
        assert_eq!(check.findings[0].shape, Shape::TurnStep);
        assert!(check.summary.contains("turn"), "{}", check.summary);
        assert!(check.summary.contains("sinscal diagnose"));
    }

    #[test]
    fn many_moderate_scores_fail_the_sum_alone() {
        // 100 scores at 2.5: none beyond the Bonferroni bound (≈ 4.4), but
        // χ² = 625 ≫ 149.
        let v: Vec<Misfit> = (0..100).map(|i| misfit(Shape::Drift, i + 1, 2.5)).collect();
        let check = judge(v, Vec::new());
        assert!(!check.adequate);
        assert!(check.largest_z < check.largest_z_threshold);
        assert_eq!(check.findings.len(), 5);
    }
}
