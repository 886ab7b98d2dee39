//! The checks every record passes whatever its encoding: finite values,
//! strictly increasing time at the nominal step; and the conversion of rate
//! samples to increments.

use crate::record::{DataKind, Record};

use super::error::{Column, DataError, Position};
use super::layout::{
    INCREMENT_COLUMNS, MAX_COLUMNS, MEAN_RATE_TOLERANCE, RATE_COLUMNS, STEP_TOLERANCE,
    TEMPERATURE_COLUMN,
};

/// Steps after which the mean step is checked: by then the jitter of single
/// time stamps (within the step tolerance) averages below the mean tolerance.
const MEAN_RATE_AFTER_STEPS: u64 = 1000;

pub(crate) fn column(kind: DataKind, index0: usize) -> Column {
    let names = match kind {
        DataKind::Increments => &INCREMENT_COLUMNS,
        DataKind::Rates => &RATE_COLUMNS,
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

/// The time axis of a run as the reader sees it.
#[derive(Clone, Debug)]
pub(crate) struct Timing {
    nominal: f64,
    previous: Option<f64>,
    first: f64,
    steps: u64,
}

impl Timing {
    pub(crate) fn new(sample_rate_hz: f64) -> Result<Self, DataError> {
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(DataError::InvalidSampleRate(sample_rate_hz));
        }
        Ok(Timing {
            nominal: 1.0 / sample_rate_hz,
            previous: None,
            first: 0.0,
            steps: 0,
        })
    }

    /// The nominal record interval Δt = 1/sample_rate_hz, s.
    pub(crate) fn nominal(&self) -> f64 {
        self.nominal
    }

    /// Accepts `t` as the next record's time. Each step is compared with
    /// the nominal one rather than with the previous step, so slow drift
    /// cannot creep past the tolerance.
    #[inline]
    pub(crate) fn accept(
        &mut self,
        t: f64,
        at: impl FnOnce() -> Position,
    ) -> Result<(), DataError> {
        if let Some(previous) = self.previous {
            let step = t - previous;
            if step <= 0.0 {
                return Err(DataError::TimeNotIncreasing {
                    at: at(),
                    t,
                    previous,
                });
            }
            if (step - self.nominal).abs() > STEP_TOLERANCE * self.nominal {
                return Err(DataError::TimeStep {
                    at: at(),
                    t,
                    previous,
                    step,
                    nominal: self.nominal,
                });
            }
            self.steps += 1;
            if self.steps >= MEAN_RATE_AFTER_STEPS {
                let span = t - self.first;
                let expected = self.steps as f64 * self.nominal;
                if (span - expected).abs() > MEAN_RATE_TOLERANCE * expected {
                    return Err(DataError::MeanRate {
                        at: at(),
                        steps: self.steps,
                        span,
                        expected,
                        sample_rate_hz: 1.0 / self.nominal,
                        mean_rate_hz: self.steps as f64 / span,
                    });
                }
            }
        } else {
            self.first = t;
        }
        self.previous = Some(t);
        Ok(())
    }
}

/// Builds a record from checked values in file order.
///
/// Rates are turned into increments over the record's nominal interval:
/// `dtheta = w·Δt`, `dv = f·Δt` with `Δt = 1/sample_rate_hz`, i.e. the sample
/// at `t` is taken as the mean rate over `(t − Δt, t]`.
#[inline]
pub(crate) fn to_record(kind: DataKind, v: &[f64; MAX_COLUMNS], dt: f64) -> Record {
    match kind {
        DataKind::Increments => Record {
            t: v[0],
            dtheta: [v[1], v[2], v[3]],
            dv: [v[4], v[5], v[6]],
        },
        DataKind::Rates => Record {
            t: v[0],
            dtheta: [v[1] * dt, v[2] * dt, v[3] * dt],
            dv: [v[4] * dt, v[5] * dt, v[6] * dt],
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: u64) -> impl FnOnce() -> Position {
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
    fn steps_within_one_percent_pass_and_beyond_fail() {
        let mut timing = Timing::new(100.0).expect("valid");
        timing.accept(1.0, line(1)).expect("first");
        timing.accept(1.00991, line(2)).expect("0.9 % short");
        timing.accept(1.01996, line(3)).expect("0.5 % long");
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
        // The exact rate, with alternating jitter of 0.9 % of a step, passes.
        let mut timing = Timing::new(100.0).unwrap();
        for k in 0..5000u64 {
            let jitter = if k % 2 == 0 { 0.0045 } else { -0.0045 };
            timing
                .accept((k as f64 + jitter) / 100.0, line(k + 2))
                .unwrap();
        }
    }

    #[test]
    fn a_step_off_by_more_than_the_tolerance_is_refused() {
        let mut timing = Timing::new(100.0).expect("valid");
        timing.accept(0.0, line(1)).expect("first");
        let err = timing.accept(0.0102, line(2)).expect_err("2 % long");
        assert!(matches!(err, DataError::TimeStep { .. }));
        let err = timing.accept(0.0098, line(2)).expect_err("2 % short");
        assert!(matches!(err, DataError::TimeStep { .. }));
        let err = timing.accept(0.0, line(2)).expect_err("repeat");
        assert!(matches!(err, DataError::TimeNotIncreasing { .. }));
    }

    #[test]
    fn rates_scale_by_the_nominal_interval_and_increments_pass_through() {
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
