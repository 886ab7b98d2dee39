//! The driver: the pre-scan, the choice of stretches and τ, one streaming
//! pass of the Allan sums, and a fit per channel.

use std::sync::atomic::{AtomicBool, Ordering};

use super::allan::{cluster_sizes, OverlappingAllan, CHANNELS};
use super::edf::{edf_pooled, NoiseKind};
use super::fit::{fit_terms, CurvePoint, TermFit};
use super::report::{
    AccelCurve, AccelNoise, AllanCurves, Coverage, GyroCurve, GyroNoise, NoiseReport, Span,
    Stretch, Triad,
};
use super::{NoiseError, NoiseOptions};
use crate::calib::prescan::prescan;
use crate::calib::{RecordSource, RunInfo, SegmentKind};
use crate::model::units::{DEG_PER_H, UG};
use crate::record::{Interval, Intervals};

/// How often (records) the cancel flag is read.
const CANCEL_EVERY: u64 = 65_536;

/// The overlapping Allan deviation of every axis over the run's dwells
/// (or the whole run, `opts.span`), and the noise terms fitted to it.
/// Reads `source` twice; holds at most 2·m_max + 1 cumulative sums per
/// channel.
pub fn analyse(
    source: &dyn RecordSource,
    run: &RunInfo,
    opts: &NoiseOptions,
    cancel: &AtomicBool,
) -> Result<NoiseReport, NoiseError> {
    opts.validate()?;
    if !(run.sample_rate_hz.is_finite() && run.sample_rate_hz > 0.0) {
        return Err(NoiseError::Options(format!(
            "sample rate {} Hz",
            run.sample_rate_hz
        )));
    }
    let tau0 = 1.0 / run.sample_rate_hz;
    let scan = prescan(source, run, &opts.detect, cancel)?;
    let mut warnings = Vec::new();
    let windows: Vec<(f64, f64)> = match opts.span {
        Span::Dwells => scan.dwells().map(|d| (d.t_start, d.t_end)).collect(),
        Span::WholeRun => {
            let motions = scan
                .segments
                .iter()
                .filter(|s| s.kind == SegmentKind::Motion)
                .count();
            if motions > 0 {
                warnings.push(format!(
                    "the whole run was analysed but the pre-scan finds {motions} motion(s) in it: \
                     turns raise the curve; analyse the dwells instead"
                ));
            }
            vec![(scan.t_begin, scan.t_end)]
        }
    };
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
    let stretches = accumulate(source, &windows, tau0, &mut acc, cancel)?;
    Ok(report(
        &acc,
        stretches,
        opts.span,
        run.sample_rate_hz,
        warnings,
    ))
}

/// One pass: every record whose interval's middle lies in a window goes to
/// the stretch of that window. Returns the stretches that received
/// records. Each record's interval comes from its stamps (SPEC §2a): its
/// increment is taken as its mean rate times the nominal interval τ0, so
/// that a resting unit's constant rate still cancels in the second
/// differences when the stamps jitter. A gap (inside a dwell: the
/// pre-scan refuses any other) ends the stretch, so no cluster spans time
/// no record covers; a record whose interval the stamps do not give (the
/// first, the one after a gap) is left out, as 10 % of its g·Δt would
/// outweigh the noise.
fn accumulate(
    source: &dyn RecordSource,
    windows: &[(f64, f64)],
    tau0: f64,
    acc: &mut OverlappingAllan,
    cancel: &AtomicBool,
) -> Result<Vec<Stretch>, NoiseError> {
    let mut used: Vec<Stretch> = Vec::new();
    let mut w = 0;
    let mut open: Option<Stretch> = None;
    let mut n = 0u64;
    let mut intervals = Intervals::new(1.0 / tau0);
    for r in source.records()? {
        let r = r?;
        n += 1;
        if n % CANCEL_EVERY == 0 && cancel.load(Ordering::Relaxed) {
            return Err(NoiseError::Cancelled);
        }
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
        if w == windows.len() {
            break;
        }
        if mid < windows[w].0 {
            continue;
        }
        let s = open.get_or_insert(Stretch {
            t_start: r.t - dt,
            t_end: r.t,
            records: 0,
        });
        s.t_end = r.t;
        s.records += 1;
        let to_tau0 = tau0 / dt;
        acc.push(&[
            r.dtheta[0] * to_tau0,
            r.dtheta[1] * to_tau0,
            r.dtheta[2] * to_tau0,
            r.dv[0] * to_tau0,
            r.dv[1] * to_tau0,
            r.dv[2] * to_tau0,
        ]);
    }
    acc.end_stretch();
    used.extend(open.take());
    Ok(used)
}

/// The curves, a fit per channel, and the report in reporting units.
fn report(
    acc: &OverlappingAllan,
    stretches: Vec<Stretch>,
    span: Span,
    sample_rate_hz: f64,
    warnings: Vec<String>,
) -> NoiseReport {
    let tau0 = 1.0 / sample_rate_hz;
    let mut tau_s = Vec::new();
    let mut cluster_records = Vec::new();
    let mut terms = Vec::new();
    let mut points: Vec<Vec<CurvePoint>> = vec![Vec::new(); CHANNELS];
    for (i, &m) in acc.sizes().iter().enumerate() {
        let Some(avar) = acc.variance(i, tau0) else {
            continue;
        };
        let edf = NoiseKind::ALL.map(|k| edf_pooled(k, acc.stretches(), m));
        tau_s.push(m as f64 * tau0);
        cluster_records.push(m as u64);
        terms.push(acc.terms()[i]);
        for (c, p) in points.iter_mut().enumerate() {
            p.push(CurvePoint {
                tau_s: m as f64 * tau0,
                avar: avar[c],
                edf,
            });
        }
    }
    let fits: Vec<TermFit> = points.iter().map(|p| fit_terms(p)).collect();
    let adev = |c: usize, unit: f64| -> Vec<f64> {
        points[c].iter().map(|p| p.avar.sqrt() / unit).collect()
    };
    let curves = AllanCurves {
        gyro: Triad::from_fn(|a| GyroCurve {
            adev_deg_h: adev(a, DEG_PER_H),
            edf: fits[a].edf.clone(),
        }),
        accel: Triad::from_fn(|a| AccelCurve {
            adev_ug: adev(3 + a, UG),
            edf: fits[3 + a].edf.clone(),
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
        seconds_used: records_used as f64 * tau0,
        records_used,
        max_tau_s: curves.tau_s.last().copied().unwrap_or(0.0),
        longest_stretch_s,
        stretches,
    };
    NoiseReport {
        gyro: Triad::from_fn(|a| GyroNoise::from_fit(&fits[a])),
        accel: Triad::from_fn(|a| AccelNoise::from_fit(&fits[3 + a])),
        curves,
        computed_over,
        method: METHOD.into(),
        warnings,
    }
}

const METHOD: &str = "overlapping Allan variance of each axis's rate (gyro) or specific force \
    (accelerometer), pooled over the stretches analysed, at log-spaced tau up to a fraction of the \
    longest (computed_over.max_tau_s); terms from a non-negative least-squares fit of sigma^2(tau) = 3Q^2/tau^2 + N^2/tau \
    + (2 ln2/pi) B^2 + K^2 tau/3 over every tau, iteratively reweighted by the variance of \
    each point (2 sigma^4/edf, edf from NIST SP 1065 for the model's mix of noise kinds); \
    bias instability is B (flicker floor 0.664 B, IEEE Std 952/1293)";
