//! Compensating records as they stream past: each record is replaced by the
//! true increments behind it, by the model's exact inversion (SPEC §2,
//! `model::Compensator`), one at a time, so a run of any length is never
//! held in memory.

use crate::model::{Compensator, ErrorParameters};
use crate::record::{Intervals, Record};

/// An iterator of compensated records over an iterator of records (or of
/// read results, whose errors pass through untouched).
pub struct Compensated<I> {
    records: I,
    compensator: Compensator,
    intervals: Intervals,
}

impl<I> Compensated<I> {
    /// Compensates `records` of a run sampled at `sample_rate_hz` with
    /// `params` (SI). Δt is each record's own interval from its stamps
    /// (SPEC §2a), as the estimator takes it.
    pub fn new(records: I, params: &ErrorParameters, sample_rate_hz: f64) -> Self {
        Compensated {
            records,
            compensator: params.compensator(),
            intervals: Intervals::new(sample_rate_hz),
        }
    }

    /// The records being compensated (e.g. a reader, for what it keeps
    /// beside the records).
    pub fn inner(&self) -> &I {
        &self.records
    }
}

impl<I, E> Iterator for Compensated<I>
where
    I: Iterator<Item = Result<Record, E>>,
{
    type Item = Result<Record, E>;

    fn next(&mut self) -> Option<Self::Item> {
        let (c, intervals) = (&self.compensator, &mut self.intervals);
        self.records
            .next()
            .map(|r| r.map(|rec| c.record(&rec, intervals.next(rec.t).dt)))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.records.size_hint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::convert::Infallible;

    #[test]
    fn compensating_a_generated_record_returns_the_true_one() {
        let p = ErrorParameters::paper();
        let dt = 0.01;
        let f_b = nalgebra::Vector3::new(0.3, -0.2, 9.79);
        let w_b = nalgebra::Vector3::new(1e-5, 2e-5, 4e-5);
        let truth = Record {
            t: 1.0,
            dtheta: (w_b * dt).into(),
            dv: (f_b * dt).into(),
        };
        let measured = Record {
            t: 1.0,
            dtheta: p.apply_gyro(&(w_b * dt), dt).into(),
            dv: p
                .apply_accel(&(f_b * dt), &(f_b.component_mul(&f_b) * dt), dt)
                .into(),
        };
        let out: Vec<Record> =
            Compensated::new([Ok::<_, Infallible>(measured)].into_iter(), &p, 1.0 / dt)
                .collect::<Result<_, _>>()
                .unwrap();
        assert_eq!(out.len(), 1);
        for i in 0..3 {
            assert!((out[0].dv[i] - truth.dv[i]).abs() < 1e-16, "dv {i}");
            assert!(
                (out[0].dtheta[i] - truth.dtheta[i]).abs() < 1e-20,
                "dtheta {i}"
            );
            // The measured record was far from it: the test can fail.
            assert!(
                (measured.dv[i] - truth.dv[i]).abs() > 1e-8,
                "dv {i} unchanged"
            );
        }
    }
}
