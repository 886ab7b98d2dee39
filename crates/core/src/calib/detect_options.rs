//! The thresholds by which the pre-scan tells rest from motion
//! (`segment`), with the reasons for their defaults.

use serde::{Deserialize, Serialize};

/// Thresholds of the still/moving classification.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DetectOptions {
    /// Block length over which rates are averaged, s.
    pub block_s: f64,
    /// A block whose mean angular rate differs by more than this from the
    /// run's rest rate is moving, deg/s, unless the run's own noise makes
    /// the block mean scatter more (`noise_sigmas`). At rest a gyro senses
    /// Earth rate (0.004 deg/s) plus its bias, the same in every dwell up to
    /// the Earth rate's turn with the unit; the rest rate is measured on the
    /// run's first dwell, so this bound does not depend on the bias (a MEMS
    /// gyro's 0.3 deg/s reads steadily too). A block that would extend a
    /// still stretch is held to that stretch's own rate instead, which a
    /// MEMS gyro's g-sensitivity moves with the orientation. It is the only
    /// sign of a turn about the vertical, which leaves f^b unchanged.
    pub rate_threshold_dps: f64,
    /// Largest mean rate a block of the run's first still stretch may have,
    /// deg/s: before any rest rate is known, a block is compared with this
    /// and with the blocks around it. Three times the largest bias of a
    /// consumer-grade gyro (1 deg/s), and below any turntable's or hand's
    /// turning rate.
    pub rest_rate_max_dps: f64,
    /// A block whose mean specific force differs by more than this from
    /// the mean of the still stretch it would extend (or, after a motion,
    /// from the block before) is moving, m/s², unless the run's noise
    /// makes the block mean scatter more. 0.02 m/s² is ten times the block
    /// mean's noise at a tactical-grade 50 µg/√Hz, and a tilt of 0.12°: a
    /// unit lifted, or creeping below the rate bound, is moving.
    pub force_step_mps2: f64,
    /// How far, in standard deviations of a block mean under the run's
    /// measured white noise, a block may stray from its reference and still
    /// be at rest: what widens the two bounds above for a noisy unit.
    pub noise_sigmas: f64,
    /// Loose bounds on |f| at rest as fractions of the local gravity: a
    /// unit reading outside them is falling, shaken or broken, not still.
    pub force_range_g: [f64; 2],
    /// Shortest still stretch taken as a dwell, s. Hand recordings of MEMS
    /// units rest 3–10 s (imu_tk's Xsens recording: 3.6–11 s but for a
    /// few brief stops); a turntable never stops that long mid-turn.
    pub min_dwell_s: f64,
    /// Time cut from each end of a still stretch, s.
    pub guard_s: f64,
    /// Span at the run's start over which its motion is summarised for a
    /// run that does not begin at rest, s.
    pub start_summary_s: f64,
}

impl Default for DetectOptions {
    fn default() -> Self {
        DetectOptions {
            block_s: 0.1,
            rate_threshold_dps: 0.05,
            rest_rate_max_dps: 3.0,
            force_step_mps2: 0.02,
            noise_sigmas: 6.0,
            force_range_g: [0.5, 2.0],
            min_dwell_s: 3.0,
            guard_s: 0.5,
            start_summary_s: 5.0,
        }
    }
}
