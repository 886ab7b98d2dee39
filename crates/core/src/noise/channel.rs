//! One axis's curve read against the model: the fit, the bands where the
//! curve departs from it, and which terms those bands spoil.
//!
//! Disturbances add variance (a rocking base, vibration, a periodic
//! signal, a trend all raise σ²(τ), never lower it), so the sensor's own
//! noise lies at or below the measured curve everywhere, and a departure
//! is the curve rising above it. A departure pulls a fit over every point
//! up towards itself (a vehicle's rocking read as white noise and
//! quantization), so when the fit over every point leaves points outside
//! their confidence, the curve's lower envelope is found first (the same
//! fit with points above the model weighted 1000 times less than points
//! below it); the points that agree with the envelope are fitted, and the
//! set grown to every point within or below the fit and fitted again until
//! it settles (eight rounds at most). Fewer than four points agreeing
//! means no band of the curve shows the sensor's own noise: every term not
//! held is then bounded by the curve itself, and the departures are read
//! against the envelope. The terms are then
//! read where the curve follows the model; points below the final model
//! are reported too (a periodic component's dips, or a fit that could not
//! follow the curve). A term whose own band (where it makes half the model
//! or more, or where its bound binds) overlaps a departure or touches one
//! (neighbouring points share data) is marked as spoiled: disturbances add,
//! so the sensor's own term is at most that figure.

use super::covariance::CurveCovariance;
use super::departures::{find_departures, Departure};
use super::fit::{bounds_only, fit_terms, shapes, CurvePoint, Estimate, FitInput, TermFit};

/// Rounds of fitting without the departing points.
const ROUNDS: usize = 8;

/// The fewest points a fit keeps.
const MIN_USED: usize = 4;

/// An axis's reading of its curve.
#[derive(Clone, Debug)]
pub struct ChannelFit {
    pub fit: TermFit,
    pub departures: Vec<Departure>,
    /// Points the final fit used.
    pub used: Vec<bool>,
    /// Per term (Q, N, B, K): the τ band it is read from (resolved, fixed)
    /// or where its bound binds, s.
    pub bands: [[f64; 2]; 4],
    /// Per term: its band overlaps a departure.
    pub spoiled: [bool; 4],
}

/// Fits `points` with `covariance` (the same cluster sizes), Q held at
/// `fixed_quantization` when a quantum was found, and finds where the
/// curve departs from the fit.
///
/// ```
/// use sinscal_core::noise::allan::cluster_sizes;
/// use sinscal_core::noise::channel::read_curve;
/// use sinscal_core::noise::covariance::CurveCovariance;
/// use sinscal_core::noise::fit::{CurvePoint, NoiseTerms};
/// let sizes = cluster_sizes(2_000, 10);
/// let white = NoiseTerms { white: 1e-5, ..NoiseTerms::default() };
/// let points: Vec<CurvePoint> = sizes
///     .iter()
///     .map(|&m| CurvePoint {
///         tau_s: m as f64 * 0.01,
///         cluster_records: m,
///         avar: white.allan_variance(m as f64 * 0.01),
///         edf: [1e3; 4],
///     })
///     .collect();
/// let covariance = CurveCovariance::new(&sizes, &[10_000], 0.01);
/// let read = read_curve(&points, &covariance, None);
/// assert!(read.departures.is_empty());
/// ```
pub fn read_curve(
    points: &[CurvePoint],
    covariance: &CurveCovariance,
    fixed_quantization: Option<f64>,
) -> ChannelFit {
    let fit_over = |used: &[bool], above_weight: f64| {
        let fit = fit_terms(
            points,
            &FitInput {
                covariance,
                fixed_quantization,
                used: Some(used),
                above_weight,
            },
        );
        let (signs, found) = find_departures(
            points,
            &fit.terms,
            &covariance.for_model(fit.terms.powers()),
        );
        (fit, signs, found)
    };
    let all = vec![true; points.len()];
    let reading = fit_over(&all, 1.0);
    if reading.1.iter().all(|s| *s == 0) {
        return finish(points, reading.0, reading.2, all);
    }
    // The lower envelope: where the curve follows it is where the sensor's
    // own noise shows.
    let (envelope, signs, below_envelope) = fit_over(&all, ENVELOPE_ABOVE_WEIGHT);
    let mut used: Vec<bool> = signs.iter().map(|s| *s == 0).collect();
    if used.iter().filter(|u| **u).count() < MIN_USED {
        // No band follows the model: every term is bounded by the curve,
        // and the departures are read against the envelope.
        let mut fit = bounds_only(points, fixed_quantization);
        fit.rms_z = envelope.rms_z;
        return finish(points, fit, below_envelope, vec![false; points.len()]);
    }
    let mut reading = fit_over(&used, 1.0);
    // Grow: the points within or below the model (they hold it down),
    // without those above it.
    for _ in 0..ROUNDS {
        let next: Vec<bool> = reading.1.iter().map(|s| *s <= 0).collect();
        if next == used || next.iter().filter(|u| **u).count() < MIN_USED {
            break;
        }
        used = next;
        reading = fit_over(&used, 1.0);
    }
    finish(points, reading.0, reading.2, used)
}

/// The weight of a point above the model when fitting the curve's lower
/// envelope.
const ENVELOPE_ABOVE_WEIGHT: f64 = 1e-3;

fn finish(
    points: &[CurvePoint],
    fit: TermFit,
    departures: Vec<Departure>,
    used: Vec<bool>,
) -> ChannelFit {
    let bands: [[f64; 2]; 4] = std::array::from_fn(|k| term_band(points, &fit, k));
    // One point's step either side: neighbouring points share data.
    let step = points
        .windows(2)
        .map(|w| w[1].tau_s / w[0].tau_s)
        .fold(1.0, f64::max)
        * 1.001;
    let spoiled = bands.map(|[lo, hi]| {
        departures
            .iter()
            .any(|d| d.tau_s[0] <= hi * step && d.tau_s[1] * step >= lo)
    });
    ChannelFit {
        fit,
        departures,
        used,
        bands,
        spoiled,
    }
}

/// Where term k is read: the points where it makes at least half the
/// model (a value) or where its bound would make at least half the curve;
/// else the one point where it comes nearest.
fn term_band(points: &[CurvePoint], fit: &TermFit, k: usize) -> [f64; 2] {
    let amplitude = match fit.estimates[k] {
        Estimate::Resolved { value, .. } | Estimate::Fixed { value } => value,
        Estimate::Bound { upper } => upper,
    };
    let bound = matches!(fit.estimates[k], Estimate::Bound { .. });
    let share = |p: &CurvePoint| {
        let part = amplitude * amplitude * shapes(p.tau_s)[k];
        let whole = if bound {
            p.avar
        } else {
            fit.terms.allan_variance(p.tau_s)
        };
        if whole > 0.0 {
            part / whole
        } else {
            0.0
        }
    };
    let near: Vec<f64> = points
        .iter()
        .filter(|p| share(p) >= 0.5)
        .map(|p| p.tau_s)
        .collect();
    match (near.first(), near.last()) {
        (Some(&lo), Some(&hi)) => [lo, hi],
        _ => {
            let best = points
                .iter()
                .max_by(|a, b| share(a).total_cmp(&share(b)))
                .map_or(0.0, |p| p.tau_s);
            [best, best]
        }
    }
}
