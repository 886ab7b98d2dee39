//! How each parameter error moves the navigation errors over one record.
//!
//! With the data compensated by the current estimate, the residual errors
//! δp act on the compensated increments as δω^b Δt = δK_g Δθ + δb_g Δt and
//! δf^b Δt = δK_a Δv + δb_a Δt + δD_a (Δv∘Δv)/Δt (SPEC §2 model, residual
//! form). They enter the error dynamics (attitude error φ in n with
//! C̃_b^n = exp([φ×]) C_b^n, velocity error δv^n):
//!
//!   φ̇ = −ω_ie^n × φ + C_b^n δω^b,     δv̇ = φ × f^n − 2 ω_ie^n × δv + C_b^n δf^b.
//!
//! So over a record the parameter part of the change is C_b^n (mid-record)
//! times a column per parameter, written here. Indices follow
//! [`crate::model::PARAMETERS`].

use nalgebra::{Matrix3, Vector3};

use crate::model::params::Group;

/// Which rows a column drives: attitude (0..3) or velocity (3..6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rows {
    Attitude,
    Velocity,
}

/// Calls `add(param_index, rows, column)` for every non-zero column of the
/// base model's sensitivity over one record. Inlined: it runs for every
/// record of every pass, and its closure's calls then fold into the
/// caller's loop.
#[inline(always)]
pub fn base_columns(
    c_b_n: &Matrix3<f64>,
    dtheta: &Vector3<f64>,
    dv: &Vector3<f64>,
    dt: f64,
    mut add: impl FnMut(usize, Rows, Vector3<f64>),
) {
    let c = |i: usize| c_b_n.column(i).into_owned();
    let (cx, cy, cz) = (c(0), c(1), c(2));
    use Rows::{Attitude as A, Velocity as V};
    let axes = [cx, cy, cz];
    // Gyro biases, scale factors, misalignments (upper triangle of K_g).
    let (gb, gs, gm) = (
        Group::GyroBias.first(),
        Group::GyroScale.first(),
        Group::GyroMisalign.first(),
    );
    for (i, axis) in axes.iter().enumerate() {
        add(gb + i, A, axis * dt);
    }
    for (i, axis) in axes.iter().enumerate() {
        add(gs + i, A, axis * dtheta[i]);
    }
    add(gm, A, cx * dtheta.y); // M_gxy
    add(gm + 1, A, cx * dtheta.z); // M_gxz
    add(gm + 2, A, cy * dtheta.z); // M_gyz
                                   // Accelerometer biases, scale factors, misalignments, quadratic terms.
    let (ab, as_, am, aq) = (
        Group::AccelBias.first(),
        Group::AccelScale.first(),
        Group::AccelMisalign.first(),
        Group::AccelQuad.first(),
    );
    for (i, axis) in axes.iter().enumerate() {
        add(ab + i, V, axis * dt);
    }
    for (i, axis) in axes.iter().enumerate() {
        add(as_ + i, V, axis * dv[i]);
    }
    add(am, V, cx * dv.y); // M_axy
    add(am + 1, V, cx * dv.z); // M_axz
    add(am + 2, V, cy * dv.x); // M_ayx
    add(am + 3, V, cy * dv.z); // M_ayz
    add(am + 4, V, cz * dv.x); // M_azx
    add(am + 5, V, cz * dv.y); // M_azy
    for (i, axis) in axes.iter().enumerate() {
        add(aq + i, V, axis * (dv[i] * dv[i] / dt));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ErrorParameters;

    /// The columns, weighted by a parameter vector, must equal the change
    /// the error model makes to the increments (rotated to n).
    #[test]
    fn columns_reproduce_the_error_model() {
        let mut p = ErrorParameters::paper();
        for (i, v) in p.si.iter_mut().enumerate() {
            *v *= 1.0 + 0.1 * i as f64 * if i % 2 == 0 { 1.0 } else { -1.0 };
        }
        let c = crate::nav::attitude::rotvec_to_dcm(&Vector3::new(0.3, -1.2, 2.0));
        let dtheta = Vector3::new(1e-3, -2e-3, 1.7e-3);
        let dv = Vector3::new(0.03, -0.05, 0.08);
        let dt = 0.01;
        let mut phi = Vector3::zeros();
        let mut v = Vector3::zeros();
        base_columns(&c, &dtheta, &dv, dt, |i, rows, col| match rows {
            Rows::Attitude => phi += col * p.si[i],
            Rows::Velocity => v += col * p.si[i],
        });
        let expect_phi = c * (p.k_g() * dtheta + p.b_g() * dt);
        let expect_v =
            c * (p.k_a() * dv + p.b_a() * dt + p.d_a().component_mul(&dv.component_mul(&dv)) / dt);
        assert!((phi - expect_phi).norm() < 1e-18);
        assert!((v - expect_v).norm() < 1e-16);
    }
}
