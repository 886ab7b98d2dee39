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
    let sensed = sense_motions(source, scan, sample_rate_hz, comp, &motions)?;
    let mut rotations = Vec::new();
    let mut c_b_n = *c_b_n0;
    for (motion, &si) in sensed.iter().zip(&motions) {
        let t_rel = scan.segments[si].t_start - scan.t_begin;
        // Less the Earth rate the unit sensed in the dwell before (a turn
        // of 10 s senses 0.04 deg of it).
        let earth_b = match si.checked_sub(1).map(|i| &scan.segments[i]) {
            Some(prev) => comp.gyro(&(Vector3::from(prev.mean_omega_b) * dt), dt) / dt,
            None => Vector3::zeros(),
        };
        let turn = Turn::of(&(motion.sum - earth_b * motion.span), &c_b_n, t_rel)?;
        // The attitude after the turn, as the simulator will turn it.
        let own = Vector3::from(turn.axis.unit_vector());
        let axis_b = match turn.frame {
            Frame::Body => own,
            Frame::Nav => c_b_n.transpose() * own,
        };
        c_b_n *= rotvec_to_dcm(&(axis_b * turn.signed_rad));
        let (peak, accel, t10) = rate_ramp(&motion.rates, t_rel)?;
        rotations.push(RotationFound {
            axis: turn.axis,
            frame: turn.frame,
            angle_deg: turn.signed_rad.to_degrees(),
            rate_dps: peak.to_degrees(),
            accel_dps2: accel.to_degrees(),
            t_start: t10 - 0.1 * peak / accel - scan.t_begin,
            off_axis_deg: turn.off_axis_deg,
        });
    }
    Ok(Reconstruction {
        scheme: scheme_of(&rotations, scan.t_end - scan.t_begin),
        rotations,
    })
}

/// What one motion's records show: (mid-time, rate magnitude) of each,
/// the time they cover, and their net rotation (the sum of the
/// increments, exact for a turn about a fixed axis: no coning).
#[derive(Clone)]
struct MotionSensed {
    rates: Vec<(f64, f64)>,
    span: f64,
    sum: Vector3<f64>,
}

/// One streaming pass over the compensated records, gathering each
/// motion's (`motions`: their segment indices, in time order).
fn sense_motions(
    source: &dyn RecordSource,
    scan: &Prescan,
    sample_rate_hz: f64,
    comp: &Compensator,
    motions: &[usize],
) -> Result<Vec<MotionSensed>, DiagnoseError> {
    let empty = MotionSensed {
        rates: Vec::new(),
        span: 0.0,
        sum: Vector3::zeros(),
    };
    let mut sensed = vec![empty; motions.len()];
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
            let motion = &mut sensed[m];
            motion
                .rates
                .push((t_mid, Vector3::from(r.dtheta).norm() / r_dt));
            motion.span += r_dt;
            motion.sum += Vector3::from(r.dtheta);
        }
    }
    Ok(sensed)
}

/// A motion's net rotation read as a turn about one axis of the body or
/// of the navigation frame, whichever it is nearer.
struct Turn {
    axis: Axis,
    frame: Frame,
    off_axis_deg: f64,
    signed_rad: f64,
}

impl Turn {
    /// `rotation_b`: the net rotation vector in the body frame before the
    /// turn, `c_b_n` the attitude then; `t_rel` (s from the run's start)
    /// names the motion in an error.
    fn of(
        rotation_b: &Vector3<f64>,
        c_b_n: &Matrix3<f64>,
        t_rel: f64,
    ) -> Result<Turn, DiagnoseError> {
        let angle = rotation_b.norm();
        if angle < 1e-3 {
            return Err(DiagnoseError::Scheme(format!(
                "the motion at t = {t_rel:.1} s turns the unit by only {:.3} deg",
                angle.to_degrees()
            )));
        }
        let u_b = rotation_b / angle;
        let u_n = c_b_n * u_b;
        let body = nearest_axis(&u_b, Frame::Body);
        let nav = nearest_axis(&u_n, Frame::Nav);
        // Ties (a unit exactly at nominal) go to the body axis, SPEC's default.
        let (frame, (axis, off_axis_deg, along)) = if nav.1 < body.1 {
            (Frame::Nav, nav)
        } else {
            (Frame::Body, body)
        };
        if off_axis_deg > AXIS_TOLERANCE_DEG {
            return Err(DiagnoseError::Scheme(format!(
                "the motion at t = {t_rel:.1} s turns about [{:.3}, {:.3}, {:.3}] (body), [{:.3}, {:.3}, {:.3}] (navigation frame), {:.1} deg from any body axis and {:.1} deg from any navigation axis: only turns about one of these (SPEC §4) can be reconstructed",
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
        Ok(Turn {
            axis,
            frame,
            off_axis_deg,
            signed_rad: angle * along,
        })
    }
}

/// A motion's rate profile read as a trapezoid: its peak rate (rad/s), the
/// acceleration from the 10 % to the 90 % crossing of the peak (rad/s²)
/// and the time of the 10 % crossing.
fn rate_ramp(series: &[(f64, f64)], t_rel: f64) -> Result<(f64, f64, f64), DiagnoseError> {
    let peak = series.iter().map(|x| x.1).fold(0.0, f64::max);
    let crossing = |level: f64| -> Option<f64> {
        series.windows(2).find_map(|w| {
            let ((t0, r0), (t1, r1)) = (w[0], w[1]);
            (r0 < level && r1 >= level).then(|| t0 + (level - r0) / (r1 - r0) * (t1 - t0))
        })
    };
    match (crossing(0.1 * peak), crossing(0.9 * peak)) {
        (Some(t10), Some(t90)) if t90 > t10 => Ok((peak, 0.8 * peak / (t90 - t10), t10)),
        _ => Err(DiagnoseError::Scheme(format!(
            "the motion at t = {t_rel:.1} s has no rate ramp to reconstruct"
        ))),
    }
}

/// The scheme the rotations make: each turn at its start, dwells between,
/// the last dwell to the run's end (`total_s`).
fn scheme_of(rotations: &[RotationFound], total_s: f64) -> Scheme {
    let mut steps = Vec::new();
    let mut t = 0.0;
    for r in rotations {
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
    steps.push(Step::Dwell {
        dwell_s: (total_s - t).max(0.0),
    });
    Scheme {
        name: "reconstructed".into(),
        steps,
    }
}
