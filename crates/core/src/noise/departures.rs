//! Where a curve departs from the Q/N/B/K model beyond its confidence, and
//! what the shape of the departure suggests.
//!
//! Each point's σ̂² is σ² χ²_ν/ν under the model, ν = 2σ⁴/Var(σ̂²) from the
//! curve's covariance at the fitted model ([`super::covariance`]). A point
//! departs when σ̂² lies outside the model's two-sided interval at
//! [`FALSE_ALARM`] (about 3.9σ in the normal's terms); departing points
//! next to each other (or one point apart) make one band. Neighbouring
//! points share data, so a real departure spans several of them, and a
//! clean curve of 40 points raises a band about once in a few hundred
//! axes (`cargo bench --bench noise` counts them).
//!
//! The cause is read from the band's place and shape:
//!
//! - above the model, most at the shortest τ: a disturbance faster than
//!   the band's end (vibration, the base moving: a vehicle rocking);
//! - above it, most between the shortest and longest τ: a bump, a periodic
//!   component or a disturbance at that time scale (the Allan variance of a
//!   sinusoid of period P peaks at τ ≈ 0.37 P and falls as τ⁻² beyond, with
//!   dips at whole periods);
//! - above it, most at the longest τ: a trend or a step in the rate, or a
//!   slow wander the four terms do not hold;
//! - below it: the dips of a periodic component, or a disturbance the fit
//!   has spread over neighbouring τ.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::fit::{chi2_quantile, CurvePoint, NoiseTerms};

/// The two-sided probability of a point of a clean curve departing.
pub const FALSE_ALARM: f64 = 1e-4;

/// The standard normal quantile of 1 − FALSE_ALARM/2.
const Z: f64 = 3.890_591;

/// Where the curve lies against the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    Above,
    Below,
}

/// The likely cause, from the band's place and shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    /// Above the model, most at the shortest τ.
    FastDisturbance,
    /// Above the model, most between the shortest and the longest τ.
    Bump,
    /// Above the model, most at the longest τ.
    Trend,
    /// Above the model over the whole curve, most in between.
    Everywhere,
    /// Below the model.
    Dip,
}

/// One band of τ where the curve departs from the model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Departure {
    /// The band's first and last τ, s.
    pub tau_s: [f64; 2],
    /// The τ where the curve is farthest from the model, s.
    pub peak_tau_s: f64,
    /// Measured over model Allan deviation there.
    pub ratio: f64,
    pub direction: Direction,
    pub cause: Cause,
    /// The band, the departure and its likely cause, in words.
    pub text: String,
}

/// Each point's departure from `model`: 1 above it, −1 below, 0 within
/// its confidence; and the bands they make.
pub fn find_departures(
    points: &[CurvePoint],
    model: &NoiseTerms,
    covariance: &DMatrix<f64>,
) -> (Vec<i8>, Vec<Departure>) {
    let n = points.len();
    let mut flags = vec![false; n];
    let mut sign = vec![0i8; n];
    for (i, p) in points.iter().enumerate() {
        let m = model.allan_variance(p.tau_s);
        let var = covariance[(i, i)];
        if !(m > 0.0 && var > 0.0) {
            flags[i] = p.avar > 0.0 && m <= 0.0;
            sign[i] = 1;
            continue;
        }
        let nu = 2.0 * m * m / var;
        let (lo, hi) = (chi2_quantile(nu, -Z) / nu, chi2_quantile(nu, Z) / nu);
        let r = p.avar / m;
        if r > hi || r < lo {
            flags[i] = true;
            sign[i] = if r > 1.0 { 1 } else { -1 };
        }
    }
    // One clean point between two departing ones does not split a band.
    for i in 1..n.saturating_sub(1) {
        if !flags[i] && flags[i - 1] && flags[i + 1] && sign[i - 1] == sign[i + 1] {
            flags[i] = true;
            sign[i] = sign[i - 1];
        }
    }
    let mut bands = Vec::new();
    let mut i = 0;
    while i < n {
        if !flags[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && flags[i] && sign[i] == sign[start] {
            i += 1;
        }
        bands.push(describe(points, model, start, i - 1, n));
    }
    let signs = flags
        .iter()
        .zip(&sign)
        .map(|(f, s)| if *f { *s } else { 0 })
        .collect();
    (signs, bands)
}

fn describe(
    points: &[CurvePoint],
    model: &NoiseTerms,
    first: usize,
    last: usize,
    n: usize,
) -> Departure {
    let ratio_at = |k: usize| {
        let m = model.allan_variance(points[k].tau_s);
        if m > 0.0 {
            (points[k].avar / m).sqrt()
        } else {
            f64::INFINITY
        }
    };
    let above = ratio_at(first) >= 1.0;
    let peak = (first..=last)
        .max_by(|&a, &b| {
            let (ra, rb) = (ratio_at(a), ratio_at(b));
            if above {
                ra.total_cmp(&rb)
            } else {
                rb.total_cmp(&ra)
            }
        })
        .unwrap_or(first);
    let (lo, hi) = (points[first].tau_s, points[last].tau_s);
    let peak_tau = points[peak].tau_s;
    let ratio = ratio_at(peak);
    // Read from where the excess is largest: at the shortest τ, at the
    // longest, or in between (a bump, however far its tail reaches).
    let cause = if !above {
        Cause::Dip
    } else if first == 0 && last + 1 == n && peak != 0 && peak != last {
        Cause::Everywhere
    } else if peak == 0 {
        Cause::FastDisturbance
    } else if peak + 1 == n {
        Cause::Trend
    } else {
        Cause::Bump
    };
    let band = format!(
        "tau {}–{} s (largest at {} s, {:.1}× the model's Allan deviation)",
        sig(lo),
        sig(hi),
        sig(peak_tau),
        ratio
    );
    let text = match cause {
        Cause::FastDisturbance => format!(
            "above the noise model at {band}: a disturbance faster than about {} s — \
             vibration, or the base moving (a vehicle rocking)",
            sig(hi)
        ),
        Cause::Bump => format!(
            "a bump above the noise model at {band}: a periodic component of period near {} s, \
             or a disturbance at that time scale (a vehicle rocking, floor vibration)",
            sig(peak_tau / 0.371)
        ),
        Cause::Trend => format!(
            "rises above the noise model at {band}: a trend or a step in the rate, or a slow \
             wander the four terms do not hold (temperature, a slow motion of the base)"
        ),
        Cause::Everywhere => format!(
            "the whole curve departs from the noise model ({band}): the base was moving all \
             along (a vehicle rocking, vibration), or the noise is not of these kinds"
        ),
        Cause::Dip => format!(
            "below the noise model at {band}: the dips of a periodic component (its Allan \
             variance vanishes at whole periods), or a disturbance the fit spread over \
             neighbouring tau"
        ),
    };
    Departure {
        tau_s: [lo, hi],
        peak_tau_s: peak_tau,
        ratio,
        direction: if above {
            Direction::Above
        } else {
            Direction::Below
        },
        cause,
        text,
    }
}

/// Three significant figures.
pub(crate) fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}
