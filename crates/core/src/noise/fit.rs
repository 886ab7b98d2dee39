//! The noise terms from an Allan variance curve, each with a σ or a bound.
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
//! is a non-negative least squares on σ² itself: every τ is used, each
//! term is read where it dominates, and nothing depends on choosing the τ
//! at which to read it. A quantum found in the data (`quantum`) fixes
//! Q = q/√12 instead of fitting it, so white noise is not confused with
//! the pulses.
//!
//! Weights. σ̂²(τ) ~ σ² χ²_ν/ν, so its variance is 2σ⁴/ν with ν the
//! equivalent degrees of freedom at that τ, which depend on the kind of
//! noise there ([`super::edf`]). Both σ² and the kind come from the
//! model, so the fit is iteratively reweighted until the coefficients
//! settle. Weighting by the model rather than by σ̂² keeps points that
//! happen to fall low from pulling the fit down.
//!
//! σ and bounds. Adjacent points share data, so the weights rank the
//! points but do not give the coefficients' errors. Those come from the
//! whole covariance of the curve under the fitted model
//! ([`super::covariance`]) carried through the weighted fit, which is
//! linear in the data: Cov(p̂) = H C Hᵀ, H = (AᵀWA)⁻¹AᵀW. A term is
//! resolved when its power p = coefficient² is at least [`RESOLVED_SIGMAS`]
//! of its σ; the least significant of the others is dropped and the rest
//! fitted again until every term left is. A term not resolved gets a
//! one-sided 95 % upper bound: the fit of the resolved terms plus that one
//! gives p̂ + 1.645 σ, and no term can exceed the curve itself at the 97.5 %
//! point of any τ's χ² interval; the bound is the smaller of the two.

use nalgebra::{DMatrix, DVector};

use super::covariance::CurveCovariance;
use super::edf::edf_mixed;

/// 2 ln 2 / π: the flicker floor of the Allan variance per B².
pub const FLICKER_FLOOR: f64 = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;

/// A term's power must be this many of its σ to be read as a value.
pub const RESOLVED_SIGMAS: f64 = 3.0;

/// One-sided 95 % normal quantile: the statistical bound of a term not
/// resolved.
const BOUND_SIGMAS: f64 = 1.645;

/// Reweighting rounds at most; the coefficients settle in three to five.
const MAX_ROUNDS: usize = 20;

/// One point of the curve for the fit.
#[derive(Clone, Debug)]
pub struct CurvePoint {
    pub tau_s: f64,
    /// Records per cluster.
    pub cluster_records: usize,
    /// σ̂², SI rate units squared.
    pub avar: f64,
    /// ν of this point for each kind, in [`super::edf::NoiseKind::ALL`] order.
    pub edf: [f64; 4],
}

/// The terms, SI: Q (rad or m/s), N (per √s), B (rad/s or m/s²),
/// K (per s^1.5).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoiseTerms {
    pub quantization: f64,
    pub white: f64,
    pub flicker: f64,
    pub random_walk: f64,
}

impl NoiseTerms {
    /// The model's Allan variance at τ, SI.
    pub fn allan_variance(&self, tau_s: f64) -> f64 {
        shapes(tau_s)
            .iter()
            .zip(self.powers())
            .map(|(g, p)| g * p)
            .sum()
    }

    /// The model's Allan deviation at τ, SI (the fitted curve a plot
    /// draws over the measured one).
    pub fn allan_deviation(&self, tau_s: f64) -> f64 {
        self.allan_variance(tau_s).sqrt()
    }

    /// (Q², N², B², K²).
    pub fn powers(&self) -> [f64; 4] {
        [
            self.quantization,
            self.white,
            self.flicker,
            self.random_walk,
        ]
        .map(|c| c * c)
    }

    fn from_powers(p: [f64; 4]) -> Self {
        let a = p.map(|x| x.max(0.0).sqrt());
        NoiseTerms {
            quantization: a[0],
            white: a[1],
            flicker: a[2],
            random_walk: a[3],
        }
    }
}

/// What the curve says of one term (SI amplitude).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Estimate {
    /// Read from the curve, with its 1-σ.
    Resolved { value: f64, sigma: f64 },
    /// Not resolved: below `upper` (one-sided 95 %).
    Bound { upper: f64 },
    /// Held at a value known from elsewhere (Q from a detected quantum).
    Fixed { value: f64 },
}

/// A fit and how well the model follows the curve.
#[derive(Clone, Debug)]
pub struct TermFit {
    /// The model in force: resolved and fixed terms, 0 for bounds.
    pub terms: NoiseTerms,
    /// Q, N, B, K.
    pub estimates: [Estimate; 4],
    /// ν per point under the fitted model's mix of kinds.
    pub edf: Vec<f64>,
    /// RMS over the points used of (σ̂² − model) / sd(σ̂²): near 1 or below
    /// when the model explains the curve (below, because adjacent points
    /// share data), far above when it does not.
    pub rms_z: f64,
}

/// What the fit takes besides the points.
#[derive(Clone, Copy, Debug)]
pub struct FitInput<'a> {
    /// The covariance of the curve's points (the same cluster sizes).
    pub covariance: &'a CurveCovariance,
    /// Q known from a detected quantum (q/√12), SI.
    pub fixed_quantization: Option<f64>,
    /// Points the fit uses (the others depart from the model); all when
    /// `None`.
    pub used: Option<&'a [bool]>,
    /// The weight of a point above the model relative to one below: 1 for
    /// a fit, small for the curve's lower envelope (disturbances only
    /// add, so the sensor's own noise lies at or below every point).
    pub above_weight: f64,
}

/// The shape of each term in σ²(τ), per unit of its squared coefficient.
pub fn shapes(tau: f64) -> [f64; 4] {
    [3.0 / (tau * tau), 1.0 / tau, FLICKER_FLOOR, tau / 3.0]
}

/// Fits the terms to `points` (at least one used).
pub fn fit_terms(points: &[CurvePoint], input: &FitInput) -> TermFit {
    let used: Vec<bool> = match input.used {
        Some(u) => u.to_vec(),
        None => vec![true; points.len()],
    };
    let mut fixed = [0.0; 4];
    let mut free = [true; 4];
    if let Some(q) = input.fixed_quantization {
        fixed[0] = q * q;
        free[0] = false;
    }
    let curve = Curve {
        points,
        used: &used,
        fixed,
        above_weight: input.above_weight,
    };
    let (fit, weights) = loop {
        let fit = curve.reweighted(free);
        let active: [bool; 4] = std::array::from_fn(|k| free[k] && fit.coef[k] > 0.0);
        if active != free {
            free = active;
            continue;
        }
        let cov = curve.parameter_covariance(&fit, free, input.covariance);
        let weakest = (0..4)
            .filter(|&k| free[k])
            .map(|k| (k, fit.coef[k] / cov[k].sqrt()))
            .filter(|(_, z)| z.is_nan() || *z < RESOLVED_SIGMAS)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match weakest {
            Some((k, _)) => free[k] = false,
            None => break (fit.clone(), fit.weights.clone()),
        }
    };
    let model = NoiseTerms::from_powers(std::array::from_fn(|k| fixed[k] + fit.coef[k]));
    let cov_here = curve.parameter_covariance(&fit, free, input.covariance);
    let estimates: [Estimate; 4] = std::array::from_fn(|k| {
        if input.fixed_quantization.is_some() && k == 0 {
            Estimate::Fixed {
                value: fixed[0].sqrt(),
            }
        } else if free[k] {
            let value = fit.coef[k].sqrt();
            Estimate::Resolved {
                value,
                sigma: cov_here[k].sqrt() / (2.0 * value),
            }
        } else {
            Estimate::Bound {
                upper: curve.bound(k, free, (&fit.target, &weights), &model, input.covariance),
            }
        }
    });
    TermFit {
        terms: model,
        estimates,
        rms_z: curve.rms_z(&fit),
        edf: fit.edf,
    }
}

/// No band of the curve follows the model: every term not held is bounded
/// by the curve itself (no term can exceed it at the 97.5 % point of any
/// τ's χ² interval), and the model in force is the held terms alone.
pub fn bounds_only(points: &[CurvePoint], fixed_quantization: Option<f64>) -> TermFit {
    let estimates = std::array::from_fn(|k| match (k, fixed_quantization) {
        (0, Some(value)) => Estimate::Fixed { value },
        _ => Estimate::Bound {
            upper: ceiling(points, None, k).max(0.0).sqrt(),
        },
    });
    TermFit {
        terms: NoiseTerms {
            quantization: fixed_quantization.unwrap_or(0.0),
            ..NoiseTerms::default()
        },
        estimates,
        edf: points.iter().map(|p| p.edf[1]).collect(),
        rms_z: f64::NAN,
    }
}

/// The largest power of term k no point of the curve (of those `used`)
/// rules out at its 97.5 % point.
fn ceiling(points: &[CurvePoint], used: Option<&[bool]>, k: usize) -> f64 {
    points
        .iter()
        .enumerate()
        .filter(|(i, _)| used.map_or(true, |u| u[*i]))
        .map(|(_, p)| p.avar * upper_factor(p.edf[k].max(1.0)) / shapes(p.tau_s)[k])
        .fold(f64::INFINITY, f64::min)
}

/// One reweighted fit's state.
#[derive(Clone, Debug)]
struct Reweighted {
    /// Powers of the free terms (0 elsewhere).
    coef: [f64; 4],
    edf: Vec<f64>,
    /// Var(σ̂²) per point under the model, and the weights 1/Var.
    variance: Vec<f64>,
    weights: Vec<f64>,
    /// The values fitted last (σ̂², or the log fit's pseudo-data).
    target: Vec<f64>,
}

/// The points, which are used, and the fixed powers.
struct Curve<'a> {
    points: &'a [CurvePoint],
    used: &'a [bool],
    fixed: [f64; 4],
    above_weight: f64,
}

impl Curve<'_> {
    fn model_at(&self, coef: &[f64; 4], tau: f64) -> [f64; 4] {
        let g = shapes(tau);
        std::array::from_fn(|k| g[k] * (coef[k] + self.fixed[k]))
    }

    /// The non-negative weighted fit of the `free` terms, reweighted by the
    /// model until it settles. The first round fits σ̂² itself; the later
    /// ones fit ln σ̂² (Gauss–Newton: the pseudo-data m (1 + ln(σ̂²/m) − E)
    /// with E = E[ln χ²_ν/ν] ≈ −1/ν − 1/(3ν²), so that σ̂² falling below the
    /// model pulls it down as hard as σ̂² above pulls it up, and the skew of
    /// χ² at few degrees of freedom does not bias it).
    fn reweighted(&self, free: [bool; 4]) -> Reweighted {
        let pts = self.points;
        // Start: the data's own σ² and white-rate ν.
        let mut variance: Vec<f64> = pts
            .iter()
            .map(|p| 2.0 * p.avar.powi(2) / p.edf[1].max(1.0))
            .collect();
        let mut edf: Vec<f64> = pts.iter().map(|p| p.edf[1]).collect();
        let mut coef = [0.0; 4];
        let mut weights = Vec::new();
        let mut target: Vec<f64> = pts.iter().map(|p| p.avar).collect();
        let mut above = vec![false; pts.len()];
        for _ in 0..MAX_ROUNDS {
            weights = variance
                .iter()
                .zip(self.used.iter().zip(&above))
                .map(|(v, (u, a))| match (*u && *v > 0.0, *a) {
                    (false, _) => 0.0,
                    (true, false) => 1.0 / v,
                    (true, true) => self.above_weight / v,
                })
                .collect();
            let next = self.nnls(&target, &weights, free);
            let settled = next
                .iter()
                .zip(&coef)
                .all(|(a, b)| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()));
            coef = next;
            for (k, p) in pts.iter().enumerate() {
                let parts = self.model_at(&coef, p.tau_s);
                let model: f64 = parts.iter().sum();
                above[k] = p.avar > model;
                if model > 0.0 {
                    let shares = parts.map(|x| x / model);
                    edf[k] = edf_mixed(&shares, &p.edf);
                    variance[k] = 2.0 * model * model / edf[k];
                    if p.avar > 0.0 {
                        let nu = edf[k].max(1.0);
                        let bias = 1.0 / nu + 1.0 / (3.0 * nu * nu);
                        target[k] = model * (1.0 + (p.avar / model).ln() + bias);
                    }
                }
            }
            if settled {
                break;
            }
        }
        Reweighted {
            coef,
            edf,
            variance,
            weights,
            target,
        }
    }

    /// Weighted least squares of σ̂² less the fixed terms on the free
    /// shapes, every coefficient ≥ 0: with four columns at most, every
    /// subset of them is tried (the constrained optimum is the
    /// unconstrained optimum over its own positive columns).
    fn nnls(&self, target: &[f64], weights: &[f64], free: [bool; 4]) -> [f64; 4] {
        let mut best = ([0.0; 4], f64::INFINITY);
        for set in 0u32..16 {
            let cols: Vec<usize> = (0..4).filter(|i| set & (1 << i) != 0).collect();
            if cols.iter().any(|&i| !free[i]) {
                continue;
            }
            let Some(x) = self.solve(target, weights, &cols) else {
                continue;
            };
            if x.iter().any(|c| *c < 0.0) {
                continue;
            }
            let mut full = [0.0; 4];
            for (j, &i) in cols.iter().enumerate() {
                full[i] = x[j];
            }
            let ssr = self.weighted_ssr(target, weights, &full);
            if ssr < best.1 {
                best = (full, ssr);
            }
        }
        best.0
    }

    fn weighted_ssr(&self, target: &[f64], weights: &[f64], coef: &[f64; 4]) -> f64 {
        self.points
            .iter()
            .zip(weights.iter().zip(target))
            .map(|(p, (w, y))| w * (y - self.model_at(coef, p.tau_s).iter().sum::<f64>()).powi(2))
            .sum()
    }

    /// The design matrix of `cols` (columns scaled to unit norm under the
    /// weights: their sizes differ by the τ range to the fourth power),
    /// with the scales.
    fn design(&self, weights: &[f64], cols: &[usize]) -> Option<(DMatrix<f64>, Vec<f64>)> {
        let mut a = DMatrix::<f64>::zeros(self.points.len(), cols.len());
        for (k, p) in self.points.iter().enumerate() {
            let g = shapes(p.tau_s);
            for (j, &i) in cols.iter().enumerate() {
                a[(k, j)] = weights[k].sqrt() * g[i];
            }
        }
        let norms: Vec<f64> = (0..cols.len()).map(|j| a.column(j).norm()).collect();
        if norms.iter().any(|n| !n.is_finite() || *n <= 0.0) {
            return None;
        }
        for (j, n) in norms.iter().enumerate() {
            a.column_mut(j).scale_mut(1.0 / n);
        }
        Some((a, norms))
    }

    /// The unconstrained weighted fit of `cols` (powers).
    fn solve(&self, target: &[f64], weights: &[f64], cols: &[usize]) -> Option<Vec<f64>> {
        if cols.is_empty() {
            return Some(Vec::new());
        }
        let (a, norms) = self.design(weights, cols)?;
        let b = DVector::from_iterator(
            self.points.len(),
            self.points.iter().enumerate().map(|(k, p)| {
                let fixed: f64 = self.model_at(&[0.0; 4], p.tau_s).iter().sum();
                weights[k].sqrt() * (target[k] - fixed)
            }),
        );
        let x = a.svd(true, true).solve(&b, 1e-12).ok()?;
        Some(x.iter().zip(&norms).map(|(x, n)| x / n).collect())
    }

    /// The linear map from σ̂² to the fitted powers of `cols`,
    /// H = (AᵀWA)⁻¹AᵀW, rows per column.
    fn hat(&self, weights: &[f64], cols: &[usize]) -> Option<DMatrix<f64>> {
        let (a, norms) = self.design(weights, cols)?;
        let pinv = a.pseudo_inverse(1e-12).ok()?;
        let mut h = pinv;
        for (j, n) in norms.iter().enumerate() {
            for (k, w) in weights.iter().enumerate() {
                h[(j, k)] *= w.sqrt() / n;
            }
        }
        Some(h)
    }

    /// Var(p̂_k) of each free term under the curve's covariance at the
    /// fitted model (∞ where the fit cannot be formed).
    fn parameter_covariance(
        &self,
        fit: &Reweighted,
        free: [bool; 4],
        covariance: &CurveCovariance,
    ) -> [f64; 4] {
        let cols: Vec<usize> = (0..4).filter(|&k| free[k]).collect();
        let model = NoiseTerms::from_powers(std::array::from_fn(|k| fit.coef[k] + self.fixed[k]));
        let mut out = [f64::INFINITY; 4];
        if let Some(var) = self.variances(&fit.weights, &cols, &model, covariance) {
            for (j, &k) in cols.iter().enumerate() {
                out[k] = var[j];
            }
        }
        out
    }

    fn variances(
        &self,
        weights: &[f64],
        cols: &[usize],
        model: &NoiseTerms,
        covariance: &CurveCovariance,
    ) -> Option<Vec<f64>> {
        if cols.is_empty() {
            return Some(Vec::new());
        }
        let h = self.hat(weights, cols)?;
        let c = covariance.for_model(model.powers());
        let hc = &h * c * h.transpose();
        Some((0..cols.len()).map(|j| hc[(j, j)].max(0.0)).collect())
    }

    /// The 95 % upper bound of term k's amplitude, not resolved: the fit of
    /// the resolved terms plus k, and the curve's own ceiling.
    fn bound(
        &self,
        k: usize,
        free: [bool; 4],
        (target, weights): (&[f64], &[f64]),
        model: &NoiseTerms,
        covariance: &CurveCovariance,
    ) -> f64 {
        let mut cols: Vec<usize> = (0..4).filter(|&i| free[i]).collect();
        cols.push(k);
        cols.sort_unstable();
        let j = cols.iter().position(|&i| i == k).unwrap_or(0);
        let statistical = match (
            self.solve(target, weights, &cols),
            self.variances(weights, &cols, model, covariance),
        ) {
            (Some(x), Some(v)) => x[j].max(0.0) + BOUND_SIGMAS * v[j].sqrt(),
            _ => f64::INFINITY,
        };
        statistical
            .min(ceiling(self.points, None, k))
            .max(0.0)
            .sqrt()
    }

    fn rms_z(&self, fit: &Reweighted) -> f64 {
        let mut z2 = 0.0;
        let mut n = 0;
        for (k, p) in self.points.iter().enumerate() {
            if !self.used[k] || fit.variance[k] <= 0.0 {
                continue;
            }
            let model: f64 = self.model_at(&fit.coef, p.tau_s).iter().sum();
            z2 += (p.avar - model).powi(2) / fit.variance[k];
            n += 1;
        }
        (z2 / n.max(1) as f64).sqrt()
    }
}

/// σ² / σ̂² at the upper 97.5 % point of ν/χ²_ν (Wilson–Hilferty).
fn upper_factor(nu: f64) -> f64 {
    nu / chi2_quantile(nu, -1.959_964)
}

/// The χ²_ν quantile at the standard normal quantile `z` (Wilson–Hilferty,
/// within a few per cent down to ν = 1 in the tails used here).
pub fn chi2_quantile(nu: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * nu);
    (nu * (1.0 - a + z * a.sqrt()).powi(3)).max(1e-3 * nu)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact_curve(truth: [f64; 4], sizes: &[usize], tau0: f64) -> Vec<CurvePoint> {
        sizes
            .iter()
            .map(|&m| {
                let tau_s = m as f64 * tau0;
                CurvePoint {
                    tau_s,
                    cluster_records: m,
                    avar: NoiseTerms::from_powers(truth.map(|c| c * c)).allan_variance(tau_s),
                    edf: [1e9; 4],
                }
            })
            .collect()
    }

    /// An exact curve of known terms (no estimation noise) over a long
    /// stretch is fitted back to them with small σ; the absent term is a
    /// bound, not a value.
    #[test]
    fn an_exact_curve_gives_back_its_terms_and_bounds_the_absent_one() {
        let truth = [2e-5_f64, 3e-4, 5e-5, 0.0];
        let tau0 = 0.01;
        let sizes = super::super::allan::cluster_sizes(20_000, 10);
        let points = exact_curve(truth, &sizes, tau0);
        let covariance = CurveCovariance::new(&sizes, &[10_000_000], tau0);
        let fit = fit_terms(
            &points,
            &FitInput {
                covariance: &covariance,
                fixed_quantization: None,
                used: None,
                above_weight: 1.0,
            },
        );
        for (k, want) in truth.iter().enumerate().take(3) {
            match fit.estimates[k] {
                Estimate::Resolved { value, sigma } => {
                    assert!((value - want).abs() <= 1e-6 * want, "{k}: {value}");
                    assert!(sigma > 0.0 && sigma < 0.2 * want, "{k}: σ {sigma}");
                }
                e => panic!("term {k}: {e:?}"),
            }
        }
        match fit.estimates[3] {
            Estimate::Bound { upper } => assert!(upper > 0.0 && upper < 1e-5, "{upper}"),
            e => panic!("K: {e:?}"),
        }
        assert!(fit.rms_z < 1e-3, "{}", fit.rms_z);
        // Q held at a known value: only N and B are fitted.
        let held = fit_terms(
            &points,
            &FitInput {
                covariance: &covariance,
                fixed_quantization: Some(truth[0]),
                used: None,
                above_weight: 1.0,
            },
        );
        assert_eq!(held.estimates[0], Estimate::Fixed { value: truth[0] });
        assert!(matches!(held.estimates[1], Estimate::Resolved { value, .. }
            if (value - truth[1]).abs() < 1e-6 * truth[1]));
    }
}
