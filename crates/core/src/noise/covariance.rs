//! The covariance of an overlapping Allan variance curve under a noise
//! model: how far the points can move, and how they move together.
//!
//! The points of an overlapping curve share data (every record enters
//! every τ), so their errors are correlated, strongly between neighbours.
//! A fit that treated them as independent would quote its terms far too
//! precisely. This module computes the whole covariance matrix of the
//! curve for a model σ²(τ) = 3Q²/τ² + N²/τ + (2 ln 2/π) B² + K² τ/3, the
//! stretches analysed and the cluster sizes, in closed form:
//!
//! - Each term d_j(m) = x_{j+2m} − 2 x_{j+m} + x_j is a second difference
//!   of the accumulated angle (or velocity) x, so its covariances follow
//!   from x's generalized covariance G(s) (an intrinsic random function of
//!   order 1: the weights (1, −2, 1) cancel constants and slopes):
//!   G(s) = Q² δ(s) − N² |s|/2 + B² s² ln|s| / (2π) + K² |s|³/12, the four
//!   processes' own (white phase, white rate, flicker rate, random-walk
//!   rate), each scaled so that it gives its term of σ²(τ) exactly.
//! - Cov(d_j(m₁), d_{j+h}(m₂)) = Σ_a Σ_b w_a w_b G((h + b m₂ − a m₁) τ0).
//! - For Gaussian noise Cov(d², d'²) = 2 Cov(d, d')², so with M_i terms
//!   at τ_i, Cov(σ̂²_1, σ̂²_2) = 2 Σ_h W(h) C₁₂(h)² / (4 τ₁² τ₂² M₁ M₂),
//!   W(h) the number of term pairs at lag h within one stretch, summed
//!   over the stretches (separate stretches are taken as independent).
//!
//! The lag sum is exact at the breakpoints (where an argument of G is zero
//! or W changes slope) and by Gauss–Legendre quadrature between them,
//! where the summand is smooth: a few hundred evaluations per pair of
//! points whatever the cluster sizes.

use nalgebra::DMatrix;

/// Second-difference weights at 0, m, 2m.
const W: [f64; 3] = [1.0, -2.0, 1.0];

/// Integers between breakpoints summed one by one up to this many; longer
/// gaps by quadrature.
const DIRECT_MAX: i64 = 24;

/// Gauss–Legendre nodes and weights on [−1, 1], 8 points.
const GL_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// The four generalized covariances of x at lag `s` seconds per unit of
/// each term's squared coefficient (see the module text), in the order
/// Q, N, B, K; `exact_zero` where the lag is exactly zero (the white-phase
/// part).
fn generalized(s: f64, exact_zero: bool) -> [f64; 4] {
    if exact_zero {
        return [1.0, 0.0, 0.0, 0.0];
    }
    let a = s.abs();
    [
        0.0,
        -0.5 * a,
        s * s * a.ln() / (2.0 * std::f64::consts::PI),
        a * a * a / 12.0,
    ]
}

/// The 10 distinct products of two terms' parts, (k, l) with k ≤ l.
const PRODUCTS: [(usize, usize); 10] = [
    (0, 0),
    (0, 1),
    (0, 2),
    (0, 3),
    (1, 1),
    (1, 2),
    (1, 3),
    (2, 2),
    (2, 3),
    (3, 3),
];

/// One pair of cluster sizes' lag structure.
struct Pair {
    tau0: f64,
    m1: i64,
    m2: i64,
    /// Terms per stretch at m1 and m2.
    counts: Vec<(i64, i64)>,
}

impl Pair {
    /// Cov(d_j(m1), d_{j+h}(m2)) per term at a real lag h (exact zeros only
    /// at integer h).
    fn c12(&self, h: f64) -> [f64; 4] {
        let mut c = [0.0; 4];
        for (a, wa) in W.iter().enumerate() {
            for (b, wb) in W.iter().enumerate() {
                let lag = h + (b as i64 * self.m2 - a as i64 * self.m1) as f64;
                let g = generalized(lag * self.tau0, lag == 0.0);
                for k in 0..4 {
                    c[k] += wa * wb * g[k];
                }
            }
        }
        c
    }

    /// Pairs of terms at lag h, over the stretches.
    fn pairs(&self, h: f64) -> f64 {
        self.counts
            .iter()
            .map(|&(m1, m2)| {
                let (m1, m2) = (m1 as f64, m2 as f64);
                (m1.min(m2 - h) - (-h).max(0.0)).max(0.0)
            })
            .sum()
    }

    /// W(h) c_k(h) c_l(h) for every product, added to `sum` times `weight`.
    fn add_summand(&self, h: f64, weight: f64, sum: &mut [f64; 10]) {
        let w = self.pairs(h);
        if w <= 0.0 {
            return;
        }
        let c = self.c12(h);
        for (s, (k, l)) in sum.iter_mut().zip(PRODUCTS) {
            *s += weight * w * c[k] * c[l];
        }
    }

    /// The lags where the summand is not smooth, and the ends of its
    /// support (a flicker term's tail, which falls as h⁻⁴, out to 64
    /// clusters).
    fn breakpoints(&self) -> Vec<i64> {
        let (m1, m2) = (self.m1, self.m2);
        let widest = self
            .counts
            .iter()
            .fold((0, 0), |w, c| (w.0.max(c.0), w.1.max(c.1)));
        let tail = 64 * m1.max(m2);
        let lo = (-widest.0).max(-2 * m2 - tail);
        let hi = widest.1.min(2 * m1 + tail);
        let mut points = vec![lo, hi];
        for a in 0..3 {
            for b in 0..3 {
                points.push(a * m1 - b * m2);
            }
        }
        for &(c1, c2) in &self.counts {
            points.extend([0, c2 - c1, c2, -c1]);
        }
        for k in 0..7 {
            let step = m1.max(m2) << k;
            points.extend([2 * m1 + step, -2 * m2 - step]);
        }
        points.retain(|p| (lo..=hi).contains(p));
        points.sort_unstable();
        points.dedup();
        points
    }

    /// Σ_h W(h) c_k(h) c_l(h) for every product.
    fn lag_sums(&self) -> [f64; 10] {
        let points = self.breakpoints();
        let mut sum = [0.0; 10];
        for (k, &p) in points.iter().enumerate() {
            self.add_summand(p as f64, 1.0, &mut sum);
            let Some(&next) = points.get(k + 1) else {
                break;
            };
            if next - p - 1 <= DIRECT_MAX {
                for h in p + 1..next {
                    self.add_summand(h as f64, 1.0, &mut sum);
                }
            } else {
                // Σ over p+1 … next−1 ≈ ∫ from p + ½ to next − ½.
                let (a, b) = (p as f64 + 0.5, next as f64 - 0.5);
                let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
                for (x, w) in GL_X.iter().zip(&GL_W) {
                    self.add_summand(mid - half * x, half * w, &mut sum);
                    self.add_summand(mid + half * x, half * w, &mut sum);
                }
            }
        }
        sum
    }
}

/// The covariance of a curve's points for any mix of the four terms: the
/// lag sums of each product of two terms' parts, computed once for a
/// curve's cluster sizes and stretches (they are the same for every axis
/// and every model tried), then combined with the model's coefficients.
///
/// ```
/// use sinscal_core::noise::covariance::CurveCovariance;
/// let cov = CurveCovariance::new(&[1, 10, 100], &[100_000], 0.01);
/// let white = [0.0, 1e-8, 0.0, 0.0]; // N = 1e-4 /√s
/// let c = cov.for_model(white);
/// assert!(c[(0, 1)] > 0.0 && c[(0, 1)] < c[(0, 0)].max(c[(1, 1)]));
/// ```
#[derive(Clone, Debug)]
pub struct CurveCovariance {
    /// Per pair (i ≤ j): the ten lag sums already divided by
    /// 2 τ_i² τ_j² M_i M_j.
    basis: Vec<[f64; 10]>,
    n: usize,
}

impl CurveCovariance {
    /// The curve at cluster sizes `sizes` (records) over `stretches`
    /// (records each) of records `tau0_s` apart.
    pub fn new(sizes: &[usize], stretches: &[u64], tau0_s: f64) -> Self {
        let n = sizes.len();
        let per_size: Vec<Vec<i64>> = sizes
            .iter()
            .map(|&m| {
                stretches
                    .iter()
                    .map(|&r| (r as i64 + 1 - 2 * m as i64).max(0))
                    .collect()
            })
            .collect();
        let mut basis = vec![[0.0; 10]; n * n];
        for i in 0..n {
            for j in i..n {
                let (mi, mj) = (&per_size[i], &per_size[j]);
                let (ti, tj): (i64, i64) = (mi.iter().sum(), mj.iter().sum());
                if ti == 0 || tj == 0 {
                    continue;
                }
                let pair = Pair {
                    tau0: tau0_s,
                    m1: sizes[i] as i64,
                    m2: sizes[j] as i64,
                    counts: mi.iter().zip(mj).map(|(a, b)| (*a, *b)).collect(),
                };
                let (tau_i, tau_j) = (sizes[i] as f64 * tau0_s, sizes[j] as f64 * tau0_s);
                let scale = 2.0 / (4.0 * tau_i.powi(2) * tau_j.powi(2) * ti as f64 * tj as f64);
                basis[i * n + j] = pair.lag_sums().map(|s| s * scale);
            }
        }
        CurveCovariance { basis, n }
    }

    /// Cov(σ̂²(τ_i), σ̂²(τ_j)) (SI rate units to the fourth) under the model
    /// of powers `p` = (Q², N², B², K²) (`NoiseTerms::powers`).
    pub fn for_model(&self, p: [f64; 4]) -> DMatrix<f64> {
        let n = self.n;
        let mut cov = DMatrix::zeros(n, n);
        for i in 0..n {
            for j in i..n {
                let b = &self.basis[i * n + j];
                let c: f64 = PRODUCTS
                    .iter()
                    .zip(b)
                    .map(|(&(k, l), s)| {
                        let twice = if k == l { 1.0 } else { 2.0 };
                        twice * p[k] * p[l] * s
                    })
                    .sum();
                cov[(i, j)] = c;
                cov[(j, i)] = c;
            }
        }
        cov
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::edf::{edf_stretch, NoiseKind};

    fn only(q: f64, n: f64, b: f64, k: f64) -> [f64; 4] {
        [q * q, n * n, b * b, k * k]
    }

    /// σ²(τ) of the model: 3Q²/τ² + N²/τ + (2 ln 2/π) B² + K² τ/3.
    fn allan_variance(p: &[f64; 4], tau: f64) -> f64 {
        let floor = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;
        3.0 * p[0] / (tau * tau) + p[1] / tau + floor * p[2] + p[3] * tau / 3.0
    }

    /// Each term alone: the diagonal's mean is the model's σ²(τ) (through
    /// Var = 2σ⁴/ν, ν within the NIST SP 1065 approximations' few per
    /// cent), and the correlation of neighbouring points is high.
    #[test]
    fn the_diagonal_matches_the_degrees_of_freedom_of_each_kind() {
        let tau0 = 0.01;
        let records = 200_000u64;
        let sizes = [1usize, 10, 100, 1000, 1259, 10_000];
        let curve = CurveCovariance::new(&sizes, &[records], tau0);
        for (terms, kind, tolerance) in [
            (only(1e-6, 0.0, 0.0, 0.0), NoiseKind::WhitePhase, 0.05),
            (only(0.0, 1e-4, 0.0, 0.0), NoiseKind::WhiteRate, 0.05),
            (only(0.0, 0.0, 0.0, 1e-5), NoiseKind::RandomWalkRate, 0.25),
            (only(0.0, 0.0, 1e-5, 0.0), NoiseKind::FlickerRate, 0.25),
        ] {
            let cov = curve.for_model(terms);
            for (i, &m) in sizes.iter().enumerate() {
                let avar = allan_variance(&terms, m as f64 * tau0);
                let nu = 2.0 * avar * avar / cov[(i, i)];
                let table = edf_stretch(kind, records, m);
                assert!(
                    (nu / table - 1.0).abs() < tolerance,
                    "{kind:?} m {m}: ν {nu} against {table}"
                );
            }
            // Neighbours share most of their data; a decade apart, little.
            let r = |i: usize, j: usize| cov[(i, j)] / (cov[(i, i)] * cov[(j, j)]).sqrt();
            assert!(
                r(3, 4) > 0.5 && r(3, 4) <= 1.0,
                "{kind:?}: correlation {}",
                r(3, 4)
            );
            assert!(r(3, 5) < r(3, 4), "{kind:?}");
        }
    }
}
