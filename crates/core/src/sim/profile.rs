//! The trapezoidal rate profile of a rotation (SPEC §4): constant angular
//! acceleration up to the cruise rate, cruise, symmetric deceleration; a
//! triangle when the angle is too short to reach the rate.

/// A rotation's angle as a function of the time τ since it began.
/// All quantities in rad and s; `angle` carries the sign of the turn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotationProfile {
    /// Signed total angle.
    pub angle: f64,
    /// Peak rate reached (≤ the requested rate), > 0.
    pub peak_rate: f64,
    /// Angular acceleration magnitude, > 0.
    pub accel: f64,
    /// Duration of the acceleration (and of the deceleration) phase.
    pub t_accel: f64,
    /// Duration of the cruise phase (0 for a triangle).
    pub t_cruise: f64,
}

impl RotationProfile {
    /// The profile for a signed `angle` at cruise `rate` and `accel`.
    pub fn new(angle: f64, rate: f64, accel: f64) -> Self {
        let a = angle.abs();
        let (t_accel, t_cruise, peak_rate) = if a >= rate * rate / accel {
            (rate / accel, (a - rate * rate / accel) / rate, rate)
        } else {
            let t = (a / accel).sqrt();
            (t, 0.0, accel * t)
        };
        RotationProfile {
            angle,
            peak_rate,
            accel,
            t_accel,
            t_cruise,
        }
    }

    pub fn duration(&self) -> f64 {
        2.0 * self.t_accel + self.t_cruise
    }

    fn sign(&self) -> f64 {
        if self.angle < 0.0 {
            -1.0
        } else {
            1.0
        }
    }

    /// Times (since the start) where the acceleration jumps, inside the
    /// rotation: the ends of the acceleration and cruise phases.
    pub fn inner_breakpoints(&self) -> [f64; 2] {
        [self.t_accel, self.t_accel + self.t_cruise]
    }

    /// Angle turned at τ, clamped to [0, duration].
    pub fn angle_at(&self, tau: f64) -> f64 {
        let d = self.duration();
        let tau = tau.clamp(0.0, d);
        let a = self.accel;
        let magnitude = if tau <= self.t_accel {
            0.5 * a * tau * tau
        } else if tau <= self.t_accel + self.t_cruise {
            0.5 * a * self.t_accel * self.t_accel + self.peak_rate * (tau - self.t_accel)
        } else {
            let rest = d - tau;
            self.angle.abs() - 0.5 * a * rest * rest
        };
        self.sign() * magnitude
    }

    /// Angular rate at τ.
    pub fn rate_at(&self, tau: f64) -> f64 {
        let d = self.duration();
        if !(0.0..=d).contains(&tau) {
            return 0.0;
        }
        let magnitude = if tau <= self.t_accel {
            self.accel * tau
        } else if tau <= self.t_accel + self.t_cruise {
            self.peak_rate
        } else {
            self.accel * (d - tau)
        };
        self.sign() * magnitude
    }

    /// Angular acceleration at τ (one-sided at the breakpoints: the value
    /// of the phase that τ begins).
    pub fn accel_at(&self, tau: f64) -> f64 {
        let d = self.duration();
        if !(0.0..d).contains(&tau) {
            return 0.0;
        }
        let magnitude = if tau < self.t_accel {
            self.accel
        } else if tau < self.t_accel + self.t_cruise {
            0.0
        } else {
            -self.accel
        };
        self.sign() * magnitude
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const D: f64 = std::f64::consts::PI / 180.0;

    #[test]
    fn quarter_turn_at_default_rates() {
        let p = RotationProfile::new(90.0 * D, 10.0 * D, 20.0 * D);
        assert!((p.t_accel - 0.5).abs() < 1e-15);
        assert!((p.t_cruise - 8.5).abs() < 1e-12);
        assert!((p.duration() - 9.5).abs() < 1e-12);
        assert!((p.angle_at(p.duration()) - 90.0 * D).abs() < 1e-15);
        assert!((p.angle_at(0.5) - 2.5 * D).abs() < 1e-15);
        assert!((p.rate_at(4.0) - 10.0 * D).abs() < 1e-15);
    }

    #[test]
    fn short_negative_turn_is_a_triangle() {
        let p = RotationProfile::new(-2.0 * D, 10.0 * D, 20.0 * D);
        assert_eq!(p.t_cruise, 0.0);
        // a t² = 2° ⇒ t = √0.1 s.
        assert!((p.t_accel - 0.1f64.sqrt()).abs() < 1e-15);
        assert!(p.peak_rate < 10.0 * D);
        assert!((p.angle_at(p.duration()) + 2.0 * D).abs() < 1e-16);
        assert!(p.rate_at(0.1) < 0.0);
        // Rate is the derivative of angle.
        let (t, h) = (0.2, 1e-6);
        let numeric = (p.angle_at(t + h) - p.angle_at(t - h)) / (2.0 * h);
        assert!((numeric - p.rate_at(t)).abs() < 1e-9);
    }
}
