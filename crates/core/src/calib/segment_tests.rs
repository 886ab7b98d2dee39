//! The pre-scan's still/moving decision on records built to the point.

use super::*;

/// Records at `rate_hz` from `t0` for `span_s`, sensing `f_b` and no
/// rotation.
fn steady(t0: f64, span_s: f64, rate_hz: f64, f_b: [f64; 3]) -> Vec<Record> {
    let dt = 1.0 / rate_hz;
    (1..=(span_s * rate_hz).round() as usize)
        .map(|k| Record {
            t: t0 + k as f64 * dt,
            dtheta: [0.0; 3],
            dv: f_b.map(|f| f * dt),
        })
        .collect()
}

/// Records at `rate_hz` from `t0` for `span_s`, sensing `f_b` and
/// turning at `omega_dps` (deg/s, body axes).
fn turning(t0: f64, span_s: f64, rate_hz: f64, f_b: [f64; 3], omega_dps: [f64; 3]) -> Vec<Record> {
    let dt = 1.0 / rate_hz;
    steady(t0, span_s, rate_hz, f_b)
        .into_iter()
        .map(|r| Record {
            dtheta: omega_dps.map(|w| w.to_radians() * dt),
            ..r
        })
        .collect()
}

/// A gyro whose rest rate moved with the unit's orientation (a MEMS
/// g-sensitivity) by 0.04 deg/s, within the 0.05 deg/s allowance of
/// the first dwell's rate, reads one block a further 0.03 deg/s off:
/// against its own dwell's rate that block is still, and the 5 s dwell
/// stays whole instead of breaking into two pieces too short for a
/// dwell. A steady turn about the vertical at 0.1 deg/s after a motion
/// is motion, though its specific force does not change.
#[test]
fn a_dwell_is_judged_against_its_own_rest_rate() {
    let up = [0.0, 0.0, 9.8];
    let side = [9.8, 0.0, 0.0];
    let mut records = steady(0.0, 10.0, 50.0, up);
    records.extend(turning(10.0, 2.0, 50.0, [4.9, 0.0, 4.9], [0.0, 45.0, 0.0]));
    records.extend(turning(12.0, 2.5, 50.0, side, [0.0, 0.04, 0.0]));
    records.extend(turning(14.5, 0.1, 50.0, side, [0.0, 0.07, 0.0]));
    records.extend(turning(14.6, 2.5, 50.0, side, [0.0, 0.04, 0.0]));
    records.extend(turning(17.1, 2.0, 50.0, [4.9, 0.0, 4.9], [0.0, -45.0, 0.0]));
    records.extend(turning(19.1, 5.0, 50.0, up, [0.0, 0.0, 0.1]));
    let mut seg = Segmenter::new(DetectOptions::default(), 50.0, 9.8);
    records.iter().for_each(|r| seg.push(r));
    let segments = seg.finish().segments;
    let kinds: Vec<_> = segments.iter().map(|s| s.kind).collect();
    assert_eq!(
        kinds,
        [
            SegmentKind::Dwell,
            SegmentKind::Motion,
            SegmentKind::Dwell,
            SegmentKind::Motion
        ]
    );
    let side_dwell = &segments[2];
    assert!(
        side_dwell.t_end - side_dwell.t_start > 4.0,
        "{side_dwell:?}"
    );
}

/// A unit reading 1.04 g at rest is still; lifted for a second without
/// turning (its rate stays zero) it is moving, and the lift parts two
/// dwells.
#[test]
fn rest_is_found_by_steadiness_and_a_lift_without_turning_is_motion() {
    let rest = [0.3, -0.2, 10.2];
    let lifted = [0.3, -0.2, 10.9];
    let mut records = steady(0.0, 30.0, 50.0, rest);
    records.extend(steady(30.0, 1.0, 50.0, lifted));
    records.extend(steady(31.0, 30.0, 50.0, rest));
    let mut seg = Segmenter::new(DetectOptions::default(), 50.0, 9.79);
    records.iter().for_each(|r| seg.push(r));
    let kinds: Vec<_> = seg.finish().segments.iter().map(|s| s.kind).collect();
    assert_eq!(
        kinds,
        [SegmentKind::Dwell, SegmentKind::Motion, SegmentKind::Dwell]
    );
}
