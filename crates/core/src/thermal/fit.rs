//! One parameter against temperature: a weighted least-squares polynomial
//! in ΔT = T − 25 °C, each run weighted by its own σ.
//!
//! ```text
//! y_i = p + p1 ΔT_i + p2 ΔT_i² + e_i,   e_i ~ N(0, σ_i²)
//! ```
//!
//! The runs' estimates are independent (separate runs, separate noise), so
//! each parameter is fitted alone; a result does not carry the
//! correlations between its own parameters, which the fit would need to
//! do better.

use nalgebra::{DMatrix, DVector};

/// One run's estimate of the parameter at its temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub delta_t_c: f64,
    pub value: f64,
    pub sigma: f64,
}

/// A fitted polynomial and how well it explains the samples.
#[derive(Clone, Debug, PartialEq)]
pub struct PolyFit {
    /// p, p1, p2 (as many as fitted).
    pub coefficients: Vec<f64>,
    /// Their covariance, row-major, `coefficients.len()`² entries.
    pub covariance: Vec<f64>,
    /// Σ (residual/σ)².
    pub chi2: f64,
    /// Samples less coefficients.
    pub dof: usize,
    /// Each sample's residual over its own standard deviation, leverage
    /// accounted for (`r_i / (σ_i √(1 − h_ii))`): N(0, 1) when the model
    /// holds, so one run that left the model stands out.
    pub standardized: Vec<f64>,
}

impl PolyFit {
    pub fn order(&self) -> usize {
        self.coefficients.len() - 1
    }

    pub fn sigma(&self, k: usize) -> f64 {
        let n = self.coefficients.len();
        self.covariance[k * n + k].max(0.0).sqrt()
    }

    /// The polynomial's value at ΔT and its σ (from the coefficients'
    /// covariance).
    pub fn at(&self, delta_t_c: f64) -> (f64, f64) {
        let n = self.coefficients.len();
        let basis: Vec<f64> = (0..n).map(|k| delta_t_c.powi(k as i32)).collect();
        let value = basis
            .iter()
            .zip(&self.coefficients)
            .map(|(b, c)| b * c)
            .sum();
        let mut var = 0.0;
        for i in 0..n {
            for j in 0..n {
                var += basis[i] * self.covariance[i * n + j] * basis[j];
            }
        }
        (value, var.max(0.0).sqrt())
    }
}

/// The weighted least-squares polynomial of `order` through the samples;
/// `None` when the samples cannot determine it (too few distinct
/// temperatures, or a σ that is not positive).
pub fn fit_polynomial(samples: &[Sample], order: usize) -> Option<PolyFit> {
    let m = order + 1;
    let n = samples.len();
    if n < m
        || samples
            .iter()
            .any(|s| s.sigma.is_nan() || s.sigma <= 0.0 || !s.value.is_finite())
    {
        return None;
    }
    // Rows scaled by 1/σ: ordinary least squares on the whitened system.
    let a = DMatrix::from_fn(n, m, |i, k| {
        samples[i].delta_t_c.powi(k as i32) / samples[i].sigma
    });
    let b = DVector::from_fn(n, |i, _| samples[i].value / samples[i].sigma);
    let normal = a.transpose() * &a;
    let covariance = normal.clone().try_inverse()?;
    // A singular design (all runs at one temperature for a slope) shows
    // as a covariance that is not finite or not positive.
    if (0..m).any(|k| !covariance[(k, k)].is_finite() || covariance[(k, k)] <= 0.0) {
        return None;
    }
    let x = &covariance * (a.transpose() * &b);
    let residual = &b - &a * &x;
    let hat = &a * &covariance * a.transpose();
    let standardized = (0..n)
        .map(|i| {
            let room = (1.0 - hat[(i, i)]).max(1e-12);
            residual[i] / room.sqrt()
        })
        .collect();
    Some(PolyFit {
        coefficients: x.iter().copied().collect(),
        covariance: covariance.transpose().iter().copied().collect(),
        chi2: residual.norm_squared(),
        dof: n - m,
        standardized,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exact_line_is_recovered_with_the_textbook_covariance() {
        // y = 2 + 0.5 ΔT at ΔT = −1, 0, 1 with σ = 1: slope variance
        // 1/Σ ΔT² = 1/2, intercept variance 1/3, no correlation.
        let samples: Vec<Sample> = [-1.0, 0.0, 1.0]
            .iter()
            .map(|&d| Sample {
                delta_t_c: d,
                value: 2.0 + 0.5 * d,
                sigma: 1.0,
            })
            .collect();
        let f = fit_polynomial(&samples, 1).unwrap();
        assert!((f.coefficients[0] - 2.0).abs() < 1e-12);
        assert!((f.coefficients[1] - 0.5).abs() < 1e-12);
        assert!((f.sigma(0) - (1.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((f.sigma(1) - 0.5f64.sqrt()).abs() < 1e-12);
        assert!(f.chi2 < 1e-20);
        assert_eq!(f.dof, 1);
        let (v, s) = f.at(2.0);
        assert!((v - 3.0).abs() < 1e-12);
        // Var = 1/3 + 4/2.
        assert!((s - (1.0f64 / 3.0 + 2.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn one_temperature_cannot_give_a_slope_and_an_outlier_stands_out() {
        let flat = [Sample {
            delta_t_c: 5.0,
            value: 1.0,
            sigma: 1.0,
        }; 3];
        assert!(fit_polynomial(&flat, 1).is_none());
        let mut samples: Vec<Sample> = (0..6)
            .map(|k| Sample {
                delta_t_c: 10.0 * k as f64,
                value: 0.1 * k as f64,
                sigma: 0.01,
            })
            .collect();
        samples[3].value += 0.2;
        let f = fit_polynomial(&samples, 1).unwrap();
        let worst = f
            .standardized
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap();
        assert_eq!(worst.0, 3);
        assert!(worst.1.abs() > 10.0);
    }
}
