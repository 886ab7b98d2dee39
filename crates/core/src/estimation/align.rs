//! Self-alignment at rest: coarse (analytic, from the mean specific force
//! and angular rate) then fine (a zero-velocity Kalman filter over the
//! first dwell). Works at any heading and any tilt that leaves the Earth
//! rate's horizontal part measurable (everywhere but near the poles).

use nalgebra::{Matrix3, Vector3};

use super::error::EstimationError;
use super::filter::{error_dynamics, SystematicFilter};
use super::noise_model::NoiseModel;
use crate::nav::{Site, Strapdown};
use crate::record::Record;

/// C_b^n from the mean specific force f^b and angular rate ω^b at rest:
/// up is along f, east along ω × f, north completes the frame (ENU).
pub fn coarse(f_b: &Vector3<f64>, omega_b: &Vector3<f64>) -> Result<Matrix3<f64>, EstimationError> {
    let up = f_b.try_normalize(1e-9).ok_or(EstimationError::CannotAlign(
        "no specific force in the first dwell: cannot level",
    ))?;
    let east = omega_b
        .cross(&up)
        .try_normalize(1e-15)
        .ok_or(EstimationError::CannotAlign(
            "no horizontal Earth rate in the first dwell: cannot find north",
        ))?;
    let north = up.cross(&east);
    // Rows of C_b^n are the navigation axes in body coordinates.
    Ok(Matrix3::from_rows(&[
        east.transpose(),
        north.transpose(),
        up.transpose(),
    ]))
}

/// C_b^n from the mean specific force f^b alone, for a unit whose gyros
/// cannot see the Earth rate: up along f, east along the body x axis
/// made horizontal (y when x points up), north completing the frame. The
/// heading is SPEC §4's nominal start (x east): one dwell of such a unit
/// cannot find it, the whole run can (`calib::heading` turns this
/// attitude to it).
pub fn coarse_level(f_b: &Vector3<f64>) -> Result<Matrix3<f64>, EstimationError> {
    let up = f_b.try_normalize(1e-9).ok_or(EstimationError::CannotAlign(
        "no specific force in the first dwell: cannot level",
    ))?;
    let horizontal = |axis: Vector3<f64>| (axis - up * axis.dot(&up)).try_normalize(0.1);
    let east = horizontal(Vector3::x())
        .or_else(|| horizontal(Vector3::y()))
        .expect("x and y cannot both be vertical");
    let north = up.cross(&east);
    Ok(Matrix3::from_rows(&[
        east.transpose(),
        north.transpose(),
        up.transpose(),
    ]))
}

/// How the fine alignment runs.
#[derive(Clone, Copy, Debug)]
pub struct FineAlignment {
    /// Start of the first record's interval, s.
    pub t0: f64,
    /// The nominal record interval, s.
    pub nominal_dt: f64,
    /// Records between zero-velocity updates.
    pub window: usize,
    /// Noise densities, rad/√s and m/s/√s.
    pub arw: f64,
    pub vrw: f64,
}

/// Fine alignment: navigates the (compensated) records of the first dwell,
/// each over its own interval (the record and its Δt, s), from the coarse
/// attitude with zero-velocity updates every `window` records, and returns
/// the attitude at the dwell's end — which, the unit resting, is its
/// attitude throughout the dwell.
pub fn fine(
    site: &Site,
    c_b_n: &Matrix3<f64>,
    records: impl Iterator<Item = (Record, f64)>,
    how: &FineAlignment,
) -> Result<Matrix3<f64>, EstimationError> {
    let FineAlignment {
        t0,
        nominal_dt,
        window,
        arw,
        vrw,
    } = *how;
    let f = error_dynamics(&site.omega_ie_n(), &site.f_rest_n());
    let mut p0 = nalgebra::Matrix6::zeros();
    // Coarse tilt is good to a milliradian, heading to some degrees.
    for (i, s) in [1e-2, 1e-2, 0.1, 1e-3, 1e-3, 1e-3].iter().enumerate() {
        p0[(i, i)] = s * s;
    }
    let mut kf = SystematicFilter::new(f, &p0, &[], &NoiseModel::white(arw, vrw), 0.0, 1e-6);
    let mut nav = Strapdown::new(site, c_b_n, t0, nominal_dt);
    let (mut n, mut t_update) = (0, t0);
    for (r, dt) in records {
        nav.update_over(&r, dt);
        n += 1;
        if n % window == 0 {
            kf.propagate(r.t - t_update, &nav.c_b_n());
            t_update = r.t;
            kf.update_zero_velocity(&nav.v_n, &nav.c_b_n())?;
            let (phi, dv) = kf.take_navigation_errors();
            nav.correct(&phi, &dv, &Vector3::zeros());
        }
    }
    Ok(nav.c_b_n())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::attitude::{attitude_difference_n, rotvec_to_dcm};

    #[test]
    fn coarse_alignment_recovers_a_tilted_turned_attitude() {
        let site = Site::REFERENCE;
        for heading_deg in [0.0, 73.0, 181.0, -95.0] {
            let c = rotvec_to_dcm(&Vector3::new(0.06, -0.08, f64::to_radians(heading_deg)));
            let f_b = c.transpose() * site.f_rest_n();
            let w_b = c.transpose() * site.omega_ie_n();
            let est = coarse(&f_b, &w_b).unwrap();
            assert!(
                attitude_difference_n(&est, &c).norm() < 1e-12,
                "heading {heading_deg}"
            );
        }
    }
}
