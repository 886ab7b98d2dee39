//! Finding the dwells and the motions of a run from its own data.
//!
//! Short blocks of records are classed as still or moving from the mean
//! angular rate and the specific-force magnitude; runs of still blocks
//! long enough to be a dwell become static segments, shrunk by a guard at
//! both ends so that settling after a turn or a manual flip is never taken
//! for rest. Nothing here relies on the scheme the run claims: a turntable
//! whose axes miss the unit's centre, or a unit turned by hand, is found
//! the same way.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::nav::attitude::{dcm_to_rotvec, rotvec_to_dcm};
use crate::record::Record;

/// Thresholds of the still/moving classification.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectOptions {
    /// Block length over which rates are averaged, s.
    pub block_s: f64,
    /// A block whose mean angular rate exceeds this is moving, deg/s
    /// (Earth rate is 0.004 deg/s).
    pub rate_threshold_dps: f64,
    /// A block whose mean specific-force magnitude differs from the local
    /// gravity by more than this is moving, m/s².
    pub force_threshold_mps2: f64,
    /// Shortest still stretch taken as a dwell, s.
    pub min_dwell_s: f64,
    /// Time cut from each end of a still stretch, s.
    pub guard_s: f64,
}

impl Default for DetectOptions {
    fn default() -> Self {
        DetectOptions {
            block_s: 0.1,
            rate_threshold_dps: 0.05,
            force_threshold_mps2: 0.05,
            min_dwell_s: 20.0,
            guard_s: 0.5,
        }
    }
}

/// What the unit does during a segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SegmentKind {
    Dwell,
    Motion,
}

/// A stretch of the run, with the statistics the estimators need.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSegment {
    pub kind: SegmentKind,
    /// Start and end of the segment (interval edges of its first and last
    /// records), s.
    pub t_start: f64,
    pub t_end: f64,
    /// Mean angular rate and specific force in body axes (raw data).
    pub mean_omega_b: [f64; 3],
    pub mean_f_b: [f64; 3],
    /// For a motion: the net rotation vector in body axes at its start
    /// (from the raw increments), rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation_b: Option<[f64; 3]>,
    /// For a motion: largest block-mean rate, deg/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peak_rate_dps: Option<f64>,
}

/// Sums over one block or one stretch of same-class blocks.
#[derive(Clone, Copy)]
struct Stretch {
    still: bool,
    t_start: f64,
    t_end: f64,
    n: usize,
    sum_dtheta: Vector3<f64>,
    sum_dv: Vector3<f64>,
    /// Net rotation (body at start to body at end). Within a block the
    /// turn is at most a degree about a steady axis, so exp(ΣΔθ) is exact
    /// to far below the reporting precision.
    c_rot: Matrix3<f64>,
    peak_rate: f64,
}

impl Stretch {
    fn empty() -> Self {
        Stretch {
            still: true,
            t_start: 0.0,
            t_end: 0.0,
            n: 0,
            sum_dtheta: Vector3::zeros(),
            sum_dv: Vector3::zeros(),
            c_rot: Matrix3::identity(),
            peak_rate: 0.0,
        }
    }

    fn absorb(&mut self, other: &Stretch) {
        self.t_end = other.t_end;
        self.n += other.n;
        self.sum_dtheta += other.sum_dtheta;
        self.sum_dv += other.sum_dv;
        self.c_rot *= other.c_rot;
        self.peak_rate = self.peak_rate.max(other.peak_rate);
    }
}

/// Online segmentation: feed records in order, then [`Segmenter::finish`].
/// Memory grows with the number of still/moving alternations, not with
/// the number of records.
pub struct Segmenter {
    opts: DetectOptions,
    dt: f64,
    gravity: f64,
    block_len: usize,
    block: Stretch,
    stretches: Vec<Stretch>,
}

impl Segmenter {
    pub fn new(opts: DetectOptions, sample_rate_hz: f64, gravity: f64) -> Self {
        Segmenter {
            opts,
            dt: 1.0 / sample_rate_hz,
            gravity,
            block_len: ((opts.block_s * sample_rate_hz).round() as usize).max(1),
            block: Stretch::empty(),
            stretches: Vec::new(),
        }
    }

    pub fn push(&mut self, r: &Record) {
        let b = &mut self.block;
        if b.n == 0 {
            b.t_start = r.t - self.dt;
        }
        b.t_end = r.t;
        b.n += 1;
        b.sum_dtheta += Vector3::from(r.dtheta);
        b.sum_dv += Vector3::from(r.dv);
        if b.n == self.block_len {
            self.close_block();
        }
    }

    fn close_block(&mut self) {
        let mut b = std::mem::replace(&mut self.block, Stretch::empty());
        if b.n == 0 {
            return;
        }
        let span = b.n as f64 * self.dt;
        let rate = (b.sum_dtheta / span).norm();
        let force = (b.sum_dv / span).norm();
        b.still = rate < self.opts.rate_threshold_dps.to_radians()
            && (force - self.gravity).abs() < self.opts.force_threshold_mps2;
        b.c_rot = rotvec_to_dcm(&b.sum_dtheta);
        b.peak_rate = rate;
        match self.stretches.last_mut() {
            Some(s) if s.still == b.still => s.absorb(&b),
            _ => self.stretches.push(b),
        }
    }

    /// The segments: dwells (still stretches of at least `min_dwell_s`,
    /// less the guards) and the motions between them, in time order and
    /// covering the run without gaps.
    pub fn finish(mut self) -> Vec<RunSegment> {
        self.close_block();
        let mut merged: Vec<Stretch> = Vec::new();
        for s in &self.stretches {
            let mut s = *s;
            s.still = s.still && s.t_end - s.t_start >= self.opts.min_dwell_s;
            match merged.last_mut() {
                // A still stretch too short for a dwell joins the motion
                // around it.
                Some(m) if !s.still && !m.still => m.absorb(&s),
                _ => merged.push(s),
            }
        }
        let n = merged.len();
        let mut out: Vec<RunSegment> = merged
            .iter()
            .map(|s| {
                let span = s.n as f64 * self.dt;
                let moving = !s.still;
                RunSegment {
                    kind: if moving {
                        SegmentKind::Motion
                    } else {
                        SegmentKind::Dwell
                    },
                    t_start: s.t_start,
                    t_end: s.t_end,
                    mean_omega_b: (s.sum_dtheta / span).into(),
                    mean_f_b: (s.sum_dv / span).into(),
                    rotation_b: moving.then(|| dcm_to_rotvec(&s.c_rot).into()),
                    peak_rate_dps: moving.then(|| s.peak_rate.to_degrees()),
                }
            })
            .collect();
        // Guards: a dwell gives its edges next to a motion to that motion.
        let g = self.opts.guard_s;
        for i in 0..n {
            if out[i].kind != SegmentKind::Dwell {
                continue;
            }
            if i > 0 {
                out[i].t_start += g;
                out[i - 1].t_end = out[i].t_start;
            }
            if i + 1 < n {
                out[i].t_end -= g;
                out[i + 1].t_start = out[i].t_end;
            }
        }
        out
    }
}

/// Whether time `t` lies inside a dwell of `segments` (sorted).
pub fn in_dwell(segments: &[RunSegment], t: f64) -> bool {
    let i = segments.partition_point(|s| s.t_end < t);
    segments
        .get(i)
        .is_some_and(|s| s.kind == SegmentKind::Dwell && s.t_start <= t && t <= s.t_end)
}
