//! The systematic calibration Kalman filter: navigation errors (attitude
//! φ, velocity δv, in n) plus constant parameter states, propagated over
//! windows of records and updated with zero velocity during dwells.
//!
//! It runs in Friedland's two-stage form, which for constant parameters is
//! algebraically the full Kalman filter: a small "bias-free" filter for the
//! six navigation errors (mean x̄, covariance P̄), the sensitivity
//! V = ∂x/∂p of the navigation errors to the parameters, and the
//! parameters' information J and information vector h. The covariance
//! form of the 30-state filter loses the parameter covariance to
//! cancellation here: zero-velocity updates are nearly exact (σ ~ 1 µm/s)
//! while priors are thousands of times wider than the posteriors, and its
//! σ came out several times too small. Information only accumulates
//! positive terms, so it keeps full precision; P_pp = J⁻¹ by Cholesky.
//!
//! Structure exploited:
//! - the unit's reference point rests throughout, so the specific force in
//!   n is [0, 0, g] and the navigation-error dynamics F are constant: the
//!   window transition A = exp(F T) and process noise Q(T) are computed
//!   once per window length;
//! - parameters enter through B = Σ_j exp(F (T − τ_j)) B_j, accumulated per
//!   record from the zeroth, first and second time moments of the
//!   per-record columns B_j (the F³ term is below 1e-7 of the rest for 1 s
//!   windows);
//! - ARW and VRW are isotropic, so their process noise does not depend on
//!   the attitude.
//!
//! Parameter states are kept in units of their prior σ so that J starts as
//! the identity. The navigation update is the Joseph form, expanded for a
//! measurement that selects the velocity rows.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3, Vector6};

use super::error::CalibError;
use super::sensitivity::Rows;
use crate::nav::attitude::skew;

/// Number of navigation-error states: φ (0..3), δv (3..6).
pub const NAV: usize = 6;

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

/// One zero-velocity update's innovation in two-stage form: the full
/// innovation is `y_bar − m p̂` for a parameter estimate p̂ (scaled units).
#[derive(Clone, Debug)]
pub struct Innovation {
    /// Bias-free innovation, m/s.
    pub y_bar: Vector3<f64>,
    /// Its sensitivity to the scaled parameters (3 × n_p).
    pub m: DMatrix<f64>,
    /// The bias-free innovation's covariance: ȳ − m p is white with this
    /// covariance for the true parameters p.
    pub s: Matrix3<f64>,
}

/// The navigation part: the bias-free estimate and its covariance.
#[derive(Clone, Debug)]
pub struct NavState {
    pub x: Vector6<f64>,
    pub p: Matrix6<f64>,
}

/// The filter. `n_p` parameter states follow the navigation states.
pub struct SystematicFilter {
    pub nav: NavState,
    /// Sensitivity of the navigation errors to the (scaled) parameters.
    v: DMatrix<f64>,
    /// Parameter information and information vector (scaled units).
    j: DMatrix<f64>,
    h: DVector<f64>,
    n_p: usize,
    /// Prior σ of each parameter, SI: state i is δp_i / scale_i.
    scale: Vec<f64>,
    f: Matrix6<f64>,
    qc: Matrix6<f64>,
    zupt_var: f64,
    cache: Option<(f64, Matrix6<f64>, Matrix6<f64>)>,
    // Window accumulators: Σ B_j, Σ τ_j B_j, Σ τ_j² B_j.
    s0: DMatrix<f64>,
    s1: DMatrix<f64>,
    s2: DMatrix<f64>,
}

impl SystematicFilter {
    /// `p0_nav` is the initial navigation covariance; `prior_sigma` the
    /// prior 1-σ of each parameter state (SI); `arw`, `vrw` the noise
    /// densities (rad/√s, m/s/√s); `zupt_sigma` the zero-velocity
    /// measurement σ (m/s).
    pub fn new(
        f: Matrix6<f64>,
        p0_nav: &Matrix6<f64>,
        prior_sigma: &[f64],
        arw: f64,
        vrw: f64,
        zupt_sigma: f64,
    ) -> Self {
        let n_p = prior_sigma.len();
        let mut qc = Matrix6::zeros();
        for i in 0..3 {
            qc[(i, i)] = arw * arw;
            qc[(3 + i, 3 + i)] = vrw * vrw;
        }
        SystematicFilter {
            nav: NavState {
                x: Vector6::zeros(),
                p: *p0_nav,
            },
            v: DMatrix::zeros(NAV, n_p),
            j: DMatrix::identity(n_p, n_p),
            h: DVector::zeros(n_p),
            n_p,
            scale: prior_sigma.to_vec(),
            f,
            qc,
            zupt_var: zupt_sigma * zupt_sigma,
            cache: None,
            s0: DMatrix::zeros(NAV, n_p),
            s1: DMatrix::zeros(NAV, n_p),
            s2: DMatrix::zeros(NAV, n_p),
        }
    }

    pub fn n_params(&self) -> usize {
        self.n_p
    }

    /// Adds one parameter column of the current record: `col` (SI per
    /// unit of parameter) drives `rows`; `tau` is the record's mid time
    /// from the window start.
    #[inline]
    pub fn add_column(&mut self, param: usize, rows: Rows, col: &Vector3<f64>, tau: f64) {
        let r0 = match rows {
            Rows::Attitude => 0,
            Rows::Velocity => 3,
        };
        let v = col * self.scale[param];
        let terms = [
            (&mut self.s0, v),
            (&mut self.s1, v * tau),
            (&mut self.s2, v * (tau * tau)),
        ];
        for (s, add) in terms {
            // Rows r0..r0 + 3 of column `param`, one bounds check (it runs
            // 24 times a record).
            let at = param * NAV + r0;
            for (x, a) in s.as_mut_slice()[at..at + 3].iter_mut().zip(add.iter()) {
                *x += a;
            }
        }
    }

    fn window_matrices(&mut self, t: f64) -> (Matrix6<f64>, Matrix6<f64>) {
        match self.cache {
            Some((ct, a, q)) if ct == t => (a, q),
            _ => {
                let a = transition(&self.f, t);
                let q = process_noise(&self.f, &self.qc, t);
                self.cache = Some((t, a, q));
                (a, q)
            }
        }
    }

    /// Propagates over a window of length `t` whose records were added
    /// with [`SystematicFilter::add_column`], and clears the accumulators.
    pub fn propagate(&mut self, t: f64) {
        let (a, q) = self.window_matrices(t);
        self.nav.x = a * self.nav.x;
        let p = a * self.nav.p * a.transpose() + q;
        self.nav.p = (p + p.transpose()) * 0.5;
        if self.n_p > 0 {
            let fm = DMatrix::from_column_slice(NAV, NAV, self.f.as_slice());
            let am = DMatrix::from_column_slice(NAV, NAV, a.as_slice());
            // B = S0 + F (T S0 − S1) + ½ F² (T² S0 − 2T S1 + S2).
            let first = &self.s0 * t - &self.s1;
            let second = &self.s0 * (t * t) - &self.s1 * (2.0 * t) + &self.s2;
            let b = &self.s0 + &fm * first + (&fm * &fm) * second * 0.5;
            self.v = am * &self.v + b;
            self.s0.fill(0.0);
            self.s1.fill(0.0);
            self.s2.fill(0.0);
        }
    }

    /// Zero-velocity update with the navigated velocity `v_n` (m/s).
    pub fn update_zero_velocity(&mut self, v_n: &Vector3<f64>) -> Result<Innovation, CalibError> {
        let nav = &mut self.nav;
        // Bias-free innovation and its covariance.
        let y_bar = v_n - nav.x.fixed_rows::<3>(3);
        let p_xv = nav.p.fixed_columns::<3>(3).into_owned(); // 6 × 3
        let s = p_xv.fixed_rows::<3>(3).into_owned() + Matrix3::identity() * self.zupt_var;
        let chol = s.cholesky().ok_or_else(|| {
            CalibError::Numerical(
                "navigation innovation covariance is not positive definite".into(),
            )
        })?;
        let s_inv = chol.inverse();
        let k = p_xv * s_inv; // 6 × 3
        nav.x += k * y_bar;
        // Joseph form for H = [0 I]: P − K P_v· − P_·v Kᵀ + K S Kᵀ.
        let k_pv = k * p_xv.transpose();
        let p = nav.p - k_pv - k_pv.transpose() + k * s * k.transpose();
        nav.p = (p + p.transpose()) * 0.5;

        // Innovation sensitivity M = H V; information from this update;
        // then the bias-free gain applied to the sensitivity.
        let m = self.v.rows(3, 3).into_owned(); // 3 × n_p
        if self.n_p > 0 {
            let s_inv_d = DMatrix::from_column_slice(3, 3, s_inv.as_slice());
            let mt_sinv = m.transpose() * &s_inv_d; // n_p × 3
            self.j += &mt_sinv * &m;
            self.h += &mt_sinv * DVector::from_column_slice(y_bar.as_slice());
            let kd = DMatrix::from_column_slice(NAV, 3, k.as_slice());
            self.v -= kd * &m;
        }
        Ok(Innovation { y_bar, m, s })
    }

    fn solve_information(&self) -> Result<DVector<f64>, CalibError> {
        let chol = self.j.clone().cholesky().ok_or_else(|| {
            CalibError::Numerical("parameter information is not positive definite".into())
        })?;
        Ok(chol.solve(&self.h))
    }

    fn parameter_covariance(&self) -> Result<DMatrix<f64>, CalibError> {
        let chol = self.j.clone().cholesky().ok_or_else(|| {
            CalibError::Numerical("parameter information is not positive definite".into())
        })?;
        Ok(chol.inverse())
    }

    /// Takes the bias-free navigation-error estimate x̄ out of the state
    /// for feedback into the navigation; x̄ becomes zero and V is kept.
    ///
    /// Only x̄ is fed back, never the parameter-driven part V p̂: p̂ is
    /// uncertain along every direction the run has not yet excited, and
    /// feeding V p̂ back steers the navigation by those errors (1 cm/s
    /// velocity jumps after a turn, seen on simulated runs), which breaks
    /// the linear model and left σ several times too small. With x̄ alone
    /// the navigation carries the true parameter error V p, which the
    /// passes make small.
    pub fn take_navigation_errors(&mut self) -> (Vector3<f64>, Vector3<f64>) {
        let x = self.nav.x;
        self.nav.x = Vector6::zeros();
        (
            Vector3::new(x[0], x[1], x[2]),
            Vector3::new(x[3], x[4], x[5]),
        )
    }

    /// The sensitivity V accumulated since the last call (scaled
    /// parameters), leaving V zero: with no updates in between, that is the
    /// B of the whole stretch, which the least-squares cross-check needs.
    pub fn take_sensitivity(&mut self) -> DMatrix<f64> {
        let v = self.v.clone();
        self.v.fill(0.0);
        v
    }

    /// The sensitivity V of the navigation errors to the (scaled)
    /// parameters, 6 × n_p.
    pub fn sensitivity(&self) -> &DMatrix<f64> {
        &self.v
    }

    /// The scaled parameter estimate J⁻¹ h.
    pub fn scaled_estimate(&self) -> Result<DVector<f64>, CalibError> {
        self.solve_information()
    }

    /// Prior σ of each parameter (SI): the unit of the scaled states.
    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    /// Parameter estimates (SI) and their 1-σ (SI).
    pub fn parameters(&self) -> Result<(Vec<f64>, Vec<f64>), CalibError> {
        let p_hat = self.solve_information()?;
        let cov = self.parameter_covariance()?;
        Ok((0..self.n_p)
            .map(|i| {
                let s = self.scale[i];
                (p_hat[i] * s, cov[(i, i)].max(0.0).sqrt() * s)
            })
            .unzip())
    }

    /// 1-σ (SI) of the first `n` parameters with the others known: the
    /// inverse of their block of the information. The information of a
    /// set of columns does not depend on which other columns ride along,
    /// so this is the σ a filter carrying only those `n` would report.
    pub fn leading_parameter_sigma_si(&self, n: usize) -> Result<Vec<f64>, CalibError> {
        let block = self.j.view((0, 0), (n, n)).into_owned();
        let chol = block.cholesky().ok_or_else(|| {
            CalibError::Numerical("parameter information is not positive definite".into())
        })?;
        let cov = chol.inverse();
        Ok((0..n)
            .map(|i| cov[(i, i)].max(0.0).sqrt() * self.scale[i])
            .collect())
    }

    /// Parameter covariance (SI).
    pub fn parameter_covariance_si(&self) -> Result<DMatrix<f64>, CalibError> {
        let mut cov = self.parameter_covariance()?;
        for i in 0..self.n_p {
            for k in 0..self.n_p {
                cov[(i, k)] *= self.scale[i] * self.scale[k];
            }
        }
        Ok(cov)
    }

    /// 1-σ of the bias-free navigation errors.
    pub fn navigation_sigma(&self) -> [f64; NAV] {
        std::array::from_fn(|i| self.nav.p[(i, i)].max(0.0).sqrt())
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

    /// The filter on data drawn from its own linear model: every
    /// parameter's error over many trials must be as large as its σ says,
    /// at navigation grade (0.0003 deg/√h, 5 µg/√Hz) and at the noisy end
    /// of tactical grade (0.003 deg/√h, 50 µg/√Hz).
    #[test]
    fn estimates_are_consistent_on_the_linear_model() {
        for (arw, vrw) in [(8.7e-8, 4.9e-5), (8.7e-7, 4.9e-4)] {
            check_linear_model_consistency(arw, vrw);
        }
    }

    fn check_linear_model_consistency(arw: f64, vrw: f64) {
        use nalgebra::Matrix6xX;
        use rand::{Rng, SeedableRng};
        use rand_distr::StandardNormal;
        let window = 1.0;
        let f = error_dynamics(
            &Vector3::new(0.0, 6.4e-5, 3.4e-5),
            &Vector3::new(0.0, 0.0, 9.79),
        );
        let mut qc = Matrix6::zeros();
        for i in 0..3 {
            qc[(i, i)] = arw * arw;
            qc[(i + 3, i + 3)] = vrw * vrw;
        }
        let a = transition(&f, window);
        let lq = process_noise(&f, &qc, window).cholesky().unwrap().l();
        let n_p = 4;
        let prior = vec![1e-3; n_p];
        let mut p0 = Matrix6::zeros();
        for i in 0..3 {
            p0[(i, i)] = 1e-6;
            p0[(i + 3, i + 3)] = 1e-8;
        }
        let trials = 30;
        let mut z2 = vec![0.0; n_p];
        for trial in 0..trials {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(trial);
            let mut normal = || rng.sample::<f64, _>(StandardNormal);
            let p_true: Vec<f64> = (0..n_p).map(|_| normal() * 1e-3).collect();
            let mut x = Vector6::from_fn(|i, _| if i < 3 { 1e-3 } else { 1e-4 });
            let mut kf = SystematicFilter::new(f, &p0, &prior, arw, vrw, 1e-6);
            for k in 0..1500 {
                // Each parameter drives a direction that changes every
                // 300 s, like a multi-position scheme.
                let phase = k / 300;
                let mut b = Matrix6xX::zeros(n_p);
                for j in 0..n_p {
                    let ang = (phase * 7 + j * 3) as f64;
                    let col = Vector3::new(ang.sin(), ang.cos(), (0.3 * ang).sin()) * 1e-2;
                    let (rows, r0) = if j % 2 == 0 {
                        (Rows::Attitude, 0)
                    } else {
                        (Rows::Velocity, 3)
                    };
                    kf.add_column(j, rows, &col, 0.5 * window);
                    b.fixed_view_mut::<3, 1>(r0, j).copy_from(&col);
                }
                // The same single mid-window record the filter expands.
                let fm = nalgebra::DMatrix::from_column_slice(6, 6, f.as_slice());
                let bd = nalgebra::DMatrix::from_column_slice(6, n_p, b.as_slice());
                let b_eff = &bd
                    + &fm * &bd * (0.5 * window)
                    + (&fm * &fm) * &bd * (0.125 * window * window);
                let bp = b_eff * DVector::from_vec(p_true.clone());
                let w = lq * Vector6::from_fn(|_, _| normal());
                x = a * x + Vector6::from_column_slice(bp.as_slice()) + w;
                kf.propagate(window);
                let z = Vector3::new(x[3], x[4], x[5]) + Vector3::from_fn(|_, _| normal() * 1e-6);
                kf.update_zero_velocity(&z).unwrap();
                let (phi, dv) = kf.take_navigation_errors();
                for i in 0..3 {
                    x[i] -= phi[i];
                    x[i + 3] -= dv[i];
                }
            }
            let (d, s) = kf.parameters().unwrap();
            for j in 0..n_p {
                z2[j] += ((d[j] - p_true[j]) / s[j]).powi(2);
            }
        }
        for (j, v) in z2.iter().enumerate() {
            let rms = (v / trials as f64).sqrt();
            assert!(
                (0.7..1.3).contains(&rms),
                "ARW {arw} rad/√s, VRW {vrw} m/s/√s, parameter {j}: rms err/σ {rms}"
            );
        }
    }
}
