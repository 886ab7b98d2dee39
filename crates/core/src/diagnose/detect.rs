//! What a run could see: for every candidate, the smallest effect the
//! selection would have named on this run.
//!
//! A candidate is named when Δχ²/dispersion − k ln n exceeds the BIC
//! threshold. For a true effect θ (in the candidate's parameters) the fit
//! of the candidate's columns drops χ² by θᵀFθ on average plus k times
//! the dispersion for the noise the k columns absorb, F the information
//! of the candidate's parameters with the base parameters, the node
//! attitudes and the effects already named profiled out. The naming bar
//! is met at the size where that expected drop reaches it:
//!
//!   θᵀFθ = dispersion · (bic_threshold + k ln n − k).
//!
//! An effect just above the bar may still be reported ambiguous: another
//! effect's candidate r takes up the part θᵀ J_cr J_rr⁻¹ J_rc θ of its
//! signature, and when that earns r a name on its own while the effect
//! fitted on top of r would not (the Schur complement J_cc − J_cr J_rr⁻¹
//! J_rc in place of F), or while r outscores it (fewer parameters
//! charged), the selection names neither. The threshold reported is the
//! size from which the effect is named and not ambiguous, in expectation;
//! an effect at the threshold is named in about half the runs.
//!
//! Parameters are grouped by unit (a drift's gyro and accelerometer rates
//! are two quantities); within a group the threshold is along the most
//! visible direction (the largest eigenvalue of F's block), and each
//! parameter alone is reported too, for effects that hide along some axes
//! (a diagonal g-sensitivity only tilts the azimuth on a short dwell).
//!
//! All of it from one fit carrying every candidate's columns: their joint
//! information J, from which any set of columns is profiled out by a
//! Schur complement.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};
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
    /// Smallest size named, and not ambiguous, along the most visible
    /// direction (the norm of the parameter vector), `unit`.
    pub size: f64,
    /// The size at which it meets the naming bar, rivals aside.
    pub size_without_rivals: f64,
    /// Effects that below `size` would fit it as well (the run would
    /// report "ambiguous").
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rivals: Vec<String>,
    /// The group's parameters, the most visible direction (unit vector,
    /// largest component positive) and each parameter's threshold alone.
    pub params: Vec<String>,
    pub direction: Vec<f64>,
    pub per_parameter: Vec<f64>,
}

/// What the selection weighs every candidate against.
#[derive(Clone, Debug)]
pub struct Visibility {
    /// Information of every effect column (library order, signature
    /// sizes), the base parameters and the attitudes profiled out.
    pub information: DMatrix<f64>,
    pub dispersion: f64,
    /// Number of velocity observations (the BIC's n).
    pub n_obs: f64,
}

impl Visibility {
    /// From the covariance of a fit of every effect column.
    pub fn from_covariance(cov: &DMatrix<f64>, dispersion: f64, n_obs: f64) -> Self {
        Visibility {
            information: information(cov),
            dispersion,
            n_obs,
        }
    }

    /// Noncentrality a candidate of `k` parameters needs to meet the bar.
    fn bar(&self, k: usize, bic_threshold: f64) -> f64 {
        let k = k as f64;
        self.dispersion * (bic_threshold + k * self.n_obs.ln() - k).max(1.0)
    }

    /// Information of columns `a` with columns `p` profiled out.
    fn given(&self, a: &[usize], p: &[usize]) -> DMatrix<f64> {
        let j = &self.information;
        let block =
            |x: &[usize], y: &[usize]| DMatrix::from_fn(x.len(), y.len(), |i, l| j[(x[i], y[l])]);
        let aa = block(a, a);
        if p.is_empty() {
            return aa;
        }
        let ap = block(a, p);
        &aa - &ap * invert(&block(p, p)) * ap.transpose()
    }
}

/// One candidate of the library: its parameters and their columns.
pub struct Column<'a> {
    pub candidate: &'a Candidate,
    pub columns: Range<usize>,
}

/// The thresholds of candidate `c` of `library` (one per unit among its
/// parameters), with the candidates `named` in the model and
/// `bic_threshold` the selection's naming bar.
pub fn thresholds(
    library: &[Column],
    c: usize,
    named: &[usize],
    vis: &Visibility,
    bic_threshold: f64,
) -> Vec<DetectionThreshold> {
    let cand = library[c].candidate;
    let k = cand.params.len();
    let cols: Vec<usize> = library[c].columns.clone().collect();
    // In the model: the named effects other than this one.
    let profiled: Vec<usize> = named
        .iter()
        .filter(|&&n| library[n].candidate.effect != cand.effect)
        .flat_map(|&n| library[n].columns.clone())
        .collect();
    let named_effect = |e: &str| named.iter().any(|&n| library[n].candidate.effect == e);
    // Information in the parameters' own units: θ_sig = x / size.
    let size: Vec<f64> = cand.params.iter().map(|p| p.signature_size).collect();
    let units = |m: &DMatrix<f64>| DMatrix::from_fn(k, k, |i, j| m[(i, j)] / (size[i] * size[j]));
    let f = vis.given(&cols, &profiled);
    // Per rival: what it takes up, what is left to this one on top of it.
    struct Rival {
        effect: String,
        bar: f64,
        taken: DMatrix<f64>,
        left: DMatrix<f64>,
        extra_params: usize,
    }
    let rivals: Vec<Rival> = library
        .iter()
        .filter(|r| r.candidate.effect != cand.effect && !named_effect(r.candidate.effect))
        .map(|r| {
            let rc: Vec<usize> = r.columns.clone().collect();
            let both: Vec<usize> = cols.iter().chain(&rc).copied().collect();
            let joint = vis.given(&both, &profiled);
            let cr = joint.view((0, k), (k, rc.len())).into_owned();
            let rr = joint.view((k, k), (rc.len(), rc.len())).into_owned();
            let taken = &cr * invert(&rr) * cr.transpose();
            Rival {
                effect: r.candidate.effect.to_string(),
                bar: vis.bar(rc.len(), bic_threshold),
                left: units(&(&f - &taken)),
                taken: units(&taken),
                extra_params: k.saturating_sub(rc.len()),
            }
        })
        .collect();
    let f = units(&f);
    let bar = vis.bar(k, bic_threshold);
    let outscore = |extra: usize| vis.dispersion * extra as f64 * (vis.n_obs.ln() - 1.0).max(0.0);
    // Along u (k-vector, unit norm): the bar alone, and the size from
    // which no rival makes it ambiguous.
    let along = |u: &DVector<f64>| -> (f64, f64, Vec<String>) {
        let q = |m: &DMatrix<f64>| (u.transpose() * m * u)[(0, 0)].max(f64::MIN_POSITIVE);
        let alone = (bar / q(&f)).sqrt();
        let mut size = alone;
        let mut names = Vec::new();
        for r in &rivals {
            let qualifies = (r.bar / q(&r.taken)).sqrt();
            let beyond = (bar / q(&r.left))
                .sqrt()
                .max((outscore(r.extra_params) / q(&r.left)).sqrt());
            if qualifies < beyond && beyond > alone {
                size = size.max(beyond);
                if !names.contains(&r.effect) {
                    names.push(r.effect.clone());
                }
            }
        }
        (size, alone, names)
    };
    let mut units_of: Vec<&str> = Vec::new();
    for p in &cand.params {
        if !units_of.contains(&p.unit.as_str()) {
            units_of.push(&p.unit);
        }
    }
    units_of
        .into_iter()
        .map(|unit| {
            let idx: Vec<usize> = (0..k).filter(|&i| cand.params[i].unit == unit).collect();
            let block = DMatrix::from_fn(idx.len(), idx.len(), |a, b| f[(idx[a], idx[b])]);
            let eig = block.symmetric_eigen();
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
            let embed = |v: &[(usize, f64)]| {
                let mut u = DVector::zeros(k);
                for &(i, x) in v {
                    u[i] = x;
                }
                u
            };
            let u: Vec<(usize, f64)> = idx.iter().copied().zip(direction.iter().copied()).collect();
            let (size, size_without_rivals, rivals) = along(&embed(&u));
            DetectionThreshold {
                effect: cand.effect.to_string(),
                candidate: cand.name.to_string(),
                quantity: quantity(cand, unit).to_string(),
                unit: unit.to_string(),
                size,
                size_without_rivals,
                rivals,
                params: idx.iter().map(|&i| cand.params[i].name.clone()).collect(),
                direction,
                per_parameter: idx.iter().map(|&i| along(&embed(&[(i, 1.0)])).0).collect(),
            }
        })
        .collect()
}

/// The inverse of a symmetric positive semi-definite matrix through its
/// eigen-decomposition, directions below rounding left at zero.
fn invert(m: &DMatrix<f64>) -> DMatrix<f64> {
    let eig = m.clone().symmetric_eigen();
    let largest = eig.eigenvalues.amax();
    let inv = eig
        .eigenvalues
        .map(|l| if l > largest * 1e-12 { 1.0 / l } else { 0.0 });
    &eig.eigenvectors * DMatrix::from_diagonal(&inv) * eig.eigenvectors.transpose()
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
            let mut notes = Vec::new();
            if !t.rivals.is_empty() {
                notes.push(format!(
                    "from {} up, ambiguous with {}",
                    figure(t.size_without_rivals),
                    t.rivals.join(" and ")
                ));
            }
            if let Some((i, &w)) = worst {
                if t.per_parameter.len() > 1 && w > ALONE_NOTE_FACTOR * t.size {
                    notes.push(format!("{} alone only ≥ {}", t.params[i], figure(w)));
                }
            }
            if !notes.is_empty() {
                s.push_str(&format!(" ({})", notes.join("; ")));
            }
            s
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A multi-parameter effect's hardest parameter is noted ("… alone only
/// ≥ …") when its own threshold exceeds the effect's by more than this:
/// below it the effect's figure already says enough, above it a reader
/// would misjudge what the run sees of that parameter.
const ALONE_NOTE_FACTOR: f64 = 3.0;

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

    /// The library with its columns, and a diagonal information of σ
    /// (signature sizes) `sigma` for every column.
    fn setup(sigma: f64) -> (Vec<Candidate>, DMatrix<f64>) {
        let lib = library();
        let n: usize = lib.iter().map(|c| c.params.len()).sum();
        (lib, DMatrix::identity(n, n) / (sigma * sigma))
    }

    fn columns(lib: &[Candidate]) -> Vec<Column<'_>> {
        let mut at = 0;
        lib.iter()
            .map(|c| {
                let columns = at..at + c.params.len();
                at = columns.end;
                Column {
                    candidate: c,
                    columns,
                }
            })
            .collect()
    }

    fn index(lib: &[Candidate], name: &str) -> usize {
        lib.iter().position(|c| c.name == name).unwrap()
    }

    #[test]
    fn one_parameter_threshold_meets_the_naming_bar() {
        // σ of 0.1 signature sizes (0.1 ms), n = 300, bar 10, no column
        // correlated with another: the expected Δχ² of the threshold,
        // (size/σ)² + 1, is 10 + ln 300.
        let (lib, info) = setup(0.1);
        let cols = columns(&lib);
        let vis = Visibility {
            information: info,
            dispersion: 1.0,
            n_obs: 300.0,
        };
        let delay = index(&lib, "accel_delay");
        let t = thresholds(&cols, delay, &[], &vis, 10.0);
        assert_eq!(t.len(), 1);
        let expect = 0.1 * (10.0 + 300f64.ln() - 1.0).sqrt();
        assert!((t[0].size - expect).abs() < 1e-12, "{}", t[0].size);
        assert_eq!(t[0].size, t[0].size_without_rivals);
        assert!(t[0].rivals.is_empty());
        assert_eq!(t[0].per_parameter, [t[0].size]);
        // Twice the dispersion: √2 times the size.
        let t2 = thresholds(
            &cols,
            delay,
            &[],
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
        // their difference is well determined), every other column
        // independent.
        let (lib, mut info) = setup(1.0);
        let cols = columns(&lib);
        let drift = index(&lib, "bias_drift");
        let (x, y) = (cols[drift].columns.start, cols[drift].columns.start + 1);
        let cov = DMatrix::from_row_slice(2, 2, &[1.0, 0.99, 0.99, 1.0]);
        let inv = cov.try_inverse().unwrap();
        for (a, i) in [x, y].into_iter().enumerate() {
            for (b, j) in [x, y].into_iter().enumerate() {
                info[(i, j)] = inv[(a, b)];
            }
        }
        let vis = Visibility {
            information: info,
            dispersion: 1.0,
            n_obs: 100.0,
        };
        let t = thresholds(&cols, drift, &[], &vis, 10.0);
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
    fn a_rival_that_takes_up_most_of_the_signature_raises_the_threshold() {
        // The delay's column and the along-axis lever arm's x column
        // nearly alike: the lever arm takes up most of a delay.
        let (lib, mut info) = setup(0.1);
        let cols = columns(&lib);
        let delay = index(&lib, "accel_delay");
        let arm = index(&lib, "accel_lever_arm");
        let (d, a) = (cols[delay].columns.start, cols[arm].columns.start);
        info[(d, a)] = 0.95 * info[(d, d)];
        info[(a, d)] = info[(d, a)];
        let vis = Visibility {
            information: info,
            dispersion: 1.0,
            n_obs: 300.0,
        };
        let t = &thresholds(&cols, delay, &[], &vis, 10.0)[0];
        assert_eq!(t.rivals, ["accel_lever_arm"]);
        assert!(t.size > 2.0 * t.size_without_rivals, "{t:?}");
        // With the lever arm named, it is no rival but is profiled out.
        let named = thresholds(&cols, delay, &[arm], &vis, 10.0);
        assert!(named[0].rivals.is_empty());
        let left = 1.0 - 0.95f64.powi(2);
        let expect = t.size_without_rivals / left.sqrt();
        assert!((named[0].size - expect).abs() < 1e-9 * expect, "{named:?}");
    }

    #[test]
    fn figures_keep_three_significant_digits() {
        assert_eq!(figure(0.0101), "0.0101");
        assert_eq!(figure(1.0188), "1.02");
        assert_eq!(figure(112.3), "112");
        assert_eq!(figure(2.5e-6), "2.50e-6");
    }
}
