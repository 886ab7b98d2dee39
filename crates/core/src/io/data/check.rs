//! The checks every record passes whatever its encoding: finite values,
//! strictly increasing time at the nominal step (SPEC §2a: jitter within
//! 10 % normal, a longer step a gap passed on); and the conversion of rate
//! samples to increments over each record's interval.

use crate::record::{DataKind, Interval, Intervals, Record, StepKind};

use super::error::{Column, DataError, Position};
use super::layout::{
    COUNT_COLUMNS, INCREMENT_COLUMNS, MAX_COLUMNS, MEAN_RATE_SIGMAS, MEAN_RATE_TOLERANCE,
    RATE_COLUMNS, TEMPERATURE_COLUMN,
};

/// Steps after which the mean step is checked: by then the mean of the
/// normal steps is known to its standard error, and whether gaps outnumber
/// them is clear.
const MEAN_RATE_AFTER_STEPS: u64 = 1000;

pub(crate) fn column(kind: DataKind, index0: usize) -> Column {
    let names = match kind {
        DataKind::Increments => &INCREMENT_COLUMNS,
        DataKind::Rates => &RATE_COLUMNS,
        DataKind::Counts => &COUNT_COLUMNS,
    };
    Column {
        index: index0 + 1,
        name: names
            .get(index0)
            .copied()
            .or((index0 == names.len()).then_some(TEMPERATURE_COLUMN))
            .unwrap_or("?"),
    }
}

/// Index of the first value that is NaN or infinite.
#[inline]
pub(crate) fn first_non_finite(values: &[f64]) -> Option<usize> {
    // One combined test keeps the common all-finite path branch-light.
    if values.iter().all(|v| v.is_finite()) {
        None
    } else {
        values.iter().position(|v| !v.is_finite())
    }
}

/// The time axis of a run as the reader sees it: each step classed by
/// the rule of SPEC §2a ([`StepKind`]), the record's interval from it
/// ([`Intervals`]), and the mean of the normal steps.
#[derive(Clone, Debug)]
pub(crate) struct Timing {
    intervals: Intervals,
    /// sample_rate_hz, 1/s.
    per_nominal: f64,
    /// Normal steps, their sum (s) and the sums of their relative
    /// deviations from nominal and its square.
    normal: u64,
    span: f64,
    sum_dev: f64,
    sum_dev2: f64,
    gaps: u64,
}

impl Timing {
    pub(crate) fn new(sample_rate_hz: f64) -> Result<Self, DataError> {
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(DataError::InvalidSampleRate(sample_rate_hz));
        }
        Ok(Timing {
            intervals: Intervals::new(sample_rate_hz),
            per_nominal: sample_rate_hz,
            normal: 0,
            span: 0.0,
            sum_dev: 0.0,
            sum_dev2: 0.0,
            gaps: 0,
        })
    }

    /// The nominal record interval Δt = 1/sample_rate_hz, s.
    pub(crate) fn nominal(&self) -> f64 {
        self.intervals.nominal()
    }

    /// Gaps passed so far.
    pub(crate) fn gaps(&self) -> u64 {
        self.gaps
    }

    /// Accepts `t` as the next record's time and returns the record's
    /// interval. Each step is compared with the nominal one rather than
    /// with the previous step, so slow drift cannot creep past the
    /// tolerance. A step longer than the tolerance is a gap, passed on in
    /// the interval; a shorter one, zero or negative is refused.
    #[inline]
    pub(crate) fn accept(
        &mut self,
        t: f64,
        at: impl Fn() -> Position,
    ) -> Result<Interval, DataError> {
        let previous = self.intervals.previous();
        let (interval, kind) = self.intervals.next_classified(t);
        let (Some(previous), Some(kind)) = (previous, kind) else {
            return Ok(interval);
        };
        match kind {
            StepKind::TooShort if t <= previous => {
                return Err(DataError::TimeNotIncreasing {
                    at: at(),
                    t,
                    previous,
                })
            }
            StepKind::TooShort => {
                return Err(DataError::TimeStep {
                    at: at(),
                    t,
                    previous,
                    step: interval.dt,
                    nominal: self.nominal(),
                })
            }
            StepKind::Gap => self.gaps += 1,
            StepKind::Normal => {
                let dev = interval.dt * self.per_nominal - 1.0;
                self.normal += 1;
                self.span += interval.dt;
                self.sum_dev += dev;
                self.sum_dev2 += dev * dev;
            }
        }
        // The mean within the fixed tolerance needs no more (the common
        // case, checked without a division on every step).
        let steps = self.normal + self.gaps;
        if steps >= MEAN_RATE_AFTER_STEPS
            && (self.gaps > self.normal
                || self.sum_dev.abs() > MEAN_RATE_TOLERANCE * self.normal as f64)
        {
            self.check_mean_rate(&at)?;
        }
        Ok(interval)
    }

    /// The rate the steps show against the metadata's: gaps must stay the
    /// exception, and the mean normal step must be nominal within
    /// [`MEAN_RATE_TOLERANCE`] plus five standard errors of the steps'
    /// spread. Gaps stay out of the mean: how many records one lost is
    /// unknown.
    #[cold]
    fn check_mean_rate(&self, at: &impl Fn() -> Position) -> Result<(), DataError> {
        let nominal = self.nominal();
        let steps = self.normal + self.gaps;
        if self.gaps > self.normal {
            return Err(DataError::MostlyGaps {
                at: at(),
                steps,
                gaps: self.gaps,
                nominal,
                sample_rate_hz: 1.0 / nominal,
            });
        }
        let n = self.normal as f64;
        let mean_dev = self.sum_dev / n;
        let spread2 = (self.sum_dev2 / n - mean_dev * mean_dev).max(0.0);
        let bound = MEAN_RATE_TOLERANCE + MEAN_RATE_SIGMAS * (spread2 / n).sqrt();
        if mean_dev.abs() > bound {
            return Err(DataError::MeanRate {
                at: at(),
                steps: self.normal,
                span: self.span,
                expected: n * nominal,
                sample_rate_hz: 1.0 / nominal,
                mean_rate_hz: n / self.span,
                bound_pct: 100.0 * bound,
            });
        }
        Ok(())
    }
}

/// Builds a record from checked values in file order.
///
/// Rates are turned into increments over the record's own interval:
/// `dtheta = w·Δt`, `dv = f·Δt` with `Δt` the record's [`Interval`] (its
/// step; one nominal step for the first record and after a gap), i.e. the
/// sample at `t` is taken as the mean rate over `(t − Δt, t]`.
#[inline]
pub(crate) fn to_record(kind: DataKind, v: &[f64; MAX_COLUMNS], dt: f64) -> Record {
    match kind {
        DataKind::Increments => Record {
            t: v[0],
            dtheta: [v[1], v[2], v[3]],
            dv: [v[4], v[5], v[6]],
        },
        // Counts are converted before this (`CountsConversion`); taken
        // as rates here they would read the count as rad/s.
        DataKind::Rates | DataKind::Counts => Record {
            t: v[0],
            dtheta: [v[1] * dt, v[2] * dt, v[3] * dt],
            dv: [v[4] * dt, v[5] * dt, v[6] * dt],
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: u64) -> impl Fn() -> Position {
        move || Position::Line(n)
    }

    #[test]
    fn sample_rate_must_be_positive_and_finite() {
        for bad in [0.0, -100.0, f64::NAN, f64::INFINITY] {
            assert!(
                matches!(Timing::new(bad), Err(DataError::InvalidSampleRate(_))),
                "{bad}"
            );
        }
        assert_eq!(Timing::new(200.0).expect("valid").nominal(), 0.005);
    }

    #[test]
    fn steps_within_ten_percent_pass_longer_ones_are_gaps_and_shorter_ones_fail() {
        let mut timing = Timing::new(100.0).expect("valid");
        assert_eq!(timing.accept(1.0, line(1)).expect("first").dt, 0.01);
        let short = timing.accept(1.00901, line(2)).expect("9.9 % short");
        assert!((short.dt - 0.00901).abs() < 1e-12 && short.gap.is_none());
        let long = timing.accept(1.02, line(3)).expect("9.9 % long");
        assert!((long.dt - 0.01099).abs() < 1e-12 && long.gap.is_none());
        let after = timing.accept(1.03101, line(4)).expect("10.1 % long: a gap");
        assert_eq!(after.dt, 0.01);
        let gap = after.gap.expect("gap");
        assert_eq!(gap.t_start, 1.02);
        assert!((gap.length_s() - 0.00101).abs() < 1e-12);
        assert_eq!(timing.gaps(), 1);
    }

    #[test]
    fn a_clock_half_a_percent_fast_is_refused_once_the_mean_step_shows_it() {
        // 100.5 Hz data under 100 Hz metadata: every step is 0.5 % short,
        // inside the step tolerance, but the mean gives it away.
        let mut timing = Timing::new(100.0).unwrap();
        let mut refused_at = None;
        for k in 0..5000u64 {
            if let Err(e) = timing.accept(k as f64 / 100.5, line(k + 2)) {
                assert!(matches!(e, DataError::MeanRate { .. }), "{e}");
                refused_at = Some(k);
                break;
            }
        }
        assert_eq!(refused_at, Some(MEAN_RATE_AFTER_STEPS));
        // The exact rate, with alternating jitter of 9 % of a step, passes.
        let mut timing = Timing::new(100.0).unwrap();
        for k in 0..5000u64 {
            let jitter = if k % 2 == 0 { 0.045 } else { -0.045 };
            timing
                .accept((k as f64 + jitter) / 100.0, line(k + 2))
                .unwrap();
        }
    }

    /// Steps of 9.2, 10 or 10.8 ms in a scrambled order make the mean
    /// wander like a random walk: it must pass at the right rate and fail
    /// at 2 % off, where every step still passes on its own.
    #[test]
    fn the_mean_rate_bound_follows_the_jitter_of_the_steps() {
        // The top two bits of a Weyl sequence: 0, 1, 2, 3 equally often.
        let draw = |k: u64| match k.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 62 {
            0 => -1.0,
            3 => 1.0,
            _ => 0.0,
        };
        for (rate, passes) in [(100.0, true), (102.0, false)] {
            let mut timing = Timing::new(100.0).unwrap();
            let mut t = 0.0;
            let mut result = Ok(());
            for k in 0..20_000u64 {
                t += (1.0 + 0.08 * draw(k)) / rate;
                if let Err(e) = timing.accept(t, line(k + 2)) {
                    result = Err(e);
                    break;
                }
            }
            match result {
                Ok(()) => assert!(passes, "{rate} Hz passed"),
                Err(e) => {
                    assert!(!passes, "{rate} Hz: {e}");
                    assert!(matches!(e, DataError::MeanRate { .. }), "{e}");
                }
            }
        }
    }

    #[test]
    fn a_run_at_half_the_stated_rate_is_refused_as_mostly_gaps() {
        let mut timing = Timing::new(100.0).unwrap();
        let err = (0..2000u64)
            .find_map(|k| timing.accept(k as f64 / 50.0, line(k + 2)).err())
            .expect("refused");
        assert!(matches!(err, DataError::MostlyGaps { .. }), "{err}");
    }

    #[test]
    fn a_step_too_short_zero_or_negative_is_refused() {
        let mut timing = Timing::new(100.0).expect("valid");
        timing.accept(0.0, line(1)).expect("first");
        let err = timing.accept(0.00899, line(2)).expect_err("10.1 % short");
        assert!(matches!(err, DataError::TimeStep { .. }));
        let err = timing.accept(0.0, line(2)).expect_err("repeat");
        assert!(matches!(err, DataError::TimeNotIncreasing { .. }));
        let err = timing.accept(-0.01, line(2)).expect_err("back");
        assert!(matches!(err, DataError::TimeNotIncreasing { .. }));
    }

    #[test]
    fn rates_scale_by_the_interval_and_increments_pass_through() {
        let v = [2.0, 0.5, -1.0, 0.25, 0.0, 1.0, 9.8, 25.0];
        let inc = to_record(DataKind::Increments, &v, 0.01);
        assert_eq!(inc.dtheta, [0.5, -1.0, 0.25]);
        assert_eq!(inc.dv, [0.0, 1.0, 9.8]);
        let rate = to_record(DataKind::Rates, &v, 0.25);
        assert_eq!(rate.t, 2.0);
        assert_eq!(rate.dtheta, [0.125, -0.25, 0.0625]);
        assert_eq!(rate.dv, [0.0, 0.25, 2.45]);
    }
}
