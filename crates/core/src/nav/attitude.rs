//! Attitude algebra: rotation vectors, direction cosine matrices and
//! quaternions, in the convention C_b^n v^b = v^n.
//!
//! Every function here is exact (no small-angle truncation) and keeps full
//! precision near zero angle, where the calibration lives.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// The skew-symmetric matrix [v×], so that [v×] w = v × w.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The vector of a skew-symmetric matrix (inverse of [`skew`]), taking the
/// antisymmetric part of `m`.
pub fn unskew(m: &Matrix3<f64>) -> Vector3<f64> {
    Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    ) * 0.5
}

/// sin(x)/x and (1 − cos x)/x², accurate near 0.
fn rodrigues_coefficients(angle: f64) -> (f64, f64) {
    let a2 = angle * angle;
    if angle.abs() < 1e-4 {
        // Taylor series; the next terms are below 1e-20 here.
        (
            1.0 - a2 / 6.0 + a2 * a2 / 120.0,
            0.5 - a2 / 24.0 + a2 * a2 / 720.0,
        )
    } else {
        (angle.sin() / angle, (1.0 - angle.cos()) / a2)
    }
}

/// exp([φ×]): the DCM of a rotation by |φ| about φ (Rodrigues' formula).
pub fn rotvec_to_dcm(phi: &Vector3<f64>) -> Matrix3<f64> {
    let (a, b) = rodrigues_coefficients(phi.norm());
    let k = skew(phi);
    Matrix3::identity() + k * a + k * k * b
}

/// log of a DCM: the rotation vector φ with exp([φ×]) = c, |φ| ≤ π.
pub fn dcm_to_rotvec(c: &Matrix3<f64>) -> Vector3<f64> {
    // Through the quaternion: robust at every angle including near π.
    quat_to_rotvec(&UnitQuaternion::from_matrix(c))
}

/// The unit quaternion of rotation vector φ: [cos(θ/2), sin(θ/2) φ/θ],
/// θ = |φ|. Below 0.1 rad (a record's turn: the strapdown calls this for
/// every record) by the half angle's series, which needs no square root
/// or sine and whose first omitted term is below 1e-19.
pub fn rotvec_to_quat(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    let theta2 = phi.norm_squared();
    if theta2 >= 1e-2 {
        return UnitQuaternion::from_scaled_axis(*phi);
    }
    let h2 = 0.25 * theta2;
    // cos h and sin(h)/h to h⁸, by Horner.
    let cos_h = 1.0 - h2 / 2.0 * (1.0 - h2 / 12.0 * (1.0 - h2 / 30.0 * (1.0 - h2 / 56.0)));
    let sinc_h = 1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0 * (1.0 - h2 / 72.0)));
    let v = phi * (0.5 * sinc_h);
    UnitQuaternion::new_unchecked(Quaternion::new(cos_h, v.x, v.y, v.z))
}

/// The rotation vector of a unit quaternion, |φ| ≤ π.
pub fn quat_to_rotvec(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let q = if q.w < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        *q
    };
    let v = q.imag();
    let s = v.norm();
    if s < 1e-12 {
        // 2·asin(s)/s → 2 as s → 0; w ≈ 1.
        return v * 2.0;
    }
    let angle = 2.0 * s.atan2(q.w);
    v * (angle / s)
}

/// The small rotation between two attitudes, as a rotation vector in n:
/// φ with C_a = exp([φ×]) C_b. This is the attitude error convention used
/// across sinscal (C̃_b^n = exp([φ×]) C_b^n, φ the misalignment in n).
pub fn attitude_difference_n(c_a: &Matrix3<f64>, c_b: &Matrix3<f64>) -> Vector3<f64> {
    dcm_to_rotvec(&(c_a * c_b.transpose()))
}

/// Roll, pitch and heading (rad) of C_b^n, with y_b the forward axis:
/// pitch is the elevation of y_b, roll the tilt of x_b about y_b, heading
/// the angle of y_b's horizontal projection from North, clockwise positive.
pub fn euler_from_dcm(c_b_n: &Matrix3<f64>) -> (f64, f64, f64) {
    let pitch = c_b_n[(2, 1)].clamp(-1.0, 1.0).asin();
    let roll = (-c_b_n[(2, 0)]).atan2(c_b_n[(2, 2)]);
    let heading = c_b_n[(0, 1)].atan2(c_b_n[(1, 1)]);
    (roll, pitch, heading)
}

/// Re-orthonormalises a DCM that has drifted numerically.
pub fn orthonormalize(c: &Matrix3<f64>) -> Matrix3<f64> {
    UnitQuaternion::from_matrix(c)
        .to_rotation_matrix()
        .into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn close(a: &Matrix3<f64>, b: &Matrix3<f64>, tol: f64) -> bool {
        (a - b).abs().max() < tol
    }

    #[test]
    fn rodrigues_matches_closed_form_about_z() {
        let c = rotvec_to_dcm(&Vector3::new(0.0, 0.0, 0.3));
        let (s, k) = (0.3f64.sin(), 0.3f64.cos());
        let expected = Matrix3::new(k, -s, 0.0, s, k, 0.0, 0.0, 0.0, 1.0);
        assert!(close(&c, &expected, 1e-15));
    }

    #[test]
    fn exp_log_round_trip_at_many_angles() {
        for &angle in &[0.0, 1e-12, 1e-7, 1e-4, 0.1, 1.0, 3.0, PI - 1e-6] {
            let phi = Vector3::new(0.3, -0.5, 0.81).normalize() * angle;
            let back = dcm_to_rotvec(&rotvec_to_dcm(&phi));
            assert!((back - phi).norm() < 1e-13 * (1.0 + angle), "angle {angle}");
            let q = rotvec_to_quat(&phi);
            assert!(close(
                &q.to_rotation_matrix().into_inner(),
                &rotvec_to_dcm(&phi),
                1e-15
            ));
        }
    }

    /// The series below 0.1 rad against the sines, on both sides of the
    /// switch.
    #[test]
    fn quaternion_series_agrees_with_the_sines() {
        for &angle in &[0.0, 1e-9, 1e-5, 3e-3, 0.02, 0.0999, 0.1, 0.1001] {
            let phi = Vector3::new(-0.7, 0.2, 0.41).normalize() * angle;
            let (q, exact) = (rotvec_to_quat(&phi), UnitQuaternion::from_scaled_axis(phi));
            assert!((q.coords - exact.coords).amax() < 2e-16, "angle {angle}");
            assert!((q.norm() - 1.0).abs() < 4e-16, "angle {angle}");
        }
    }

    #[test]
    fn attitude_difference_is_small_angle_in_n() {
        let c = rotvec_to_dcm(&Vector3::new(0.2, 0.4, -1.0));
        let phi = Vector3::new(1e-6, -2e-6, 3e-6);
        let c_err = rotvec_to_dcm(&phi) * c;
        assert!((attitude_difference_n(&c_err, &c) - phi).norm() < 1e-18 + 1e-15);
    }

    #[test]
    fn skew_unskew() {
        let v = Vector3::new(1.0, 2.0, 3.0);
        let w = Vector3::new(-0.5, 0.25, 4.0);
        assert_eq!(skew(&v) * w, v.cross(&w));
        assert_eq!(unskew(&skew(&v)), v);
    }

    #[test]
    fn euler_of_heading_rotation() {
        // Rotating the body 30° about Up (counter-clockwise seen from above)
        // turns y_b from North towards West: heading −30°.
        let c = rotvec_to_dcm(&Vector3::new(0.0, 0.0, 30f64.to_radians()));
        let (r, p, y) = euler_from_dcm(&c);
        assert!(r.abs() < 1e-15 && p.abs() < 1e-15);
        assert!((y + 30f64.to_radians()).abs() < 1e-15);
    }
}
