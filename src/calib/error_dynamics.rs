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
}
