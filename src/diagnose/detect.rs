//! What a run could see: for every candidate, the smallest effect the
//! selection would have named on this run.
//!
//! A candidate is named when Δχ²/dispersion − k ln n exceeds the BIC
//! threshold. For a true effect θ (in the candidate's parameters) the fit
//! of the candidate's columns drops χ² by θᵀFθ on average plus k times
//! the dispersion for the noise the k columns absorb, F the information
//! of the candidate's parameters with the base parameters, the node
//! attitudes and the effects already named profiled out (the inverse of
//! their covariance in the fit). The threshold is the size at which that
//! expected drop reaches the naming bar:
//!
//!   θᵀFθ = dispersion · (bic_threshold + k ln n − k).
//!
//! An effect at the threshold is named in about half the runs; at twice
//! it, its Δχ² is four times the bar's noncentrality. Parameters are
//! grouped by unit (a drift's gyro and accelerometer rates are two
//! quantities); within a group the threshold is along the most visible
//! direction (the largest eigenvalue of F's block), and each parameter
//! alone is reported too, for effects that hide along some axes (a
//! diagonal g-sensitivity only tilts the azimuth on a short dwell).
//!
//! The threshold speaks of the naming bar only: a candidate another one
//! explains as well is reported as ambiguous instead, whatever its size.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::candidates::{quantity, Candidate};

/// The smallest effect of one quantity that the run would have named.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectionThreshold {
    /// SPEC §3 name.
    pub effect: String,
    /// The parameterisation.
    pub candidate: String,
    /// What the size is of ("gyro drift", "delay", …).
    pub quantity: String,
    pub unit: String,
    /// Smallest size named along the most visible direction (the norm of
    /// the parameter vector), `unit`.
    pub size: f64,
    /// The group's parameters, the most visible direction (unit vector,
    /// largest component positive) and each parameter's threshold alone.
    pub params: Vec<String>,
    pub direction: Vec<f64>,
    pub per_parameter: Vec<f64>,
}

/// What the selection weighed one candidate against when it last scored
/// it.
#[derive(Clone, Debug)]
pub struct Visibility {
    /// Covariance of the candidate's parameters in signature sizes², the
    /// other unknowns profiled out.
    pub cov: DMatrix<f64>,
    pub dispersion: f64,
    /// Number of velocity observations (the BIC's n).
    pub n_obs: f64,
}

/// The thresholds of candidate `cand` (one per unit among its
/// parameters), `bic_threshold` the selection's naming bar.
pub fn thresholds(
    cand: &Candidate,
    vis: &Visibility,
    bic_threshold: f64,
) -> Vec<DetectionThreshold> {
    let k = cand.params.len();
    let need = vis.dispersion * (bic_threshold + k as f64 * vis.n_obs.ln() - k as f64);
    let lambda = need.max(vis.dispersion);
    // Information in the parameters' own units: θ_sig = x / size.
    let info = information(&vis.cov);
    let size: Vec<f64> = cand.params.iter().map(|p| p.signature_size).collect();
    let info_units = DMatrix::from_fn(k, k, |i, j| info[(i, j)] / (size[i] * size[j]));
    let mut units: Vec<&str> = Vec::new();
    for p in &cand.params {
        if !units.contains(&p.unit.as_str()) {
            units.push(&p.unit);
        }
    }
    units
        .into_iter()
        .map(|unit| {
            let idx: Vec<usize> = (0..k).filter(|&i| cand.params[i].unit == unit).collect();
            let block = DMatrix::from_fn(idx.len(), idx.len(), |a, b| info_units[(idx[a], idx[b])]);
            let eig = block.clone().symmetric_eigen();
            let top = eig.eigenvalues.imax();
            let mut direction: Vec<f64> = eig.eigenvectors.column(top).iter().copied().collect();
            let largest = direction
                .iter()
                .copied()
                .max_by(|a, b| a.abs().total_cmp(&b.abs()))
                .unwrap_or(1.0);
            if largest < 0.0 {
                direction.iter_mut().for_each(|d| *d = -*d);
            }
            let at = |f: f64| (lambda / f.max(f64::MIN_POSITIVE)).sqrt();
            DetectionThreshold {
                effect: cand.effect.to_string(),
                candidate: cand.name.to_string(),
                quantity: quantity(cand, unit).to_string(),
                unit: unit.to_string(),
                size: at(eig.eigenvalues[top]),
                params: idx.iter().map(|&i| cand.params[i].name.clone()).collect(),
                direction,
                per_parameter: (0..idx.len()).map(|a| at(block[(a, a)])).collect(),
            }
        })
        .collect()
}

/// The inverse of a covariance through its eigen-decomposition: a
/// direction the fit held only by its prior keeps a tiny, not a negative,
/// information.
fn information(cov: &DMatrix<f64>) -> DMatrix<f64> {
    let eig = cov.clone().symmetric_eigen();
    let largest = eig.eigenvalues.amax().max(f64::MIN_POSITIVE);
    let inv = eig.eigenvalues.map(|l| 1.0 / l.max(largest * f64::EPSILON));
    &eig.eigenvectors * DMatrix::from_diagonal(&inv) * eig.eigenvectors.transpose()
}

/// "a delay ≥ 0.12 ms, a gyro drift ≥ … deg/h/h, …", with the least
/// visible parameter of a group whose parameters differ much.
pub fn describe(thresholds: &[DetectionThreshold]) -> String {
    thresholds
        .iter()
        .map(|t| {
            let article = if t.quantity.starts_with(['a', 'e', 'i', 'o', 'u']) {
                "an"
            } else {
                "a"
            };
            let mut s = format!("{article} {} ≥ {} {}", t.quantity, figure(t.size), t.unit);
            let worst = t
                .per_parameter
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1));
            if let Some((i, &w)) = worst {
                if t.per_parameter.len() > 1 && w > 3.0 * t.size {
                    s.push_str(&format!(" ({} alone only ≥ {})", t.params[i], figure(w)));
                }
            }
            s
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Three significant figures, in plain notation where that is short.
fn figure(x: f64) -> String {
    if !(1e-4..1e5).contains(&x.abs()) {
        return format!("{x:.2e}");
    }
    let decimals = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::candidates::library;

    fn candidate(name: &str) -> Candidate {
        library().into_iter().find(|c| c.name == name).unwrap()
    }

    #[test]
    fn one_parameter_threshold_meets_the_naming_bar() {
        // σ of 0.1 signature sizes (0.1 ms), n = 300, bar 10: the expected
        // Δχ² of the threshold, (size/σ)² + 1, is 10 + ln 300.
        let vis = Visibility {
            cov: DMatrix::from_element(1, 1, 0.01),
            dispersion: 1.0,
            n_obs: 300.0,
        };
        let t = thresholds(&candidate("accel_delay"), &vis, 10.0);
        assert_eq!(t.len(), 1);
        let expect = 0.1 * (10.0 + 300f64.ln() - 1.0).sqrt();
        assert!((t[0].size - expect).abs() < 1e-12, "{}", t[0].size);
        assert_eq!(t[0].per_parameter, [t[0].size]);
        // Twice the dispersion: √2 times the size.
        let t2 = thresholds(
            &candidate("accel_delay"),
            &Visibility {
                dispersion: 2.0,
                ..vis
            },
            10.0,
        );
        assert!((t2[0].size / t[0].size - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn groups_by_unit_and_finds_the_most_visible_direction() {
        // Drift: gyro x and y with strongly correlated errors (only
        // their difference is well determined), every other parameter
        // independent.
        let mut cov = DMatrix::<f64>::identity(6, 6);
        cov[(0, 0)] = 1.0;
        cov[(1, 1)] = 1.0;
        cov[(0, 1)] = 0.99;
        cov[(1, 0)] = 0.99;
        let vis = Visibility {
            cov,
            dispersion: 1.0,
            n_obs: 100.0,
        };
        let t = thresholds(&candidate("bias_drift"), &vis, 10.0);
        assert_eq!(t.len(), 2);
        assert_eq!(t[0].unit, "deg/h/h");
        assert_eq!(t[1].unit, "ug/h");
        assert_eq!(t[0].params.len(), 3);
        // x − y is the visible combination.
        let d = &t[0].direction;
        assert!((d[0].abs() - 0.5f64.sqrt()).abs() < 1e-9, "{d:?}");
        assert!((d[0] + d[1]).abs() < 1e-9, "{d:?}");
        assert!(t[0].size < t[0].per_parameter[0]);
        for x in t.iter().flat_map(|t| t.per_parameter.iter()) {
            assert!(x.is_finite() && *x > 0.0);
        }
        let text = describe(&t);
        assert!(text.contains("a gyro drift ≥ "), "{text}");
        assert!(text.contains("an accelerometer drift ≥ "), "{text}");
    }

    #[test]
    fn figures_keep_three_significant_digits() {
        assert_eq!(figure(0.0101), "0.0101");
        assert_eq!(figure(1.0188), "1.02");
        assert_eq!(figure(112.3), "112");
        assert_eq!(figure(2.5e-6), "2.50e-6");
    }
}
