//! The records every pass walks: each with its own interval from its
//! stamps (SPEC §2a), the gaps the pre-scan bridged (`gaps`) filled, and
//! the first record at rest.
//!
//! **Project's choice** (docs/CONTRACT.md §5 "Time"): the bridge spans the
//! whole step (t_{k−1}, t_k], the gap and the record after it, whose own
//! interval the stamps do not give (taken as one nominal step while 10 %
//! longer, its increments would put a false step of 0.1·g·Δt into the
//! velocity, 10 mm/s at 100 Hz). It is made of records of at most one
//! nominal step, each holding the dwell's own mean raw output (its Earth
//! rate and gravity as the unit senses them, errors included) times its
//! length; the last one, stamped t_k, stands for record k. The unit
//! rests, so those are its increments less the noise; the records then
//! pass the compensation, the navigation and the parameter columns like
//! measured ones, and the filter's model of how the navigation errors grow
//! (every parameter acting all the time) stays true across the gap. The
//! ideal rest motion of SPEC §1 in the navigated attitude would hold the
//! navigation error still there instead, while the filter's model lets
//! the residual biases and scale factors act: a misfit of b·T over a gap
//! of length T.
//!
//! The run's first record is the other whose interval the stamps do not
//! give: it is taken over one nominal step, and as the first dwell's mean
//! output over that step (the run begins at rest, or is refused). Read as
//! it is, a first record 10 % longer than nominal put a velocity step of
//! 0.1·g·Δt before the alignment, and a jittered 20 Hz run's z
//! accelerometer scale factor came out 12 σ off.

use super::error::CalibError;
use super::gaps::BridgedGap;
use super::prescan::Prescan;
use super::run::RecordSource;
use super::segment::{RunSegment, SegmentKind};
use crate::record::{Gap, Interval, Intervals, Record};

/// A record as a pass walks it: its increments (raw, as the source holds
/// them), its interval, and whether it was added to bridge a gap beyond
/// the run's own records (the bridge's last record stands for the record
/// after the gap and is not extra).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timed {
    pub record: Record,
    pub dt: f64,
    pub extra: bool,
}

/// The records of `source` with their intervals, the gaps of `scan`
/// bridged and the first record at rest (see the module's
/// documentation). A gap the pre-scan did not bridge (a source that
/// changed between passes) is an error.
pub fn timed_records<'a>(
    source: &'a dyn RecordSource,
    scan: &'a Prescan,
    sample_rate_hz: f64,
) -> Result<TimedRecords<'a>, CalibError> {
    Ok(TimedRecords {
        records: source.records()?,
        intervals: Intervals::new(sample_rate_hz),
        scan,
        next_gap: 0,
        fill: None,
        first: true,
    })
}

/// The iterator of [`timed_records`].
pub struct TimedRecords<'a> {
    records: Box<dyn Iterator<Item = Result<Record, CalibError>> + 'a>,
    intervals: Intervals,
    scan: &'a Prescan,
    next_gap: usize,
    fill: Option<Fill>,
    /// Before the first record.
    first: bool,
}

/// The bridge over one gap: `n` records of `dt` from `t_start` to
/// `t_end`, each the dwell's mean rate and specific force times `dt`.
struct Fill {
    t_start: f64,
    t_end: f64,
    dt: f64,
    n: u64,
    done: u64,
    dtheta: [f64; 3],
    dv: [f64; 3],
}

impl Fill {
    /// The bridge from the gap's start to `t_end`, the stamp of the record
    /// after it.
    fn new(bridged: &BridgedGap, segment: &RunSegment, nominal: f64, t_end: f64) -> Self {
        let length = t_end - bridged.gap.t_start;
        let n = ((length / nominal - 1e-9).ceil() as u64).max(1);
        let dt = length / n as f64;
        Fill {
            t_start: bridged.gap.t_start,
            t_end,
            dt,
            n,
            done: 0,
            dtheta: segment.mean_omega_b.map(|w| w * dt),
            dv: segment.mean_f_b.map(|f| f * dt),
        }
    }

    fn next(&mut self) -> Option<Timed> {
        (self.done < self.n).then(|| {
            self.done += 1;
            let t = if self.done == self.n {
                self.t_end
            } else {
                self.t_start + self.done as f64 * self.dt
            };
            Timed {
                record: Record {
                    t,
                    dtheta: self.dtheta,
                    dv: self.dv,
                },
                dt: self.dt,
                extra: self.done < self.n,
            }
        })
    }
}

impl TimedRecords<'_> {
    /// The first record, over `dt`: the first dwell's mean output (the
    /// record as it is when the run does not begin at rest, which no pass
    /// reaches: the alignment refuses it).
    fn at_rest(&self, record: Record, dt: f64) -> Timed {
        let record = match self.scan.segments.first() {
            Some(s) if s.kind == SegmentKind::Dwell => Record {
                t: record.t,
                dtheta: s.mean_omega_b.map(|w| w * dt),
                dv: s.mean_f_b.map(|f| f * dt),
            },
            _ => record,
        };
        Timed {
            record,
            dt,
            extra: false,
        }
    }

    /// Starts the bridge over the gap before the record stamped `t`.
    fn start_fill(&mut self, gap: &Gap, t: f64) -> Result<(), CalibError> {
        let bridged = self
            .scan
            .gaps
            .get(self.next_gap)
            // The previous record's stamp, exactly as the pre-scan saw it.
            .filter(|b| b.gap.t_start == gap.t_start)
            .ok_or_else(|| {
                CalibError::Source(format!(
                    "a gap of {:.3} s after t = {:.3} s that the pre-scan did not see: the \
                     run changed between passes",
                    gap.length_s(),
                    gap.t_start
                ))
            })?;
        self.next_gap += 1;
        let segment = &self.scan.segments[bridged.segment];
        self.fill = Some(Fill::new(bridged, segment, self.intervals.nominal(), t));
        Ok(())
    }
}

impl Iterator for TimedRecords<'_> {
    type Item = Result<Timed, CalibError>;

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if let Some(fill) = &mut self.fill {
            match fill.next() {
                Some(timed) => return Some(Ok(timed)),
                None => self.fill = None,
            }
        }
        let record = match self.records.next()? {
            Ok(r) => r,
            Err(e) => return Some(Err(e)),
        };
        let Interval { dt, gap, .. } = self.intervals.next(record.t);
        if std::mem::take(&mut self.first) {
            return Some(Ok(self.at_rest(record, dt)));
        }
        match gap {
            None => Some(Ok(Timed {
                record,
                dt,
                extra: false,
            })),
            Some(gap) => match self.start_fill(&gap, record.t) {
                Ok(()) => self.next(),
                Err(e) => Some(Err(e)),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::gaps::bridge_gaps;
    use crate::calib::gaps::tests::segments;
    use crate::calib::segment::StartActivity;
    use crate::calib::sources::SliceSource;

    #[test]
    fn a_bridged_gap_is_filled_with_the_dwells_mean_output_through_the_record_after_it() {
        let rate = 10.0;
        let stamps = [41.0, 41.1, 41.2, 43.45, 43.55];
        let records: Vec<Record> = stamps
            .iter()
            .map(|&t| Record {
                t,
                dtheta: [0.0; 3],
                dv: [0.0, 0.0, 0.98],
            })
            .collect();
        let gap = Gap {
            t_start: 41.2,
            t_end: 43.45 - 1.0 / rate,
        };
        let segments = segments();
        let scan = Prescan {
            gaps: bridge_gaps(&segments, &[gap]).unwrap(),
            segments,
            n_records: records.len() as u64,
            t_begin: 40.9,
            t_end: 43.55,
            arw: 0.0,
            vrw: 0.0,
            start: StartActivity {
                span_s: 0.0,
                block_s: 0.1,
                rate_mean_dps: 0.0,
                rate_spread_dps: 0.0,
                force_mean_mps2: 0.0,
                force_spread_mps2: 0.0,
            },
        };
        let source = SliceSource(&records);
        let walked: Vec<Timed> = timed_records(&source, &scan, rate)
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        // 2.15 s of gap and the 0.1 s of the record after it: 23 records
        // of 0.0978 s, the last standing for that record.
        assert_eq!(walked.len(), records.len() + 22);
        let mut t = 40.9;
        for w in &walked {
            assert!(
                (w.record.t - w.dt - t).abs() < 1e-9,
                "contiguous at {}",
                w.record.t
            );
            t = w.record.t;
        }
        let bridge = &walked[3..26];
        assert!(bridge.iter().all(|w| (w.dt - 2.25 / 23.0).abs() < 1e-12));
        for w in bridge {
            assert!((w.record.dv[2] - 9.8 * w.dt).abs() < 1e-12);
            assert!((w.record.dtheta[0] - 1e-5 * w.dt).abs() < 1e-18);
        }
        assert_eq!(walked.iter().filter(|w| w.extra).count(), 22);
        assert!(!bridge[22].extra && bridge[22].record.t == 43.45);
        assert_eq!(walked[26].record, records[4]);
        // The first record's interval is unknown: the dwell's rest output
        // over one nominal step (segment 0's means).
        for (got, mean) in walked[0].record.dv.iter().zip([0.1, 0.2, 9.8]) {
            assert!((got - mean * 0.1).abs() < 1e-15, "{:?}", walked[0].record);
        }
        assert_eq!(walked[1].record, records[1]);
    }
}
