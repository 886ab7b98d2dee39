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

use super::check_statistics::judge;
use super::error::CalibError;
use super::result::DwellResidual;
use super::segment::{RunSegment, SegmentKind};
use crate::estimation::filter::Innovation;

use super::misfit::NAV_AXES;
pub use super::misfit::{Misfit, ModelCheck, NavAxis, Shape, FALSE_ALARM_RATE};
pub use crate::estimation::quantile;

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
    ) -> Result<(), CalibError> {
        let Some(Some(d)) = self.dwells.get_mut(segment) else {
            return Ok(());
        };
        // S = L Lᵀ; L⁻¹ whitens (a positive definite S has an invertible L).
        let l_inv: Matrix3<f64> = Cholesky::new(innov.s)
            .and_then(|c| c.l().try_inverse())
            .ok_or_else(|| {
                CalibError::Numerical("innovation covariance is not positive definite".into())
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
