//! The navigation errors' dynamics at rest on a fixed site (φ, δv in n):
//! F, the window transition exp(F T), the white noise's process noise Q(T),
//! and the window matrices the filter keeps per window length.

use nalgebra::{Matrix3, Matrix6, Vector3};

use crate::nav::attitude::skew;

/// The constant navigation-error dynamics at a fixed site.
pub fn error_dynamics(omega_ie_n: &Vector3<f64>, f_n: &Vector3<f64>) -> Matrix6<f64> {
    let mut f = Matrix6::zeros();
    let w = skew(omega_ie_n);
    f.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-w));
    f.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-skew(f_n)));
    f.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-2.0 * w));
    f
}

/// exp(F T) by its series; ‖F T‖ is dominated by the nilpotent φ→δv block,
/// so a handful of terms reach rounding for windows of seconds.
pub fn transition(f: &Matrix6<f64>, t: f64) -> Matrix6<f64> {
    let ft = f * t;
    let mut term = Matrix6::identity();
    let mut sum = Matrix6::identity();
    for k in 1..8 {
        term = term * ft / k as f64;
        sum += term;
    }
    sum
}

/// Q(T) = ∫₀ᵀ exp(F u) Q_c exp(F u)ᵀ du, by 16-interval Simpson (the
/// integrand is a low-order polynomial in u to rounding).
pub fn process_noise(f: &Matrix6<f64>, qc: &Matrix6<f64>, t: f64) -> Matrix6<f64> {
    const N: usize = 16;
    let h = t / N as f64;
    let mut q = Matrix6::zeros();
    for i in 0..=N {
        let w = if i == 0 || i == N {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let a = transition(f, i as f64 * h);
        q += a * qc * a.transpose() * w;
    }
    let q = q * (h / 3.0);
    (q + q.transpose()) * 0.5
}

/// Q(t) by its series Σₙ tⁿ⁺¹/(n+1)! Lⁿ(Q_c), L(X) = F X + X Fᵀ: F
/// enters a product at most once through the φ→δv block (g) and otherwise
/// through the Earth rate, so each term beyond the third is smaller by
/// about Ω t than the one before, and ten reach rounding for any window
/// of a run.
fn process_noise_series(f: &Matrix6<f64>, qc: &Matrix6<f64>, t: f64) -> Matrix6<f64> {
    let mut term = qc * t;
    let mut sum = term;
    for n in 1..10 {
        term = (f * term + term * f.transpose()) * (t / (n + 1) as f64);
        sum += term;
    }
    sum
}

/// The window matrices of one window length: exp(F T), and the response
/// of Q(T) to each entry of the white noise's density in n (Q is linear in
/// it; the density turns with the unit when the axes' noise differs).
pub(super) struct WindowCache {
    pub t: f64,
    pub phi: Matrix6<f64>,
    /// Q(T) for a unit density on entry (i, j) and (j, i) of the gyro
    /// block, then of the accelerometer block, i ≤ j.
    basis: [Matrix6<f64>; 12],
}

/// The symmetric 3 × 3 entries, i ≤ j, in `WindowCache::basis` order.
const SYM3: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

impl WindowCache {
    pub fn new(f: &Matrix6<f64>, t: f64) -> Self {
        let basis = std::array::from_fn(|k| {
            let (block, (i, j)) = (3 * (k / 6), SYM3[k % 6]);
            let mut qc = Matrix6::zeros();
            qc[(block + i, block + j)] = 1.0;
            qc[(block + j, block + i)] = 1.0;
            process_noise(f, &qc, t)
        });
        WindowCache {
            t,
            phi: transition(f, t),
            basis,
        }
    }

    /// Q(T) for the white densities `gyro_n`, `accel_n` (3 × 3, in n).
    pub fn white_noise(&self, gyro_n: &Matrix3<f64>, accel_n: &Matrix3<f64>) -> Matrix6<f64> {
        let mut q = Matrix6::zeros();
        for (k, b) in self.basis.iter().enumerate() {
            let (i, j) = SYM3[k % 6];
            let d = if k < 6 { gyro_n } else { accel_n };
            // An off-diagonal basis carries both (i, j) and (j, i).
            let v = d[(i, j)];
            if v != 0.0 {
                q += b * v;
            }
        }
        q
    }

    /// Whether a window of `t` seconds is reached from this one by a
    /// short step ([`WindowCache::over`]): any longer window, or one at
    /// most a quarter shorter (Q(T) − Q(δ) then keeps its digits).
    pub fn reaches(&self, t: f64) -> bool {
        t - self.t >= -0.25 * self.t
    }

    /// exp(F t) and the white noise's Q(t) for a window of `t` seconds
    /// from this window's matrices: a run with jittered stamps has windows
    /// of as many lengths as windows, and each would otherwise cost twelve
    /// integrals. With δ = t − T and Φ(δ) = exp(F δ): exp(F t) = exp(F T)
    /// Φ(δ), and Q(t) = Φ(δ) Q(T) Φ(δ)ᵀ + Q(δ), or Φ(δ) (Q(T) − Q(−δ))
    /// Φ(δ)ᵀ when δ < 0 (Q over consecutive stretches), both exact.
    pub fn over(
        &self,
        f: &Matrix6<f64>,
        t: f64,
        gyro_n: &Matrix3<f64>,
        accel_n: &Matrix3<f64>,
    ) -> (Matrix6<f64>, Matrix6<f64>) {
        let q_t = self.white_noise(gyro_n, accel_n);
        let delta = t - self.t;
        if delta == 0.0 {
            return (self.phi, q_t);
        }
        let step = transition(f, delta);
        let mut qc = Matrix6::zeros();
        qc.fixed_view_mut::<3, 3>(0, 0).copy_from(gyro_n);
        qc.fixed_view_mut::<3, 3>(3, 3).copy_from(accel_n);
        let q_step = process_noise_series(f, &qc, delta.abs());
        let q = if delta > 0.0 {
            step * q_t * step.transpose() + q_step
        } else {
            step * (q_t - q_step) * step.transpose()
        };
        (self.phi * step, (q + q.transpose()) * 0.5)
    }

    /// exp(F t) from this window's, as [`WindowCache::over`] makes it.
    pub fn phi_over(&self, f: &Matrix6<f64>, t: f64) -> Matrix6<f64> {
        let delta = t - self.t;
        if delta == 0.0 {
            self.phi
        } else {
            self.phi * transition(f, delta)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transition_matches_tilt_to_velocity_coupling() {
        // With Earth rate off, a tilt φ_E makes δv_N grow as −g φ_E t… with
        // f = [0,0,g]: δv̇ = φ × f = [φ_N g, −φ_E g, 0].
        let f = error_dynamics(&Vector3::zeros(), &Vector3::new(0.0, 0.0, 9.8));
        let a = transition(&f, 2.0);
        assert!((a[(4, 0)] + 9.8 * 2.0).abs() < 1e-12);
        assert!((a[(3, 1)] - 9.8 * 2.0).abs() < 1e-12);
        assert_eq!(a[(0, 0)], 1.0);
    }

    #[test]
    fn process_noise_has_the_random_walk_closed_form() {
        let f = error_dynamics(&Vector3::zeros(), &Vector3::new(0.0, 0.0, 9.8));
        let mut qc = Matrix6::zeros();
        for i in 0..6 {
            qc[(i, i)] = 1e-10;
        }
        let t = 1.5;
        let q = process_noise(&f, &qc, t);
        // Velocity: q t + g² q t³/3 (attitude noise integrated through g).
        assert!((q[(3, 3)] - (1e-10 * t + 9.8 * 9.8 * 1e-10 * t.powi(3) / 3.0)).abs() < 1e-22);
        assert!((q[(0, 0)] - 1e-10 * t).abs() < 1e-24);
    }

    /// A window's matrices reached from another length by a short step
    /// (jittered stamps, a bridged gap) are those made for its own length.
    #[test]
    fn matrices_over_another_length_equal_those_made_for_it() {
        let site = crate::nav::Site::REFERENCE;
        let f = error_dynamics(&site.omega_ie_n(), &site.f_rest_n());
        let c = crate::nav::attitude::rotvec_to_dcm(&Vector3::new(0.3, -0.2, 1.1));
        let gyro_n = c * Matrix3::from_diagonal(&Vector3::new(1e-12, 4e-12, 9e-13)) * c.transpose();
        let accel_n = c * Matrix3::from_diagonal(&Vector3::new(3e-9, 1e-9, 2e-9)) * c.transpose();
        let from = WindowCache::new(&f, 1.0);
        for t in [1.0, 1.004, 0.95, 0.8, 3.0] {
            let (phi, q) = from.over(&f, t, &gyro_n, &accel_n);
            let own = WindowCache::new(&f, t);
            let q_own = own.white_noise(&gyro_n, &accel_n);
            assert!((phi - own.phi).norm() < 1e-12 * own.phi.norm(), "Φ at {t}");
            assert_eq!(from.phi_over(&f, t), phi);
            assert!(
                (q - q_own).norm() < 1e-9 * q_own.norm(),
                "Q at {t}: {q} vs {q_own}"
            );
        }
    }
}
