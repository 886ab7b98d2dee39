//! Reconstructing a run's rotation scheme from its own gyro data: the
//! dwells from the segmentation, and for each motion its axis and angle
//! (net rotation vector) and its trapezoidal profile (peak rate, angular
//! acceleration, start time) from the record rates.
//!
//! The ramp of a trapezoidal profile is linear in time and a record's
//! mean rate is the rate at its mid-time, so the times where the rate
//! crosses 10 % and 90 % of its peak (interpolated between records) give
//! the acceleration and the start to a small fraction of a record.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::DiagnoseError;
use crate::calib::estimate::Prescan;
use crate::calib::{RecordSource, SegmentKind};
use crate::model::Compensator;
use crate::sim::profile::RotationProfile;
use crate::sim::scheme::{Axis, Rotate, Step};
use crate::sim::Scheme;

/// Largest angle between a motion's rotation vector and the nearest body
/// axis for it to be taken as a turn about that axis, deg.
const AXIS_TOLERANCE_DEG: f64 = 3.0;

/// One reconstructed rotation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RotationFound {
    pub axis: String,
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

/// Reconstructs the scheme with one streaming pass over the records,
/// compensated with `comp` (the calibration) so that angles and rates are
/// the table's, not the gyros' raw readings.
pub fn reconstruct(
    source: &dyn RecordSource,
    scan: &Prescan,
    sample_rate_hz: f64,
    comp: &Compensator,
) -> Result<Reconstruction, DiagnoseError> {
    let dt = 1.0 / sample_rate_hz;
    let motions: Vec<usize> = scan
        .segments
        .iter()
        .enumerate()
        .filter(|(_, s)| s.kind == SegmentKind::Motion)
        .map(|(i, _)| i)
        .collect();
    // Per motion: (mid-time, rate magnitude) of its records.
    let mut rates: Vec<Vec<(f64, f64)>> = vec![Vec::new(); motions.len()];
    // Net rotation of each motion: the sum of the increments, exact for a
    // turn about a fixed axis (no coning), less the Earth rate the unit
    // sensed in the dwell before (a turn of 10 s senses 0.04 deg of it).
    let mut sums: Vec<Vector3<f64>> = vec![Vector3::zeros(); motions.len()];
    let mut m = 0;
    for r in source.records()? {
        let r = comp.record(&r?, dt);
        let t_mid = r.t - 0.5 * dt;
        while m < motions.len() && scan.segments[motions[m]].t_end < t_mid {
            m += 1;
        }
        if m == motions.len() {
            break;
        }
        if t_mid >= scan.segments[motions[m]].t_start {
            rates[m].push((t_mid, Vector3::from(r.dtheta).norm() / dt));
            sums[m] += Vector3::from(r.dtheta);
        }
    }

    let mut rotations = Vec::new();
    for (k, &si) in motions.iter().enumerate() {
        let seg = &scan.segments[si];
        let earth_b = match si.checked_sub(1).map(|i| &scan.segments[i]) {
            Some(prev) => comp.gyro(&(Vector3::from(prev.mean_omega_b) * dt), dt) / dt,
            None => Vector3::zeros(),
        };
        let rv = sums[k] - earth_b * (rates[k].len() as f64 * dt);
        let angle = rv.norm();
        if angle < 1e-3 {
            return Err(DiagnoseError::Scheme(format!(
                "the motion at t = {:.1} s turns the unit by only {:.3} deg",
                seg.t_start - scan.t_begin,
                angle.to_degrees()
            )));
        }
        let (axis_i, axis) = (0..3)
            .map(|i| (i, [Axis::X, Axis::Y, Axis::Z][i]))
            .max_by(|a, b| rv[a.0].abs().total_cmp(&rv[b.0].abs()))
            .unwrap_or((0, Axis::X));
        let off_axis = (rv[axis_i].abs() / angle)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        if off_axis > AXIS_TOLERANCE_DEG {
            return Err(DiagnoseError::Scheme(format!(
                "the motion at t = {:.1} s turns about [{:.3}, {:.3}, {:.3}] (body), {:.1} deg from any body axis: only turns about body axes can be reconstructed",
                seg.t_start - scan.t_begin,
                rv.x / angle,
                rv.y / angle,
                rv.z / angle,
                off_axis
            )));
        }
        let signed = rv[axis_i];
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
            axis: format!("{axis:?}").to_lowercase(),
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
            axis: match r.axis.as_str() {
                "x" => Axis::X,
                "y" => Axis::Y,
                _ => Axis::Z,
            },
            angle_deg: r.angle_deg,
            rate_dps: r.rate_dps,
            accel_dps2: r.accel_dps2,
            frame: None,
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
