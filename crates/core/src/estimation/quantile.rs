//! Upper quantiles of the normal and χ² distributions: the thresholds of
//! the model check and of the thermal model's check.

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

#[cfg(test)]
mod tests {
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
}
