//! Gaps in a run's time stamps (SPEC §2a: records lost) and the records
//! every pass walks: each with its own interval, and a gap at rest bridged.
//!
//! The pre-scan finds the gaps ([`crate::record::Intervals`] on the
//! stamps) and the dwells; a gap with rest on both sides, inside one
//! dwell, is bridged, any other refuses the run: in motion nothing says
//! what the unit did while no record was kept.
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

use serde::{Deserialize, Serialize};

use super::error::CalibError;
use super::prescan::Prescan;
use super::run::RecordSource;
use super::segment::{RunSegment, SegmentKind};
use crate::record::{Gap, Interval, Intervals, Record};

/// A gap the calibration met, as its result reports it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GapReport {
    /// Stamp of the last record before the gap, s (the file's time).
    pub t_s: f64,
    /// Time no record covers, s.
    pub length_s: f64,
    /// Filled with the dwell's rest output (the only gaps a result can
    /// have: any other refuses the run).
    pub bridged: bool,
}

/// A gap at rest, and the segment (a dwell) whose mean output fills it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BridgedGap {
    pub gap: Gap,
    pub segment: usize,
}

impl BridgedGap {
    /// What a result says of it.
    pub fn report(&self) -> GapReport {
        GapReport {
            t_s: self.gap.t_start,
            length_s: self.gap.length_s(),
            bridged: true,
        }
    }

    /// The warning a result carries for it.
    pub fn warning(&self, segments: &[RunSegment]) -> String {
        let d = &segments[self.segment];
        format!(
            "records are missing for {:.3} s after t = {:.3} s, inside the dwell from {:.2} s to \
             {:.2} s: the gap was bridged with the dwell's mean output (SPEC §2a)",
            self.gap.length_s(),
            self.gap.t_start,
            d.t_start,
            d.t_end
        )
    }
}

/// The gaps of a run bridged, each in the dwell that holds it with rest
/// on both sides; the first gap anywhere else refuses the run, naming its
/// time and length and the motion it meets.
pub fn bridge_gaps(segments: &[RunSegment], gaps: &[Gap]) -> Result<Vec<BridgedGap>, CalibError> {
    gaps.iter()
        .map(|gap| {
            let i = segments.partition_point(|s| s.t_end < gap.t_start);
            match segments.get(i) {
                Some(s)
                    if s.kind == SegmentKind::Dwell
                        && s.t_start <= gap.t_start
                        && gap.t_end <= s.t_end =>
                {
                    Ok(BridgedGap {
                        gap: *gap,
                        segment: i,
                    })
                }
                found => Err(refused(gap, found)),
            }
        })
        .collect()
}

/// The refusal of a gap that is not inside a dwell.
fn refused(gap: &Gap, segment: Option<&RunSegment>) -> CalibError {
    let place = match segment {
        Some(s) if s.kind == SegmentKind::Motion => format!(
            "in the motion from t = {:.2} s to {:.2} s",
            s.t_start, s.t_end
        ),
        Some(s) => format!(
            "at the edge of the dwell from t = {:.2} s to {:.2} s, next to motion",
            s.t_start, s.t_end
        ),
        None => "after the run's last segment".into(),
    };
    CalibError::Unusable(format!(
        "records are missing for {:.3} s after t = {:.3} s, {place}: what the unit did then is \
         unknown, so the run cannot be trusted past it (SPEC §2a; only a gap with rest on both \
         sides, inside a dwell, is bridged)",
        gap.length_s(),
        gap.t_start
    ))
}

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
    use crate::calib::sources::SliceSource;
    use crate::calib::segment::StartActivity;

    fn segment(kind: SegmentKind, t_start: f64, t_end: f64) -> RunSegment {
        RunSegment {
            kind,
            t_start,
            t_end,
            mean_omega_b: [1e-5, 2e-5, 3e-5],
            mean_f_b: [0.1, 0.2, 9.8],
            rotation_b: None,
            peak_rate_dps: None,
        }
    }

    fn segments() -> Vec<RunSegment> {
        vec![
            segment(SegmentKind::Dwell, 0.0, 30.0),
            segment(SegmentKind::Motion, 30.0, 40.0),
            segment(SegmentKind::Dwell, 40.0, 70.0),
        ]
    }

    #[test]
    fn a_gap_inside_a_dwell_is_bridged_and_one_in_motion_or_at_its_edge_refused() {
        let inside = Gap {
            t_start: 45.0,
            t_end: 47.0,
        };
        let bridged = bridge_gaps(&segments(), &[inside]).unwrap();
        assert_eq!(bridged[0].segment, 2);
        assert_eq!(bridged[0].report().length_s, 2.0);
        for (gap, place) in [
            ((33.0, 34.0), "in the motion from t = 30.00 s"),
            ((29.5, 30.5), "at the edge of the dwell from t = 0.00 s"),
            ((69.0, 71.0), "at the edge of the dwell from t = 40.00 s"),
        ] {
            let gap = Gap {
                t_start: gap.0,
                t_end: gap.1,
            };
            let err = bridge_gaps(&segments(), &[gap]).unwrap_err().to_string();
            assert!(err.contains(place), "{err}");
            assert!(err.contains(&format!("after t = {:.3} s", gap.t_start)), "{err}");
        }
    }

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
            assert!((w.record.t - w.dt - t).abs() < 1e-9, "contiguous at {}", w.record.t);
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
