//! The noise terms from an Allan variance curve.
//!
//! The model (IEEE Std 952 Annex C, IEEE Std 1293 Annex J) is the sum of
//! independent processes, each with its own slope:
//!
//! ```text
//! σ²(τ) = 3Q²/τ² + N²/τ + (2 ln 2/π) B² + K² τ/3
//! ```
//!
//! Q quantization, N the white-rate density (ARW, VRW), B the flicker
//! floor ("bias instability": the flat part of the Allan deviation is
//! √(2 ln 2/π)·B ≈ 0.664·B), K the random-walk rate (RRW). The model is
//! linear in (Q², N², B², K²), all of which are non-negative, so the fit
//! is a non-negative least squares on σ² itself rather than on
//! straight-line pieces of log σ drawn by eye: every τ is used, each
//! term is read where it dominates, and nothing depends on choosing the
//! τ at which to read it.
//!
//! Weights. σ̂²(τ) ~ σ² χ²_ν/ν, so its variance is 2σ⁴/ν with ν the
//! equivalent degrees of freedom at that τ, which depend on the kind of
//! noise there ([`super::edf`]). Both σ² and the kind come from the
//! model, so the fit is iteratively reweighted: weights from the data and
//! white-rate ν first, then from the fitted model (its σ², and ν mixed by
//! each term's share) until the coefficients settle. Weighting by the
//! model rather than by σ̂² keeps points that happen to fall low from
//! pulling the fit down. Adjacent τ share data, so the weights rank the
//! points' trust but do not make a χ² test.
//!
//! Quantization is fitted so that a real ring-laser gyro's output, whose
//! angle quantization dominates the shortest τ, does not inflate the ARW.

use nalgebra::{DMatrix, DVector};

use super::edf::edf_mixed;

/// 2 ln 2 / π: the flicker floor of the Allan variance per B².
pub const FLICKER_FLOOR: f64 = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;

/// Reweighting rounds at most; the coefficients settle in three to five.
const MAX_ROUNDS: usize = 20;

/// One point of the curve for the fit.
#[derive(Clone, Debug)]
pub struct CurvePoint {
    pub tau_s: f64,
    /// σ̂², SI rate units squared.
    pub avar: f64,
    /// ν of this point for each kind, in [`super::edf::NoiseKind::ALL`] order.
    pub edf: [f64; 4],
}

/// The fitted terms, SI: Q (rad or m/s), N (per √s), B (rad/s or m/s²),
/// K (per s^1.5).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoiseTerms {
    pub quantization: f64,
    pub white: f64,
    pub flicker: f64,
    pub random_walk: f64,
}

impl NoiseTerms {
    /// The model's Allan deviation at τ, SI (the fitted curve a plot
    /// draws over the measured one).
    pub fn allan_deviation(&self, tau_s: f64) -> f64 {
        let (q, n, b, k) = (
            self.quantization,
            self.white,
            self.flicker,
            self.random_walk,
        );
        (3.0 * q * q / (tau_s * tau_s)
            + n * n / tau_s
            + FLICKER_FLOOR * b * b
            + k * k * tau_s / 3.0)
            .sqrt()
    }
}

/// A fit and how well the model follows the curve.
#[derive(Clone, Debug)]
pub struct TermFit {
    pub terms: NoiseTerms,
    /// ν per point under the fitted model's mix of kinds.
    pub edf: Vec<f64>,
    /// RMS over the points of (σ̂² − model) / sd(σ̂²): near 1 or below
    /// when the model explains the curve (below, because adjacent points
    /// share data), far above when it does not (a periodic or drifting
    /// signal, a dwell with motion in it).
    pub rms_z: f64,
}

/// The shape of each term in σ²(τ), per unit of its squared coefficient.
fn shapes(tau: f64) -> [f64; 4] {
    [3.0 / (tau * tau), 1.0 / tau, FLICKER_FLOOR, tau / 3.0]
}

/// Fits the four terms to `points` (at least one).
pub fn fit_terms(points: &[CurvePoint]) -> TermFit {
    let avar: Vec<f64> = points.iter().map(|p| p.avar).collect();
    // Start: the data's own σ² and white-rate ν.
    let mut variance: Vec<f64> = points
        .iter()
        .map(|p| 2.0 * p.avar.powi(2) / p.edf[1].max(1.0))
        .collect();
    let mut coef = [0.0; 4];
    let mut edf: Vec<f64> = points.iter().map(|p| p.edf[1]).collect();
    for _ in 0..MAX_ROUNDS {
        let weights: Vec<f64> = variance
            .iter()
            .map(|v| if *v > 0.0 { 1.0 / v } else { 0.0 })
            .collect();
        let next = nnls(points, &avar, &weights);
        let settled = next
            .iter()
            .zip(&coef)
            .all(|(a, b)| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()));
        coef = next;
        for (k, p) in points.iter().enumerate() {
            let parts: Vec<f64> = shapes(p.tau_s)
                .iter()
                .zip(&coef)
                .map(|(g, c)| g * c)
                .collect();
            let model: f64 = parts.iter().sum();
            if model > 0.0 {
                let shares: Vec<f64> = parts.iter().map(|x| x / model).collect();
                edf[k] = edf_mixed(&shares, &p.edf);
                variance[k] = 2.0 * model * model / edf[k];
            }
        }
        if settled {
            break;
        }
    }
    let mut z2 = 0.0;
    for (k, p) in points.iter().enumerate() {
        let model: f64 = shapes(p.tau_s).iter().zip(&coef).map(|(g, c)| g * c).sum();
        if variance[k] > 0.0 {
            z2 += (p.avar - model).powi(2) / variance[k];
        }
    }
    TermFit {
        terms: NoiseTerms {
            quantization: coef[0].sqrt(),
            white: coef[1].sqrt(),
            flicker: coef[2].sqrt(),
            random_walk: coef[3].sqrt(),
        },
        edf,
        rms_z: (z2 / points.len().max(1) as f64).sqrt(),
    }
}

/// Weighted least squares of `avar` on the four shapes with every
/// coefficient ≥ 0. With four columns the exact answer is found by trying
/// every set of free columns (15): the constrained optimum is the
/// unconstrained optimum over its own positive columns, so the best
/// feasible subset fit is it.
fn nnls(points: &[CurvePoint], avar: &[f64], weights: &[f64]) -> [f64; 4] {
    let rows = points.len();
    let mut best = ([0.0; 4], f64::INFINITY);
    for set in 1u32..16 {
        let cols: Vec<usize> = (0..4).filter(|i| set & (1 << i) != 0).collect();
        let mut a = DMatrix::<f64>::zeros(rows, cols.len());
        let mut b = DVector::<f64>::zeros(rows);
        for (k, p) in points.iter().enumerate() {
            let w = weights[k].sqrt();
            let g = shapes(p.tau_s);
            for (j, &i) in cols.iter().enumerate() {
                a[(k, j)] = w * g[i];
            }
            b[k] = w * avar[k];
        }
        // Columns scaled to unit norm: their sizes differ by the τ range
        // to the fourth power.
        let norms: Vec<f64> = (0..cols.len()).map(|j| a.column(j).norm()).collect();
        if norms.iter().any(|n| !n.is_finite() || *n <= 0.0) {
            continue;
        }
        for (j, n) in norms.iter().enumerate() {
            a.column_mut(j).scale_mut(1.0 / n);
        }
        let Ok(x) = a.clone().svd(true, true).solve(&b, 1e-12) else {
            continue;
        };
        let coef: Vec<f64> = x.iter().zip(&norms).map(|(x, n)| x / n).collect();
        if coef.iter().any(|c| *c < 0.0) {
            continue;
        }
        let ssr = (&a * &x - &b).norm_squared();
        if ssr < best.1 {
            let mut full = [0.0; 4];
            for (j, &i) in cols.iter().enumerate() {
                full[i] = coef[j];
            }
            best = (full, ssr);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An exact curve of known terms (no estimation noise) is fitted back
    /// to them, and a term that is absent stays zero.
    #[test]
    fn an_exact_curve_gives_back_its_terms() {
        let truth = [2e-6_f64, 3e-4, 5e-5, 0.0];
        let points: Vec<CurvePoint> = (0..40)
            .map(|i| {
                let tau_s = 0.01 * 10f64.powf(i as f64 / 10.0);
                let avar = shapes(tau_s)
                    .iter()
                    .zip(&truth)
                    .map(|(g, c)| g * c * c)
                    .sum();
                CurvePoint {
                    tau_s,
                    avar,
                    edf: [100.0; 4],
                }
            })
            .collect();
        let fit = fit_terms(&points);
        let t = fit.terms;
        for (got, want) in [t.quantization, t.white, t.flicker].iter().zip(&truth) {
            assert!((got - want).abs() <= 1e-6 * want, "{t:?}");
        }
        // The absent term adds nothing visible even at the longest τ.
        let last = points.last().unwrap();
        assert!(
            t.random_walk.powi(2) * last.tau_s / 3.0 < 1e-9 * last.avar,
            "{t:?}"
        );
        assert!(fit.rms_z < 1e-6);
    }
}
