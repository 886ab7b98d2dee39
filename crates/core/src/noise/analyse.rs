//! The driver: the choice of τ over the stretches the caller found still,
//! one streaming pass of the Allan sums and the quantum detector, and each
//! axis's curve read against the model.

use std::sync::atomic::{AtomicBool, Ordering};

use super::allan::{cluster_sizes, OverlappingAllan, CHANNELS};
use super::channel::read_curve;
use super::covariance::CurveCovariance;
use super::edf::{edf_pooled, NoiseKind};
use super::fit::CurvePoint;
use super::quantum::QuantumDetector;
use super::report::{
    AccelCurve, AccelNoise, AllanCurves, Coverage, GyroCurve, GyroNoise, NoiseReport, Span,
    Stretch, Triad,
};
use super::{NoiseError, NoiseOptions};
use crate::model::units::{DEG_PER_H, UG};
use crate::record::{Interval, Intervals, Record};

/// How often (records) the cancel flag is read.
const CANCEL_EVERY: u64 = 65_536;

/// What to analyse: time windows (s) of the run, each one stretch, from
/// the caller (the dwells its pre-scan found, or the whole of a static
/// run), and what they are.
#[derive(Clone, Debug, PartialEq)]
pub struct Stretches {
    pub span: Span,
    /// (start, end) of each window, ascending and apart; a record belongs
    /// to the window that holds the middle of its interval.
    pub windows: Vec<(f64, f64)>,
}

/// The overlapping Allan deviation of every axis over `stretches` of the
/// records (at `sample_rate_hz` nominal), the pulse quanta every record
/// shows, and the noise terms read from each curve. One pass over
/// `records`; holds at most 2·m_max + 1 cumulative sums per channel.
pub fn analyse(
    records: impl Iterator<Item = Result<Record, NoiseError>>,
    sample_rate_hz: f64,
    stretches: &Stretches,
    opts: &NoiseOptions,
    cancel: &AtomicBool,
) -> Result<NoiseReport, NoiseError> {
    opts.validate()?;
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(NoiseError::Options(format!(
            "sample rate {sample_rate_hz} Hz"
        )));
    }
    let tau0 = 1.0 / sample_rate_hz;
    let windows = &stretches.windows;
    let longest_s = windows.iter().map(|w| w.1 - w.0).fold(0.0, f64::max);
    let longest_records = (longest_s / tau0).round().max(0.0) as usize;
    let m_max = ((opts.max_tau_fraction * longest_records as f64).floor() as usize)
        .min(opts.max_cluster_records);
    let sizes = cluster_sizes(m_max, opts.points_per_decade);
    if sizes.len() < opts.min_points {
        let m_needed = cluster_sizes(usize::MAX / 4, opts.points_per_decade)
            .get(opts.min_points - 1)
            .copied()
            .unwrap_or(1);
        return Err(NoiseError::TooShort {
            longest_s,
            needed_s: m_needed as f64 * tau0 / opts.max_tau_fraction,
        });
    }
    let mut acc = OverlappingAllan::new(sizes);
    let mut quanta = QuantumDetector::default();
    let used = accumulate(records, windows, tau0, &mut acc, &mut quanta, cancel)?;
    Ok(report(&acc, &quanta, used, stretches.span, sample_rate_hz))
}

/// One pass: every record goes to the quantum detector, and every record
/// whose interval's middle lies in a window to the stretch of that window,
/// with its own interval from its stamps (SPEC §2a). Returns the stretches
/// that received records. A gap (inside a dwell: the pre-scan refuses any
/// other) ends the stretch, so no cluster spans time no record covers; a
/// record whose interval the stamps do not give (the first, the one after
/// a gap) is left out of the curves, as 10 % of its g·Δt would outweigh
/// the noise.
fn accumulate(
    records: impl Iterator<Item = Result<Record, NoiseError>>,
    windows: &[(f64, f64)],
    tau0: f64,
    acc: &mut OverlappingAllan,
    quanta: &mut QuantumDetector,
    cancel: &AtomicBool,
) -> Result<Vec<Stretch>, NoiseError> {
    let mut used: Vec<Stretch> = Vec::new();
    let mut w = 0;
    let mut open: Option<Stretch> = None;
    let mut n = 0u64;
    let mut intervals = Intervals::new(1.0 / tau0);
    for r in records {
        let r = r?;
        n += 1;
        if n % CANCEL_EVERY == 0 && cancel.load(Ordering::Relaxed) {
            return Err(NoiseError::Cancelled);
        }
        let inc = [
            r.dtheta[0],
            r.dtheta[1],
            r.dtheta[2],
            r.dv[0],
            r.dv[1],
            r.dv[2],
        ];
        quanta.push(&inc);
        let Interval {
            dt,
            gap,
            from_stamps,
        } = intervals.next(r.t);
        if gap.is_some() && open.is_some() {
            acc.end_stretch();
            used.extend(open.take());
        }
        if !from_stamps {
            continue;
        }
        let mid = r.t - 0.5 * dt;
        while w < windows.len() && mid > windows[w].1 {
            w += 1;
            acc.end_stretch();
            used.extend(open.take());
        }
        if w == windows.len() || mid < windows[w].0 {
            continue;
        }
        let s = open.get_or_insert(Stretch {
            t_start: r.t - dt,
            t_end: r.t,
            records: 0,
        });
        s.t_end = r.t;
        s.records += 1;
        acc.push(dt, &inc);
    }
    acc.end_stretch();
    used.extend(open.take());
    Ok(used)
}

/// The curves, each axis's reading, and the report in reporting units.
fn report(
    acc: &OverlappingAllan,
    quanta: &QuantumDetector,
    stretches: Vec<Stretch>,
    span: Span,
    sample_rate_hz: f64,
) -> NoiseReport {
    let tau0 = 1.0 / sample_rate_hz;
    let mut tau_s = Vec::new();
    let mut cluster_records = Vec::new();
    let mut terms = Vec::new();
    let mut points: Vec<Vec<CurvePoint>> = vec![Vec::new(); CHANNELS];
    for (i, &m) in acc.sizes().iter().enumerate() {
        let Some(avar) = acc.variance(i) else {
            continue;
        };
        let edf = NoiseKind::ALL.map(|k| edf_pooled(k, acc.stretches(), m));
        tau_s.push(m as f64 * tau0);
        cluster_records.push(m as u64);
        terms.push(acc.terms()[i]);
        for (c, p) in points.iter_mut().enumerate() {
            p.push(CurvePoint {
                tau_s: m as f64 * tau0,
                cluster_records: m,
                avar: avar[c],
                edf,
            });
        }
    }
    let sizes: Vec<usize> = cluster_records.iter().map(|&m| m as usize).collect();
    let covariance = CurveCovariance::new(&sizes, acc.stretches(), tau0);
    let found = quanta.quanta();
    let reads: Vec<_> = points
        .iter()
        .zip(found)
        .map(|(p, q)| read_curve(p, &covariance, q.map(|q| q / 12f64.sqrt())))
        .collect();
    let covered = [
        tau_s.first().copied().unwrap_or(0.0),
        tau_s.last().copied().unwrap_or(0.0),
    ];
    let adev = |c: usize, unit: f64| -> Vec<f64> {
        points[c].iter().map(|p| p.avar.sqrt() / unit).collect()
    };
    let curves = AllanCurves {
        gyro: Triad::from_fn(|a| GyroCurve {
            adev_deg_h: adev(a, DEG_PER_H),
            edf: reads[a].fit.edf.clone(),
        }),
        accel: Triad::from_fn(|a| AccelCurve {
            adev_ug: adev(3 + a, UG),
            edf: reads[3 + a].fit.edf.clone(),
        }),
        tau_s,
        cluster_records,
        terms,
    };
    let records_used: u64 = stretches.iter().map(|s| s.records).sum();
    let longest_stretch_s = stretches
        .iter()
        .map(|s| s.t_end - s.t_start)
        .fold(0.0, f64::max);
    let computed_over = Coverage {
        span,
        sample_rate_hz,
        seconds_used: stretches.iter().map(|s| s.t_end - s.t_start).sum(),
        records_used,
        max_tau_s: curves.tau_s.last().copied().unwrap_or(0.0),
        longest_stretch_s,
        stretches,
    };
    let gyro = Triad::from_fn(|a| GyroNoise::from_channel(&reads[a], found[a], covered));
    let accel = Triad::from_fn(|a| AccelNoise::from_channel(&reads[3 + a], found[3 + a], covered));
    let mut warnings = Vec::new();
    for (sensor, deps) in gyro
        .iter()
        .map(|(axis, g)| (format!("gyro {axis}"), &g.departures))
        .chain(
            accel
                .iter()
                .map(|(axis, a)| (format!("accel {axis}"), &a.departures)),
        )
    {
        for d in deps {
            warnings.push(format!("{sensor}: {}", d.text));
        }
    }
    NoiseReport {
        gyro,
        accel,
        curves,
        computed_over,
        method: METHOD.into(),
        warnings,
    }
}

const METHOD: &str = "overlapping Allan variance of each axis's rate (gyro) or specific force \
    (accelerometer), each cluster's mean over its own records' intervals, pooled over the stretches \
    analysed, at log-spaced tau up to a fraction of the longest (computed_over.max_tau_s); terms \
    from a non-negative least-squares fit of sigma^2(tau) = 3Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 \
    + K^2 tau/3, iteratively reweighted by the variance of each point (2 sigma^4/edf, edf from \
    NIST SP 1065 for the model's mix of noise kinds); where every record of an axis is a whole \
    number of one quantum q (found exactly from the data), Q is held at q/sqrt(12) and not \
    fitted; sigma of each term from the covariance of the whole curve under the fitted model \
    (closed form, correlated points) through the fit; a term is resolved when its power is at \
    least 3 sigma, else reported as a one-sided 95 % upper bound; points outside the model's \
    chi-square interval at 1e-4 are departures, left out of the fit and named with their band; \
    bias instability is B (flicker floor 0.664 B, IEEE Std 952/1293)";
