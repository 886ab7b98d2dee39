//! Finding the dwells and the motions of a run from its own data.
//!
//! Short blocks of records are classed as still or moving from the
//! *stillness* of the signals, not from their size: an uncalibrated unit
//! does not read g at rest (a few mg of bias, 1 % of scale factor and
//! quadratic terms move |f| by tenths of a m/s²), but whatever it reads at
//! rest it reads steadily. A block is still when its mean specific force
//! agrees with the still stretch it would extend, its mean angular rate is
//! as small as a resting unit's (Earth rate plus a bias, whatever the
//! calibration), and |f| is loosely gravity-sized. Runs of still blocks
//! long enough to be a dwell become static segments, shrunk by a guard at
//! both ends so that settling after a turn or a manual flip is never taken
//! for rest. The same block decision picks the records the noise is
//! measured on. Nothing here relies on the scheme the run claims: a
//! turntable whose axes miss the unit's centre, or a unit turned by hand,
//! is found the same way.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::nav::attitude::{dcm_to_rotvec, rotvec_to_dcm};
use crate::record::{Gap, Interval, Intervals, Record};

pub use super::detect_options::DetectOptions;

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
    /// Time its records cover, s (a gap's missing time left out).
    duration: f64,
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
            duration: 0.0,
            sum_dtheta: Vector3::zeros(),
            sum_dv: Vector3::zeros(),
            c_rot: Matrix3::identity(),
            peak_rate: 0.0,
        }
    }

    fn absorb(&mut self, other: &Stretch) {
        self.t_end = other.t_end;
        self.n += other.n;
        self.duration += other.duration;
        self.sum_dtheta += other.sum_dtheta;
        self.sum_dv += other.sum_dv;
        self.c_rot *= other.c_rot;
        self.peak_rate = self.peak_rate.max(other.peak_rate);
    }
}

/// Sums of squared first differences of the record mean rates, from which
/// the white-noise densities follow: at rest the true rates are constant,
/// so a difference is two draws of the noise, of variance q (1/Δt_k +
/// 1/Δt_{k−1}) per axis for density q. Rates, not increments: with jittered
/// stamps a resting accelerometer's increments differ by g·(Δt_k − Δt_{k−1}),
/// thousands of times its noise.
#[derive(Clone, Copy, Default)]
struct DiffSums {
    d2_theta: f64,
    d2_v: f64,
    /// Σ (1/Δt_k + 1/Δt_{k−1}), 1/s.
    weight: f64,
    n: usize,
}

impl DiffSums {
    /// The white-noise density per axis of a sum of squared differences
    /// (`d2_theta` or `d2_v`): E|Δ(rate noise)|² = 3 q² (1/Δt_k + 1/Δt_{k−1})
    /// per difference; zero without differences.
    fn density(&self, d2: f64) -> f64 {
        if self.n > 0 {
            (d2 / (3.0 * self.weight)).sqrt()
        } else {
            0.0
        }
    }

    fn add(&mut self, other: &DiffSums) {
        self.d2_theta += other.d2_theta;
        self.d2_v += other.d2_v;
        self.weight += other.weight;
        self.n += other.n;
    }
}

/// A record's mean rate and specific force, and 1/Δt.
#[derive(Clone, Copy)]
struct MeanRates {
    omega_b: Vector3<f64>,
    f_b: Vector3<f64>,
    per_s: f64,
}

/// Mean and spread of a quantity over blocks.
#[derive(Clone, Copy, Default)]
struct Moments {
    n: usize,
    sum: f64,
    sum2: f64,
}

impl Moments {
    fn add(&mut self, x: f64) {
        self.n += 1;
        self.sum += x;
        self.sum2 += x * x;
    }

    fn mean_spread(&self) -> (f64, f64) {
        let n = self.n.max(1) as f64;
        let mean = self.sum / n;
        (mean, (self.sum2 / n - mean * mean).max(0.0).sqrt())
    }
}

/// What the unit did over the run's first seconds: the mean and the
/// spread over blocks of the block-mean rate and specific force, so that a
/// run refused for not starting at rest says what was seen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StartActivity {
    /// Span summarised, s.
    pub span_s: f64,
    /// Block length the means are taken over, s.
    pub block_s: f64,
    pub rate_mean_dps: f64,
    pub rate_spread_dps: f64,
    pub force_mean_mps2: f64,
    pub force_spread_mps2: f64,
}

/// Noise densities measured over the still blocks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredNoise {
    /// Angle random walk, rad/√s.
    pub arw: f64,
    /// Velocity random walk, m/s/√s.
    pub vrw: f64,
    /// Record differences it rests on (0: no still block).
    pub n_differences: usize,
}

/// What a segmentation finds.
#[derive(Clone, Debug)]
pub struct Segmentation {
    pub segments: Vec<RunSegment>,
    pub noise: MeasuredNoise,
    pub start: StartActivity,
    /// Gaps in the time stamps, in time order.
    pub gaps: Vec<Gap>,
}

/// Online segmentation: feed records in order, then [`Segmenter::finish`].
/// Each record's interval comes from its stamp ([`Intervals`]); memory
/// grows with the number of still/moving alternations and of gaps, not
/// with the number of records.
pub struct Segmenter {
    opts: DetectOptions,
    /// The nominal step, s.
    dt: f64,
    intervals: Intervals,
    gaps: Vec<Gap>,
    gravity: f64,
    block_len: usize,
    block: Stretch,
    block_diffs: DiffSums,
    /// The previous record's rates, unless a gap came since.
    prev: Option<MeanRates>,
    /// Mean specific force and angular rate of the last closed block.
    prev_block_f: Option<Vector3<f64>>,
    prev_block_omega: Option<Vector3<f64>>,
    /// The run's rest rate: the mean angular rate of its first still
    /// stretch long enough for a dwell (Earth rate and the gyro biases).
    rest_omega: Option<Vector3<f64>>,
    still_diffs: DiffSums,
    /// The last block's differences if it was still, waiting for the next
    /// block's decision, and whether the block before it was still.
    pending_diffs: Option<DiffSums>,
    before_still: bool,
    t_first: Option<f64>,
    start_rate: Moments,
    start_force: Moments,
    stretches: Vec<Stretch>,
}

impl Segmenter {
    pub fn new(opts: DetectOptions, sample_rate_hz: f64, gravity: f64) -> Self {
        Segmenter {
            opts,
            dt: 1.0 / sample_rate_hz,
            intervals: Intervals::new(sample_rate_hz),
            gaps: Vec::new(),
            gravity,
            // Two records at least, so that a block has a first difference.
            block_len: ((opts.block_s * sample_rate_hz).round() as usize).max(2),
            block: Stretch::empty(),
            block_diffs: DiffSums::default(),
            prev: None,
            prev_block_f: None,
            prev_block_omega: None,
            rest_omega: None,
            still_diffs: DiffSums::default(),
            pending_diffs: None,
            before_still: false,
            t_first: None,
            start_rate: Moments::default(),
            start_force: Moments::default(),
            stretches: Vec::new(),
        }
    }

    /// Takes the next record. A record whose interval the stamps do not
    /// give (the first, the one after a gap) bounds its block in time but
    /// adds nothing to its sums: taken over the nominal step, a record 10 %
    /// longer reads 1 m/s² more at rest, and its block would be taken for
    /// motion.
    pub fn push(&mut self, r: &Record) {
        let Interval {
            dt,
            gap,
            from_stamps,
        } = self.intervals.next(r.t);
        if let Some(gap) = gap {
            self.gaps.push(gap);
        }
        let b = &mut self.block;
        if b.n == 0 {
            b.t_start = r.t - dt;
        }
        self.t_first.get_or_insert(r.t - dt);
        b.t_end = r.t;
        b.n += 1;
        if !from_stamps {
            self.prev = None;
        } else {
            self.add_to_block(r, dt);
        }
        if self.block.n == self.block_len {
            self.close_block();
        }
    }

    /// Adds a record of interval `dt` to the open block's sums and noise.
    fn add_to_block(&mut self, r: &Record, dt: f64) {
        let per_s = 1.0 / dt;
        let rates = MeanRates {
            omega_b: Vector3::from(r.dtheta) * per_s,
            f_b: Vector3::from(r.dv) * per_s,
            per_s,
        };
        let b = &mut self.block;
        if let Some(p) = self.prev.filter(|_| b.duration > 0.0) {
            let d = &mut self.block_diffs;
            d.d2_theta += (rates.omega_b - p.omega_b).norm_squared();
            d.d2_v += (rates.f_b - p.f_b).norm_squared();
            d.weight += per_s + p.per_s;
            d.n += 1;
        }
        b.duration += dt;
        b.sum_dtheta += Vector3::from(r.dtheta);
        b.sum_dv += Vector3::from(r.dv);
        self.prev = Some(rates);
    }

    /// White-noise densities (per axis: rad/√s, m/s/√s) to judge a block
    /// by: those of the still blocks so far once there are enough of them,
    /// else the block's own (which motion only raises).
    fn judging_noise(&self, block: &DiffSums) -> (f64, f64) {
        const ENOUGH: usize = 200;
        let d = if self.still_diffs.n >= ENOUGH {
            &self.still_diffs
        } else {
            block
        };
        (d.density(d.d2_theta), d.density(d.d2_v))
    }

    /// The one still/moving decision for a block of `span` seconds with
    /// mean rate `omega_b`, specific force `f_b` and record differences
    /// `diffs`: steady against its references within what the run's noise
    /// lets a block mean stray, and |f| loosely gravity-sized.
    fn is_still(
        &self,
        omega_b: &Vector3<f64>,
        f_b: &Vector3<f64>,
        diffs: &DiffSums,
        span: f64,
    ) -> bool {
        let o = &self.opts;
        let force = f_b.norm();
        let sized =
            force > o.force_range_g[0] * self.gravity && force < o.force_range_g[1] * self.gravity;
        let (q_gyro, q_accel) = self.judging_noise(diffs);
        let spread = o.noise_sigmas / span.sqrt();
        let rate_tol = o.rate_threshold_dps.to_radians().max(q_gyro * spread);
        let force_tol = o.force_step_mps2.max(q_accel * spread);
        // The reference is the still stretch this block would extend; after
        // a motion, the block before (a turn or a lift changes f^b from
        // block to block).
        let still_stretch = self.stretches.last().filter(|s| s.still);
        let f_ref = still_stretch.map_or(self.prev_block_f, |s| Some(s.sum_dv / s.duration));
        let steady = f_ref.map_or(true, |f_ref| (f_b - f_ref).norm() < force_tol);
        // Within a still stretch the reference is the stretch's own rate:
        // what a gyro reads at rest moves with its orientation (a MEMS
        // gyro's g-sensitivity: 0.2 deg/s on the y gyro of imu_tk's Xsens
        // with x up), and measured from the run's first dwell that offset
        // would eat the noise's allowance. A stretch starts only near the
        // rest rate, so a steady turn about the vertical is still motion.
        let rest_ref = match (still_stretch, self.rest_omega) {
            (Some(s), Some(_)) => Some(s.sum_dtheta / s.duration),
            (None, rest) => rest,
            (Some(_), None) => None,
        };
        let resting = match rest_ref {
            Some(rest) => (omega_b - rest).norm() < rate_tol,
            None => {
                let w_ref = still_stretch
                    .map_or(self.prev_block_omega, |s| Some(s.sum_dtheta / s.duration));
                omega_b.norm() < o.rest_rate_max_dps.to_radians()
                    && w_ref.map_or(true, |w| (omega_b - w).norm() < rate_tol)
            }
        };
        resting && sized && steady
    }

    /// Takes the run's rest rate from a still stretch that has just ended,
    /// if it is the first long enough for a dwell.
    fn learn_rest_rate(&mut self) {
        if self.rest_omega.is_some() {
            return;
        }
        if let Some(s) = self.stretches.last().filter(|s| s.still) {
            if s.t_end - s.t_start >= self.opts.min_dwell_s {
                self.rest_omega = Some(s.sum_dtheta / s.duration);
            }
        }
    }

    fn close_block(&mut self) {
        let mut b = std::mem::replace(&mut self.block, Stretch::empty());
        let diffs = std::mem::take(&mut self.block_diffs);
        if b.n == 0 {
            return;
        }
        if b.duration <= 0.0 {
            // Only records of unknown interval: nothing to decide on; the
            // stretch before spans its time.
            if let Some(s) = self.stretches.last_mut() {
                s.t_end = b.t_end;
                s.n += b.n;
            }
            return;
        }
        let span = b.duration;
        let omega_b = b.sum_dtheta / span;
        let f_b = b.sum_dv / span;
        b.still = self.is_still(&omega_b, &f_b, &diffs, span);
        // A block counts toward the noise only between two still blocks:
        // the block in which a turn starts or ends can pass the rule with a
        // few records of motion in it, and one such difference outweighs
        // hours of navigation-grade noise (σ came out up to 8× too large on
        // runs whose turns did not start on a block boundary).
        let pending = self.pending_diffs.take();
        if let Some(p) = pending {
            if self.before_still && b.still {
                self.still_diffs.add(&p);
            }
        }
        self.before_still = pending.is_some();
        if b.still {
            self.pending_diffs = Some(diffs);
        }
        if self
            .t_first
            .is_some_and(|t0| b.t_start < t0 + self.opts.start_summary_s - 1e-9)
        {
            self.start_rate.add(omega_b.norm().to_degrees());
            self.start_force.add(f_b.norm());
        }
        self.prev_block_f = Some(f_b);
        self.prev_block_omega = Some(omega_b);
        b.c_rot = rotvec_to_dcm(&b.sum_dtheta);
        b.peak_rate = omega_b.norm();
        match self.stretches.last_mut() {
            Some(s) if s.still == b.still => s.absorb(&b),
            _ => {
                self.learn_rest_rate();
                self.stretches.push(b)
            }
        }
    }

    /// The segments: dwells (still stretches of at least `min_dwell_s`,
    /// less the guards) and the motions between them, in time order and
    /// covering the run without gaps; the noise measured over the still
    /// blocks; the run's start summarised.
    pub fn finish(mut self) -> Segmentation {
        self.close_block();
        let d = self.still_diffs;
        let noise = MeasuredNoise {
            arw: d.density(d.d2_theta),
            vrw: d.density(d.d2_v),
            n_differences: d.n,
        };
        let (rate_mean_dps, rate_spread_dps) = self.start_rate.mean_spread();
        let (force_mean_mps2, force_spread_mps2) = self.start_force.mean_spread();
        let start = StartActivity {
            span_s: self
                .opts
                .start_summary_s
                .min(self.start_rate.n as f64 * self.block_len as f64 * self.dt),
            block_s: self.block_len as f64 * self.dt,
            rate_mean_dps,
            rate_spread_dps,
            force_mean_mps2,
            force_spread_mps2,
        };
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
                let span = s.duration;
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
        Segmentation {
            segments: out,
            noise,
            start,
            gaps: self.gaps,
        }
    }
}

/// Whether time `t` lies inside a dwell of `segments` (sorted).
pub fn in_dwell(segments: &[RunSegment], t: f64) -> bool {
    let i = segments.partition_point(|s| s.t_end < t);
    segments
        .get(i)
        .is_some_and(|s| s.kind == SegmentKind::Dwell && s.t_start <= t && t <= s.t_end)
}

#[cfg(test)]
#[path = "segment_tests.rs"]
mod tests;
