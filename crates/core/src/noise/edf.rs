//! Equivalent degrees of freedom of the overlapping Allan variance: how
//! far one σ̂²(τ) can be trusted. σ̂² is distributed as σ² χ²_ν / ν, so its
//! variance is 2σ⁴/ν; ν depends on the cluster size, the stretch length and
//! the kind of noise (NIST SP 1065 §5.3, Table 12, the "simple
//! approximate" formulas, accurate to a few per cent).

/// The noise kinds the fit separates, by their Allan variance slope.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseKind {
    /// White phase (angle or velocity quantization): σ² ∝ τ⁻².
    WhitePhase,
    /// White rate (angle or velocity random walk): σ² ∝ τ⁻¹.
    WhiteRate,
    /// Flicker rate (bias instability): σ² flat.
    FlickerRate,
    /// Random-walk rate (rate or acceleration random walk): σ² ∝ τ.
    RandomWalkRate,
}

impl NoiseKind {
    pub const ALL: [NoiseKind; 4] = [
        NoiseKind::WhitePhase,
        NoiseKind::WhiteRate,
        NoiseKind::FlickerRate,
        NoiseKind::RandomWalkRate,
    ];
}

/// ν over one stretch of `records` records (records + 1 cumulative sums,
/// SP 1065's N) at cluster size `m`; 0 when the stretch holds no term.
/// Bounded to [1, terms]: the approximations leave that range only for
/// stretches a few clusters long.
pub fn edf_stretch(kind: NoiseKind, records: u64, m: usize) -> f64 {
    let n = records as f64 + 1.0;
    let m = m as f64;
    let terms = n - 2.0 * m;
    if terms < 1.0 {
        return 0.0;
    }
    let nu = match kind {
        NoiseKind::WhitePhase => (n + 1.0) * (n - 2.0 * m) / (2.0 * (n - m)),
        NoiseKind::WhiteRate => {
            (3.0 * (n - 1.0) / (2.0 * m) - 2.0 * (n - 2.0) / n) * 4.0 * m * m / (4.0 * m * m + 5.0)
        }
        NoiseKind::FlickerRate if m == 1.0 => 2.0 * (n - 2.0).powi(2) / (2.3 * n - 4.9),
        NoiseKind::FlickerRate => 5.0 * n * n / (4.0 * m * (n + 3.0 * m)),
        NoiseKind::RandomWalkRate => {
            (n - 2.0) / m * ((n - 1.0).powi(2) - 3.0 * m * (n - 1.0) + 4.0 * m * m)
                / (n - 3.0).powi(2)
        }
    };
    if nu.is_finite() {
        nu.clamp(1.0, terms)
    } else {
        1.0
    }
}

/// ν of the pooled estimate over several stretches: the pooled σ̂² is the
/// terms-weighted mean of the stretches' own (independent) estimates, so
/// its variance is Σ w_d² 2σ⁴/ν_d with w_d = terms_d / Σ terms.
pub fn edf_pooled(kind: NoiseKind, stretches: &[u64], m: usize) -> f64 {
    let (mut total, mut inverse) = (0.0, 0.0);
    for &records in stretches {
        let terms = records as f64 + 1.0 - 2.0 * m as f64;
        if terms < 1.0 {
            continue;
        }
        total += terms;
        inverse += terms * terms / edf_stretch(kind, records, m);
    }
    if total > 0.0 {
        total * total / inverse
    } else {
        0.0
    }
}

/// ν of σ̂² when several independent kinds add up, the kind i making the
/// share f_i of σ² and alone having ν_i: the standard deviation of a sum
/// of quadratic forms is at most the sum of their standard deviations
/// (Cauchy–Schwarz on the cross terms), sd ≤ σ² Σ f_i √(2/ν_i), equality
/// when one kind dominates. So ν = (Σ f_i/√ν_i)⁻², the conservative value.
pub fn edf_mixed(shares: &[f64], edf: &[f64]) -> f64 {
    let s: f64 = shares
        .iter()
        .zip(edf)
        .filter(|(f, nu)| **f > 0.0 && **nu > 0.0)
        .map(|(f, nu)| f / nu.sqrt())
        .sum();
    if s > 0.0 {
        1.0 / (s * s)
    } else {
        edf.iter().copied().fold(f64::INFINITY, f64::min).max(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White rate noise over a long stretch at m = 1: ν ≈ (2/3)·N (the
    /// overlapping terms are correlated); pooling two equal stretches
    /// doubles ν; a kind alone keeps its own ν in a mixture.
    #[test]
    fn degrees_of_freedom_behave_as_expected() {
        let one = edf_stretch(NoiseKind::WhiteRate, 100_000, 1);
        assert!((one / 100_000.0 - 2.0 / 3.0).abs() < 1e-3, "{one}");
        let two = edf_pooled(NoiseKind::WhiteRate, &[100_000, 100_000], 10);
        let single = edf_stretch(NoiseKind::WhiteRate, 100_000, 10);
        assert!((two / single - 2.0).abs() < 1e-9);
        assert_eq!(edf_pooled(NoiseKind::WhiteRate, &[10], 6), 0.0);
        assert!((edf_mixed(&[1.0, 0.0], &[40.0, 3.0]) - 40.0).abs() < 1e-9);
        // Random-walk rate at the longest clusters: a handful.
        let rw = edf_stretch(NoiseKind::RandomWalkRate, 60_000, 12_000);
        assert!((2.0..4.0).contains(&rw), "{rw}");
    }
}
