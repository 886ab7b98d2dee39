//! The motion of a turn by hand (SPEC §4 `flip`): the turned angle and the
//! path of the reference point as functions of the time τ since the flip
//! began.
//!
//! Both follow the S-curve s(u) = u − sin(2πu)/2π, u = τ/T, whose rate
//! 1 − cos 2πu starts and ends at zero, so the unit leaves and reaches
//! each dwell without a jump in angular rate or velocity. The height is
//! h·sin²(πu) = h(1 − cos 2πu)/2.

use std::f64::consts::{PI, TAU};

use nalgebra::Vector3;

use super::scheme::Flip;

/// A flip in SI: rad, s, m; the displacements are in n (ENU).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipProfile {
    /// Signed total angle, rad.
    pub angle: f64,
    pub duration: f64,
    /// Peak height, m.
    pub lift: f64,
    /// Horizontal displacement at the end, n (up component zero), m.
    pub shift_n: Vector3<f64>,
}

impl FlipProfile {
    pub fn new(flip: &Flip) -> Self {
        FlipProfile {
            angle: flip.angle_deg.to_radians(),
            duration: flip.duration_s,
            lift: flip.lift_m,
            shift_n: Vector3::new(flip.shift_m[0], flip.shift_m[1], 0.0),
        }
    }

    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// u = τ/T clamped to [0, 1].
    fn u(&self, tau: f64) -> f64 {
        (tau / self.duration).clamp(0.0, 1.0)
    }

    /// True for τ strictly inside the flip: rates and accelerations are
    /// zero outside it.
    fn inside(&self, tau: f64) -> bool {
        tau > 0.0 && tau < self.duration
    }

    /// s(u), s'(u) and s''(u) of the S-curve.
    fn s_curve(u: f64) -> (f64, f64, f64) {
        let (sin, cos) = (TAU * u).sin_cos();
        (u - sin / TAU, 1.0 - cos, TAU * sin)
    }

    /// Angle turned at τ, rad.
    pub fn angle_at(&self, tau: f64) -> f64 {
        self.angle * Self::s_curve(self.u(tau)).0
    }

    /// Angular rate at τ, rad/s.
    pub fn rate_at(&self, tau: f64) -> f64 {
        if !self.inside(tau) {
            return 0.0;
        }
        self.angle * Self::s_curve(self.u(tau)).1 / self.duration
    }

    /// Angular acceleration at τ, rad/s².
    pub fn accel_at(&self, tau: f64) -> f64 {
        if !self.inside(tau) {
            return 0.0;
        }
        self.angle * Self::s_curve(self.u(tau)).2 / (self.duration * self.duration)
    }

    /// Displacement of the reference point from where the flip began, n, m.
    pub fn position_at(&self, tau: f64) -> Vector3<f64> {
        let u = self.u(tau);
        let rise = (PI * u).sin();
        self.shift_n * Self::s_curve(u).0 + Vector3::new(0.0, 0.0, self.lift * rise * rise)
    }

    /// Velocity of the reference point relative to the Earth, n, m/s.
    pub fn velocity_at(&self, tau: f64) -> Vector3<f64> {
        if !self.inside(tau) {
            return Vector3::zeros();
        }
        let u = self.u(tau);
        let t = self.duration;
        // d/dt h sin²(πu) = h π sin(2πu) / T.
        self.shift_n * (Self::s_curve(u).1 / t)
            + Vector3::new(0.0, 0.0, self.lift * PI * (TAU * u).sin() / t)
    }

    /// Acceleration of the reference point relative to the Earth, n, m/s².
    /// One-sided at the ends like the turntable's profile: the lift's
    /// acceleration jumps there, and τ = 0 belongs to the flip.
    pub fn acceleration_at(&self, tau: f64) -> Vector3<f64> {
        if !(0.0..self.duration).contains(&tau) {
            return Vector3::zeros();
        }
        let u = self.u(tau);
        let t2 = self.duration * self.duration;
        self.shift_n * (Self::s_curve(u).2 / t2)
            + Vector3::new(0.0, 0.0, 2.0 * self.lift * PI * PI * (TAU * u).cos() / t2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile() -> FlipProfile {
        FlipProfile::new(&Flip {
            axis_b: [0.0, 1.0, 0.0],
            angle_deg: -92.0,
            duration_s: 1.3,
            lift_m: 0.05,
            shift_m: [0.03, -0.02],
        })
    }

    #[test]
    fn ends_at_the_full_angle_and_shift_at_rest() {
        let p = profile();
        assert!((p.angle_at(1.3) + 92f64.to_radians()).abs() < 1e-15);
        assert_eq!(p.angle_at(0.0), 0.0);
        let end = p.position_at(1.3);
        assert!((end - Vector3::new(0.03, -0.02, 0.0)).norm() < 1e-17);
        assert!((p.position_at(0.65).z - 0.05).abs() < 1e-17);
        assert_eq!(p.rate_at(1.3), 0.0);
        assert_eq!(p.velocity_at(0.0), Vector3::zeros());
    }

    #[test]
    fn rates_are_the_derivatives() {
        let p = profile();
        let h = 1e-6;
        for tau in [0.1, 0.4, 0.77, 1.2] {
            let d_angle = (p.angle_at(tau + h) - p.angle_at(tau - h)) / (2.0 * h);
            let d_rate = (p.rate_at(tau + h) - p.rate_at(tau - h)) / (2.0 * h);
            let d_pos = (p.position_at(tau + h) - p.position_at(tau - h)) / (2.0 * h);
            let d_vel = (p.velocity_at(tau + h) - p.velocity_at(tau - h)) / (2.0 * h);
            assert!((d_angle - p.rate_at(tau)).abs() < 1e-8);
            assert!((d_rate - p.accel_at(tau)).abs() < 1e-7);
            assert!((d_pos - p.velocity_at(tau)).norm() < 1e-9);
            assert!((d_vel - p.acceleration_at(tau)).norm() < 1e-8);
        }
    }
}
