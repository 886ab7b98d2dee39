//! Gaps in a run's time stamps (SPEC §2a: records lost): which the run
//! can bridge and which refuse it, and how a result reports them.
//!
//! The pre-scan finds the gaps ([`crate::record::Intervals`] on the
//! stamps) and the dwells; a gap with rest on both sides, inside one
//! dwell, is bridged (`timed`), any other refuses the run: in motion
//! nothing says what the unit did while no record was kept.

use serde::{Deserialize, Serialize};

use super::error::CalibError;
use super::segment::{RunSegment, SegmentKind};
use crate::record::Gap;

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

#[cfg(test)]
pub(super) mod tests {
    use super::*;

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

    /// A dwell, a turn and a dwell; each dwell's mean output (1e-5, 2e-5,
    /// 3e-5) rad/s and (0.1, 0.2, 9.8) m/s².
    pub(in crate::calib) fn segments() -> Vec<RunSegment> {
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
            assert!(
                err.contains(&format!("after t = {:.3} s", gap.t_start)),
                "{err}"
            );
        }
    }
}
