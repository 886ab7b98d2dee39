//! The pre-scan every calibration starts from: one streaming read that
//! segments the run into dwells and rotations and measures the noise, and
//! the questions later passes ask of it (which dwell holds a time, where
//! the run's first rest is).

use std::sync::atomic::{AtomicBool, Ordering};

use super::error::CalibError;
use super::gaps::{bridge_gaps, BridgedGap};
use super::options::EstimateOptions;
use super::run::{RecordSource, RunInfo};
use super::segment::{DetectOptions, RunSegment, SegmentKind, Segmenter, StartActivity};
use crate::record::{StepBounds, StepKind};

/// What the pre-scan learns about a run.
#[derive(Clone, Debug)]
pub struct Prescan {
    pub segments: Vec<RunSegment>,
    pub n_records: u64,
    /// Start of the first record's interval.
    pub t_begin: f64,
    pub t_end: f64,
    /// Measured noise, rad/√s and m/s/√s.
    pub arw: f64,
    pub vrw: f64,
    /// The run's first seconds, summarised.
    pub start: StartActivity,
    /// The gaps in the time stamps (SPEC §2a), each inside a dwell and
    /// bridged by every pass (`gaps`); a run with any other is refused.
    pub gaps: Vec<BridgedGap>,
}

impl Prescan {
    /// The run's length from the start of its first record's interval to
    /// its last record, s.
    pub fn duration_s(&self) -> f64 {
        self.t_end - self.t_begin
    }

    pub fn dwells(&self) -> impl Iterator<Item = &RunSegment> {
        self.segments
            .iter()
            .filter(|s| s.kind == SegmentKind::Dwell)
    }
}

/// One streaming read: the segmentation, the noise from the still blocks
/// the segmentation found (one still decision for both), and the gaps in
/// the time stamps. A step shorter than the tolerance (a source no reader
/// checked) refuses the run, as does a gap anywhere but inside a dwell
/// (`gaps::bridge_gaps`).
pub fn prescan(
    source: &dyn RecordSource,
    run: &RunInfo,
    detect: &DetectOptions,
    cancel: &AtomicBool,
) -> Result<Prescan, CalibError> {
    let dt = 1.0 / run.sample_rate_hz;
    let steps = StepBounds::new(dt);
    let mut seg = Segmenter::new(*detect, run.sample_rate_hz, run.site.gravity());
    let (mut n, mut t_begin, mut t_end) = (0u64, f64::NAN, f64::NAN);
    for r in source.records()? {
        let r = r?;
        if n == 0 {
            t_begin = r.t - dt;
        } else if steps.kind(r.t - t_end) == StepKind::TooShort {
            return Err(CalibError::Unusable(format!(
                "record {}: time {} s follows {} s, a step more than {} % shorter than the \
                 nominal {} s",
                n + 1,
                r.t,
                t_end,
                crate::record::STEP_TOLERANCE * 100.0,
                dt
            )));
        }
        t_end = r.t;
        n += 1;
        if n % 65_536 == 0 && cancel.load(Ordering::Relaxed) {
            return Err(CalibError::Cancelled);
        }
        seg.push(&r);
    }
    if n == 0 {
        return Err(CalibError::Unusable("the run holds no records".into()));
    }
    let found = seg.finish();
    let gaps = bridge_gaps(&found.segments, &found.gaps)?;
    Ok(Prescan {
        segments: found.segments,
        n_records: n,
        t_begin,
        t_end,
        arw: found.noise.arw,
        vrw: found.noise.vrw,
        start: found.start,
        gaps,
    })
}

/// The scan every calibration starts from, after checking the rate.
pub(crate) fn scan_run(
    source: &dyn RecordSource,
    run: &RunInfo,
    opts: &EstimateOptions,
    cancel: &AtomicBool,
) -> Result<Prescan, CalibError> {
    if !(run.sample_rate_hz.is_finite() && run.sample_rate_hz > 0.0) {
        return Err(CalibError::Unusable(format!(
            "sample rate {} Hz",
            run.sample_rate_hz
        )));
    }
    prescan(source, run, &opts.detect, cancel)
}

/// Index of the dwell holding time t, if any.
pub(crate) fn dwell_at(segments: &[RunSegment], t: f64) -> Option<usize> {
    let i = segments.partition_point(|s| s.t_end < t);
    segments
        .get(i)
        .filter(|s| s.kind == SegmentKind::Dwell && s.t_start <= t && t <= s.t_end)
        .map(|_| i)
}

/// The first segment, which must be a dwell: the run is aligned on it.
pub(crate) fn first_dwell(scan: &Prescan) -> Result<&RunSegment, CalibError> {
    let first = scan
        .segments
        .first()
        .ok_or_else(|| CalibError::Unusable("no segments".into()))?;
    if first.kind == SegmentKind::Dwell {
        return Ok(first);
    }
    let s = &scan.start;
    let later = match scan.dwells().next() {
        Some(d) => format!(
            "the first still stretch long enough to align on runs from t = {:.2} s to {:.2} s",
            d.t_start, d.t_end
        ),
        None => "no still stretch long enough to align on was found anywhere".into(),
    };
    Err(CalibError::Unusable(format!(
        "the run must begin at rest: over its first {:.1} s ({:.2} s blocks) the angular rate \
         is {:.3} deg/s (spread {:.3}) and |f| is {:.4} m/s² (spread {:.4}); {later}",
        s.span_s,
        s.block_s,
        s.rate_mean_dps,
        s.rate_spread_dps,
        s.force_mean_mps2,
        s.force_spread_mps2,
    )))
}
