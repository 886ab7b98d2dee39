//! Reconstructing a run's rotation scheme from its own gyro data: the
//! dwells from the segmentation, and for each motion its axis and angle
//! (net rotation vector) and its trapezoidal profile (peak rate, angular
//! acceleration, start time) from the record rates.
//!
//! SPEC §4 turns are about a body axis or about a navigation-frame axis.
//! The net rotation vector is measured in the body frame; carried into n
//! with the attitude at the turn's start (the aligned start attitude
//! turned by the turns found so far) it shows which of the two the table
//! turned about. The frame whose nearest axis lies closer to the measured
//! one is taken: on a unit a few tenths of a degree off nominal the two
//! differ by far more than the calibrated gyros' direction error (arcsec),
//! and a turn simulated about the wrong one would tilt the simulated unit
//! by the angle between them.
//!
//! The ramp of a trapezoidal profile is linear in time and a record's
//! mean rate is the rate at its mid-time, so the times where the rate
//! crosses 10 % and 90 % of its peak (interpolated between records) give
//! the acceleration and the start to a small fraction of a record.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::error::DiagnoseError;
use crate::calib::prescan::Prescan;
use crate::calib::timed::timed_records;
use crate::calib::{RecordSource, SegmentKind};
use crate::model::Compensator;
use crate::nav::attitude::rotvec_to_dcm;
use crate::sim::profile::RotationProfile;
use crate::sim::scheme::{Axis, Frame, Rotate, Step};
use crate::sim::Scheme;

/// Largest angle between a motion's rotation vector and the nearest body
/// or navigation axis for it to be taken as a turn about that axis, deg.
const AXIS_TOLERANCE_DEG: f64 = 3.0;

/// One reconstructed rotation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RotationFound {
    /// x, y, z (body) or e, n, u (navigation frame), as in SPEC §4.
    pub axis: Axis,
    pub frame: Frame,
    pub angle_deg: f64,
    pub rate_dps: f64,
    pub accel_dps2: f64,
    /// Start, s from the scheme's start.
    pub t_start: f64,
    /// Angle between the measured rotation vector and the axis, deg.
    pub off_axis_deg: f64,
}

/// A run's scheme as its data shows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reconstruction {
    pub scheme: Scheme,
    pub rotations: Vec<RotationFound>,
}

/// The axis of `frame` nearest to the unit vector `u` (in that frame), the
/// angle between them (deg) and the component of `u` along it.
fn nearest_axis(u: &Vector3<f64>, frame: Frame) -> (Axis, f64, f64) {
    let i = (0..3)
        .max_by(|&a, &b| u[a].abs().total_cmp(&u[b].abs()))
        .unwrap_or(0);
    let axis = match (frame, i) {
        (Frame::Body, 0) => Axis::X,
        (Frame::Body, 1) => Axis::Y,
        (Frame::Body, _) => Axis::Z,
        (Frame::Nav, 0) => Axis::E,
        (Frame::Nav, 1) => Axis::N,
        (Frame::Nav, _) => Axis::U,
    };
    let off = u[i].abs().clamp(0.0, 1.0).acos().to_degrees();
    (axis, off, u[i])
}

/// Reconstructs the scheme with one streaming pass over the records,
/// compensated with `comp` (the calibration) so that angles and rates are
/// the table's, not the gyros' raw readings. `c_b_n0` is the aligned
/// start attitude, which places navigation-frame turns.
pub fn reconstruct(
    source: &dyn RecordSource,
    scan: &Prescan,
    sample_rate_hz: f64,
    comp: &Compensator,
    c_b_n0: &Matrix3<f64>,
) -> Result<Reconstruction, DiagnoseError> {
    let dt = 1.0 / sample_rate_hz;
    let motions: Vec<usize> = scan
        .segments
        .iter()
        .enumerate()
        .filter(|(_, s)| s.kind == SegmentKind::Motion)
        .map(|(i, _)| i)
        .collect();
    // Per motion: (mid-time, rate magnitude) of its records, and the
    // time they cover.
    let mut rates: Vec<Vec<(f64, f64)>> = vec![Vec::new(); motions.len()];
    let mut spans = vec![0.0; motions.len()];
    // Net rotation of each motion: the sum of the increments, exact for a
    // turn about a fixed axis (no coning), less the Earth rate the unit
    // sensed in the dwell before (a turn of 10 s senses 0.04 deg of it).
    let mut sums: Vec<Vector3<f64>> = vec![Vector3::zeros(); motions.len()];
    let mut m = 0;
    for timed in timed_records(source, scan, sample_rate_hz)? {
        let timed = timed?;
        let r_dt = timed.dt;
        let r = comp.record(&timed.record, r_dt);
        let t_mid = r.t - 0.5 * r_dt;
        while m < motions.len() && scan.segments[motions[m]].t_end < t_mid {
            m += 1;
        }
        if m == motions.len() {
            break;
        }
        if t_mid >= scan.segments[motions[m]].t_start {
            rates[m].push((t_mid, Vector3::from(r.dtheta).norm() / r_dt));
            spans[m] += r_dt;
            sums[m] += Vector3::from(r.dtheta);
        }
    }

    let mut rotations = Vec::new();
    let mut c_b_n = *c_b_n0;
    for (k, &si) in motions.iter().enumerate() {
        let seg = &scan.segments[si];
        let earth_b = match si.checked_sub(1).map(|i| &scan.segments[i]) {
            Some(prev) => comp.gyro(&(Vector3::from(prev.mean_omega_b) * dt), dt) / dt,
            None => Vector3::zeros(),
        };
        let rv = sums[k] - earth_b * spans[k];
        let angle = rv.norm();
        if angle < 1e-3 {
            return Err(DiagnoseError::Scheme(format!(
                "the motion at t = {:.1} s turns the unit by only {:.3} deg",
                seg.t_start - scan.t_begin,
                angle.to_degrees()
            )));
        }
        let u_b = rv / angle;
        let u_n = c_b_n * u_b;
        let body = nearest_axis(&u_b, Frame::Body);
        let nav = nearest_axis(&u_n, Frame::Nav);
        // Ties (a unit exactly at nominal) go to the body axis, SPEC's default.
        let (frame, (axis, off_axis, along)) = if nav.1 < body.1 {
            (Frame::Nav, nav)
        } else {
            (Frame::Body, body)
        };
        if off_axis > AXIS_TOLERANCE_DEG {
            return Err(DiagnoseError::Scheme(format!(
                "the motion at t = {:.1} s turns about [{:.3}, {:.3}, {:.3}] (body), [{:.3}, {:.3}, {:.3}] (navigation frame), {:.1} deg from any body axis and {:.1} deg from any navigation axis: only turns about one of these (SPEC §4) can be reconstructed",
                seg.t_start - scan.t_begin,
                u_b.x,
                u_b.y,
                u_b.z,
                u_n.x,
                u_n.y,
                u_n.z,
                body.1,
                nav.1
            )));
        }
        let signed = angle * along;
        // The attitude after the turn, as the simulator will turn it.
        let own = Vector3::from(axis.unit_vector());
        let axis_b = match frame {
            Frame::Body => own,
            Frame::Nav => c_b_n.transpose() * own,
        };
        c_b_n *= rotvec_to_dcm(&(axis_b * signed));
        let series = &rates[k];
        let peak = series.iter().map(|x| x.1).fold(0.0, f64::max);
        let crossing = |level: f64| -> Option<f64> {
            series.windows(2).find_map(|w| {
                let ((t0, r0), (t1, r1)) = (w[0], w[1]);
                (r0 < level && r1 >= level).then(|| t0 + (level - r0) / (r1 - r0) * (t1 - t0))
            })
        };
        let (t10, t90) = match (crossing(0.1 * peak), crossing(0.9 * peak)) {
            (Some(a), Some(b)) if b > a => (a, b),
            _ => {
                return Err(DiagnoseError::Scheme(format!(
                    "the motion at t = {:.1} s has no rate ramp to reconstruct",
                    seg.t_start - scan.t_begin
                )))
            }
        };
        let accel = 0.8 * peak / (t90 - t10);
        let t_start = t10 - 0.1 * peak / accel - scan.t_begin;
        rotations.push(RotationFound {
            axis,
            frame,
            angle_deg: signed.to_degrees(),
            rate_dps: peak.to_degrees(),
            accel_dps2: accel.to_degrees(),
            t_start,
            off_axis_deg: off_axis,
        });
    }

    let mut steps = Vec::new();
    let mut t = 0.0;
    for r in &rotations {
        steps.push(Step::Dwell {
            dwell_s: (r.t_start - t).max(0.0),
        });
        let rotate = Rotate {
            axis: r.axis,
            angle_deg: r.angle_deg,
            rate_dps: r.rate_dps,
            accel_dps2: r.accel_dps2,
            frame: Some(r.frame),
        };
        let d = RotationProfile::new(
            r.angle_deg.to_radians(),
            r.rate_dps.to_radians(),
            r.accel_dps2.to_radians(),
        )
        .duration();
        steps.push(Step::Rotate { rotate });
        t = t.max(r.t_start) + d;
    }
    let total = scan.t_end - scan.t_begin;
    steps.push(Step::Dwell {
        dwell_s: (total - t).max(0.0),
    });
    Ok(Reconstruction {
        scheme: Scheme {
            name: "reconstructed".into(),
            steps,
        },
        rotations,
    })
}
