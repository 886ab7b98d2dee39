//! The record type that flows from readers and the simulator to the
//! estimator, and the rule that gives each record its interval from the
//! time stamps (SPEC §2a), which the readers and every consumer share.

use serde::{Deserialize, Serialize};

/// One IMU record: the increments sensed over the interval `(t − Δt, t]`.
///
/// `dtheta` is the angle increment in rad, `dv` the velocity increment in
/// m/s, both in body axes (SPEC §2). The interval's length Δt is not
/// stored: it follows from the time stamps by [`Intervals`]. Readers of
/// rate files convert each sample to an increment over that interval, so
/// everything downstream sees one kind of record.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Record {
    /// End of the record's interval, s.
    pub t: f64,
    /// Angle increment, rad (body axes).
    pub dtheta: [f64; 3],
    /// Velocity increment, m/s (body axes).
    pub dv: [f64; 3],
}

/// What the columns of a data file hold (SPEC §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DataKind {
    /// `t,dthx,dthy,dthz,dvx,dvy,dvz`: increments over the record interval.
    Increments,
    /// `t,wx,wy,wz,fx,fy,fz`: angular rate (rad/s) and specific force (m/s²)
    /// sampled at `t`.
    Rates,
    /// `t,cgx,cgy,cgz,cax,cay,caz`: the unit's raw outputs, converted by
    /// the metadata's `counts` into increments or rates.
    Counts,
}

/// Largest relative deviation of a time step from the nominal step
/// 1/sample_rate_hz that is normal data (SPEC §2a: loggers stamp records
/// with jitter). A longer step is a gap; a shorter one is refused.
pub const STEP_TOLERANCE: f64 = 0.10;

/// Relative slack on the tolerance's bounds, so that a step exactly 10 %
/// off in decimal stamps (0.29 − 0.245 at 20 Hz) is not taken for a
/// shorter or longer one by the rounding of its difference.
const STEP_ROUNDING: f64 = 1e-9;

/// How one time step compares with the nominal step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepKind {
    /// Within [`STEP_TOLERANCE`] of nominal: the record covers the step.
    Normal,
    /// Longer: records were lost before this one.
    Gap,
    /// Shorter than the tolerance allows, zero or negative: not a run at
    /// its stated rate (a clock that rounds its stamps, a repeated record).
    TooShort,
}

impl StepKind {
    /// The kind of a step of `step` seconds at nominal step `nominal`.
    #[inline]
    pub fn of(step: f64, nominal: f64) -> Self {
        StepBounds::new(nominal).kind(step)
    }
}

/// The bounds of [`StepKind`] at one nominal step, worked out once for a
/// run rather than at every record.
#[derive(Clone, Copy, Debug)]
pub struct StepBounds {
    /// Longest normal step, s.
    gap_above: f64,
    /// Shortest normal step, s.
    normal_from: f64,
}

impl StepBounds {
    pub fn new(nominal: f64) -> Self {
        StepBounds {
            gap_above: (1.0 + STEP_TOLERANCE) * nominal * (1.0 + STEP_ROUNDING),
            normal_from: (1.0 - STEP_TOLERANCE) * nominal * (1.0 - STEP_ROUNDING),
        }
    }

    /// The kind of a step of `step` seconds.
    #[inline]
    pub fn kind(&self, step: f64) -> StepKind {
        if step > self.gap_above {
            StepKind::Gap
        } else if step >= self.normal_from {
            StepKind::Normal
        } else {
            StepKind::TooShort
        }
    }
}

/// Time no record covers, before the record that follows a gap.
///
/// **Project's choice** (docs/CONTRACT.md §5 "Time"): the record after a
/// gap covers one nominal step, (t − Δt_nominal, t]; the gap is the rest,
/// from the previous record's stamp to there.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// Stamp of the last record before the gap, s.
    pub t_start: f64,
    /// Start of the interval of the record after it, s.
    pub t_end: f64,
}

impl Gap {
    /// The time no record covers, s.
    pub fn length_s(&self) -> f64 {
        self.t_end - self.t_start
    }
}

/// A record's interval as its stamps give it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Length of the record's interval, s.
    pub dt: f64,
    /// The gap before the record, if records were lost there.
    pub gap: Option<Gap>,
    /// Whether the stamps give `dt` (t_k − t_{k−1}); not for the first
    /// record and the record after a gap, whose `dt` is the nominal step
    /// taken for want of one.
    pub from_stamps: bool,
}

/// The intervals of a run's records, one stamp at a time: record k
/// covers (t_{k−1}, t_k]; the first record, and a record after a gap, one
/// nominal step. Steps are assumed checked (a reader refuses
/// [`StepKind::TooShort`]); a short step here is taken as it is.
#[derive(Clone, Copy, Debug)]
pub struct Intervals {
    nominal: f64,
    bounds: StepBounds,
    previous: Option<f64>,
}

impl Intervals {
    /// For a run at `sample_rate_hz`.
    pub fn new(sample_rate_hz: f64) -> Self {
        let nominal = 1.0 / sample_rate_hz;
        Intervals {
            nominal,
            bounds: StepBounds::new(nominal),
            previous: None,
        }
    }

    /// The nominal step 1/sample_rate_hz, s.
    pub fn nominal(&self) -> f64 {
        self.nominal
    }

    /// The stamp of the last record taken, if any.
    pub fn previous(&self) -> Option<f64> {
        self.previous
    }

    /// The interval of the record stamped `t`, the next in the run.
    #[inline]
    pub fn next(&mut self, t: f64) -> Interval {
        self.next_classified(t).0
    }

    /// [`Intervals::next`], and the kind of the step to `t` (`None` for
    /// the first record): what a reader checks, from the one comparison.
    #[inline]
    pub fn next_classified(&mut self, t: f64) -> (Interval, Option<StepKind>) {
        let Some(previous) = self.previous.replace(t) else {
            return (self.nominal_step(None), None);
        };
        let step = t - previous;
        let kind = self.bounds.kind(step);
        let interval = match kind {
            StepKind::Gap => self.nominal_step(Some(Gap {
                t_start: previous,
                t_end: t - self.nominal,
            })),
            StepKind::Normal | StepKind::TooShort => Interval {
                dt: step,
                gap: None,
                from_stamps: true,
            },
        };
        (interval, Some(kind))
    }

    /// The interval of a record the stamps give none for: one nominal
    /// step, after `gap` if there is one.
    fn nominal_step(&self, gap: Option<Gap>) -> Interval {
        Interval {
            dt: self.nominal,
            gap,
            from_stamps: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_are_normal_within_ten_percent_gaps_above_and_too_short_below() {
        let nominal = 0.01;
        for (step, kind) in [
            (0.01099, StepKind::Normal),
            (0.011, StepKind::Normal),
            (0.00901, StepKind::Normal),
            (0.01101, StepKind::Gap),
            (2.0, StepKind::Gap),
            (0.00899, StepKind::TooShort),
            (0.0, StepKind::TooShort),
            (-0.01, StepKind::TooShort),
        ] {
            assert_eq!(StepKind::of(step, nominal), kind, "{step}");
        }
        // Exactly 10 % off in decimal stamps, whatever the rounding.
        assert_eq!(StepKind::of(0.29 - 0.245, 0.05), StepKind::Normal);
        assert_eq!(StepKind::of(0.355 - 0.3, 0.05), StepKind::Normal);
    }

    #[test]
    fn a_record_covers_its_own_step_and_one_nominal_step_after_a_gap() {
        let mut intervals = Intervals::new(100.0);
        let first = intervals.next(5.0);
        assert_eq!(
            first,
            Interval {
                dt: 0.01,
                gap: None,
                from_stamps: false
            }
        );
        let jittered = intervals.next(5.0109);
        assert!((jittered.dt - 0.0109).abs() < 1e-12 && jittered.gap.is_none());
        assert!(jittered.from_stamps);
        let after_gap = intervals.next(7.0109);
        assert_eq!(after_gap.dt, 0.01);
        assert!(!after_gap.from_stamps);
        let gap = after_gap.gap.expect("a gap");
        assert_eq!(gap.t_start, 5.0109);
        assert!((gap.t_end - 7.0009).abs() < 1e-12);
        assert!((gap.length_s() - 1.99).abs() < 1e-12);
    }
}
