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
//!   per-record columns B_j (`window_columns`; the F³ term is below 1e-7
//!   of the rest for 1 s windows);
//! - the white noise's process noise is linear in its density in n, so
//!   Q(T) is kept per window length as its response to each entry of that
//!   density, and a unit whose axes differ only costs a 3 × 3 rotation;
//! - a wandering bias (SPEC §2a) acts through the same columns as the
//!   constant bias, so the window's bias columns couple the wander states
//!   (`nav_errors`, `wander`) into the navigation errors.
//!
//! Parameter states are kept in units of their prior σ so that J starts as
//! the identity. The navigation update is the Joseph form, expanded for a
//! measurement that selects the velocity rows.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3};

use super::error::EstimationError;
use super::error_dynamics::WindowCache;
pub use super::error_dynamics::{error_dynamics, process_noise, transition};
pub(crate) use super::nav_errors::WindowModel;
pub use super::nav_errors::NAV;
use super::nav_errors::{NavErrors, Transition, VelocityUpdate};
use super::noise_model::NoiseModel;
use super::wander::wander_components;
use super::window_columns::{RecordColumns, WindowColumns};
use crate::model::params::Group;
use crate::model::N_PARAMS;

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

/// σ of a forgotten velocity error, m/s: far beyond anything a hand
/// motion leaves, so that the next update alone sets the velocity.
pub const FORGOTTEN_VELOCITY_SIGMA_MPS: f64 = 1.0;

/// Window lengths whose matrices are kept.
const WINDOW_CACHE: usize = 8;

/// The filter. `n_p` parameter states follow the navigation states.
pub struct SystematicFilter {
    /// The bias-free states: navigation errors and any bias wander.
    pub nav: NavErrors,
    /// Sensitivity of the bias-free states to the (scaled) parameters.
    v: DMatrix<f64>,
    /// Parameter information and information vector (scaled units).
    j: DMatrix<f64>,
    h: DVector<f64>,
    n_p: usize,
    /// Prior σ of each parameter, SI: state i is δp_i / scale_i.
    scale: Vec<f64>,
    f: Matrix6<f64>,
    noise: NoiseModel,
    zupt_var: f64,
    /// The window matrices of the lengths met so far, the latest first (a
    /// run has a few: whole windows, and the odd ones at turns).
    cache: Vec<WindowCache>,
    /// Σ ln det S_k + ȳ_kᵀ S_k⁻¹ ȳ_k over the updates (the likelihood).
    innovation_terms: f64,
    keep_input: bool,
    last_input: Option<DMatrix<f64>>,
    /// The parameters are taken as known (their effect already removed
    /// from the observations): only the bias-free part is filtered.
    parameters_known: bool,
    /// The open window's record columns.
    columns: WindowColumns,
}

impl SystematicFilter {
    /// `p0_nav` is the initial navigation covariance; `prior_sigma` the
    /// prior 1-σ of each parameter state (SI; with wandering biases the
    /// 24 base parameters must lead); `noise` the sensor noise, whose
    /// wander over a run of `run_s` seconds becomes states; `zupt_sigma`
    /// the zero-velocity measurement σ (m/s).
    pub fn new(
        f: Matrix6<f64>,
        p0_nav: &Matrix6<f64>,
        prior_sigma: &[f64],
        noise: &NoiseModel,
        run_s: f64,
        zupt_sigma: f64,
    ) -> Self {
        let n_p = prior_sigma.len();
        let wander = if noise.wanders() && n_p >= N_PARAMS {
            wander_components(noise, run_s)
        } else {
            Vec::new()
        };
        let nav = NavErrors::new(p0_nav, wander, true);
        SystematicFilter {
            v: DMatrix::zeros(nav.len(), n_p),
            nav,
            j: DMatrix::identity(n_p, n_p),
            h: DVector::zeros(n_p),
            n_p,
            scale: prior_sigma.to_vec(),
            f,
            noise: *noise,
            zupt_var: zupt_sigma * zupt_sigma,
            cache: Vec::new(),
            innovation_terms: 0.0,
            keep_input: false,
            last_input: None,
            parameters_known: false,
            columns: WindowColumns::new(n_p),
        }
    }

    pub fn n_params(&self) -> usize {
        self.n_p
    }

    /// Adds one record's parameter columns, which `fill` sets
    /// (`RecordColumns::set`: SI per unit of parameter, on the rows each
    /// drives); `tau` is the record's mid time from the window start.
    #[inline(always)]
    pub fn add_record(&mut self, tau: f64, fill: impl FnOnce(&mut RecordColumns)) {
        self.columns.add_record(tau, fill);
    }

    /// Propagates over a window of length `t` whose records were added
    /// with [`SystematicFilter::add_record`], and clears the accumulators;
    /// `c_b_n` is the attitude at the window's end (the white noise's
    /// density in n when the axes differ).
    pub fn propagate(&mut self, t: f64, c_b_n: &Matrix3<f64>) {
        let b = self.window_input(t);
        self.propagate_input(t, c_b_n, &b);
        if self.keep_input {
            self.last_input = Some(b);
        }
    }

    /// The window's parameter input B (6 × n_p, scaled) from the records'
    /// columns, clearing them.
    fn window_input(&mut self, t: f64) -> DMatrix<f64> {
        if self.n_p == 0 {
            return DMatrix::zeros(NAV, 0);
        }
        self.columns.take_input(&self.f, t, &self.scale)
    }

    /// Propagates over a window of length `t` whose parameter input B is
    /// `b` (scaled; as [`SystematicFilter::propagate`] accumulates it, or
    /// as a replay kept it).
    pub fn propagate_input(&mut self, t: f64, c_b_n: &Matrix3<f64>, b: &DMatrix<f64>) {
        let i = self.cached(t);
        let (phi, q_white) = self.cache[i].over(
            &self.f,
            t,
            &self.noise.gyro.white_density_n(c_b_n),
            &self.noise.accel.white_density_n(c_b_n),
        );
        let coupling = self.bias_coupling(b);
        let transition = self.propagate_window(&WindowModel {
            phi: &phi,
            q_white: &q_white,
            coupling: &coupling,
            t,
        });
        if self.n_p > 0 && !self.parameters_known {
            transition.apply_columns(&mut self.v);
            let mut nav_rows = self.v.rows_mut(0, NAV);
            nav_rows += b;
        }
    }

    /// Propagates the bias-free states over a window given by its
    /// matrices; returns the window's transition, for the sensitivity.
    /// What a replay with the parameters known calls directly, with
    /// matrices it made once (`calib::replay`).
    pub(crate) fn propagate_window(&mut self, window: &WindowModel) -> Transition {
        let steps = self.nav.wander_steps(window.t);
        let transition = self.nav.transition(window, &steps);
        self.nav.propagate(&transition, window, &steps);
        transition
    }

    /// exp(F T) and the white noise's Q(T) over a window of `t` seconds for
    /// the densities `gyro_n`, `accel_n` (3 × 3, in n).
    pub(crate) fn window_matrices(
        &mut self,
        t: f64,
        gyro_n: &Matrix3<f64>,
        accel_n: &Matrix3<f64>,
    ) -> (Matrix6<f64>, Matrix6<f64>) {
        let i = self.cached(t);
        self.cache[i].over(&self.f, t, gyro_n, accel_n)
    }

    /// The sensor noise model the filter runs under.
    pub(crate) fn noise(&self) -> &NoiseModel {
        &self.noise
    }

    /// The same filter for observations whose parameter part is already
    /// removed: only the navigation errors and the wander are filtered
    /// (no sensitivity, no information, no run means), which is what a
    /// noise model's likelihood needs and costs about half a pass.
    pub fn with_parameters_known(mut self) -> Self {
        let p0 = self.nav.p.view((0, 0), (NAV, NAV)).into_owned();
        let p0 = Matrix6::from_fn(|r, c| p0[(r, c)]);
        self.nav = NavErrors::new(&p0, self.nav.wander().to_vec(), false);
        self.v = DMatrix::zeros(self.nav.len(), self.n_p);
        self.parameters_known = true;
        self
    }

    /// Keep each window's parameter input B for
    /// [`SystematicFilter::take_window_input`] (a pass that records its
    /// windows for a replay).
    pub fn keep_window_inputs(&mut self) {
        self.keep_input = true;
    }

    /// The last window's parameter input B, when kept.
    pub fn take_window_input(&mut self) -> Option<DMatrix<f64>> {
        self.last_input.take()
    }

    /// exp(F T) of the navigation errors over a window of `t` seconds.
    pub fn navigation_transition(&mut self, t: f64) -> Matrix6<f64> {
        let i = self.cached(t);
        self.cache[i].phi_over(&self.f, t)
    }

    /// The index of the window matrices for length `t`, or of the nearest
    /// kept length that reaches it (`WindowCache::over`: windows over
    /// jittered stamps), made if none. At most [`WINDOW_CACHE`] lengths
    /// are kept; the least recent goes.
    fn cached(&mut self, t: f64) -> usize {
        let nearest = (self.cache.iter().enumerate())
            .filter(|(_, c)| c.reaches(t))
            .min_by(|a, b| (a.1.t - t).abs().total_cmp(&(b.1.t - t).abs()));
        if let Some((i, _)) = nearest {
            return i;
        }
        if self.cache.len() >= WINDOW_CACHE {
            self.cache.remove(0);
        }
        self.cache.push(WindowCache::new(&self.f, t));
        self.cache.len() - 1
    }

    /// The log-likelihood of the zero-velocity observations so far under
    /// the filter's noise model, the parameters integrated out against
    /// their prior (scaled: N(0, I)):
    /// −½ [Σ ln det S_k + Σ ȳ_kᵀ S_k⁻¹ ȳ_k − hᵀ J⁻¹ h + ln det J], constant
    /// dropped. The two-stage innovations ȳ_k − M_k p are independent
    /// N(0, S_k) given p, which makes this the marginal likelihood.
    pub fn log_likelihood(&self) -> Result<f64, EstimationError> {
        if self.parameters_known {
            return Ok(-0.5 * self.innovation_terms);
        }
        let chol = self.information_cholesky()?;
        let quad = self.h.dot(&chol.solve(&self.h));
        let ln_det_j = 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        Ok(-0.5 * (self.innovation_terms - quad + ln_det_j))
    }

    /// The window's [`SystematicFilter::bias_columns`] where wander states
    /// act through them; zero where none do.
    fn bias_coupling(&self, b: &DMatrix<f64>) -> Matrix6<f64> {
        if self.nav.len() == NAV {
            return Matrix6::zeros();
        }
        self.bias_columns(b)
    }

    /// The bias parameters' columns of a window's B (scaled), unscaled: how
    /// a constant body bias (gyro x, y, z, accelerometer x, y, z; SI) moved
    /// the navigation errors over the window, whether or not the filter
    /// carries wander. Zero without the base parameters.
    pub(crate) fn bias_columns(&self, b: &DMatrix<f64>) -> Matrix6<f64> {
        let mut g = Matrix6::zeros();
        if self.n_p < N_PARAMS {
            return g;
        }
        let first = [Group::GyroBias.first(), Group::AccelBias.first()];
        for axis in 0..6 {
            let col = first[axis / 3] + axis % 3;
            for r in 0..NAV {
                g[(r, axis)] = b[(r, col)] / self.scale[col];
            }
        }
        g
    }

    /// Zero-velocity update with the navigated velocity `v_n` (m/s) at
    /// attitude `c_b_n` (the accelerometers' quanta, a bounded error of
    /// the velocity, add to the observation's noise along their axes).
    pub fn update_zero_velocity(
        &mut self,
        v_n: &Vector3<f64>,
        c_b_n: &Matrix3<f64>,
    ) -> Result<Innovation, EstimationError> {
        let r =
            Matrix3::identity() * self.zupt_var + self.noise.accel.quantization_covariance_n(c_b_n);
        // Bias-free innovation, the bias-free states' update and the
        // likelihood's terms.
        let x = &self.nav.x;
        let y_bar = v_n - Vector3::new(x[3], x[4], x[5]);
        let VelocityUpdate { s, chol, gain: k } =
            self.nav
                .update_velocity(&y_bar, &r)
                .ok_or(EstimationError::NotPositiveDefinite(
                    "navigation innovation covariance",
                ))?;
        self.innovation_terms += 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>()
            + y_bar.dot(&chol.solve(&y_bar));

        // Innovation sensitivity M = H V; information from this update;
        // then the bias-free gain applied to the sensitivity.
        let m = self.v.rows(3, 3).into_owned(); // 3 × n_p
        if self.n_p > 0 && !self.parameters_known {
            let s_inv = DMatrix::from_column_slice(3, 3, chol.inverse().as_slice());
            let y_d = DVector::from_column_slice(y_bar.as_slice());
            let mt_sinv = m.transpose() * &s_inv; // n_p × 3
            self.j += &mt_sinv * &m;
            self.h += &mt_sinv * y_d;
            self.v -= &k * &m;
        }
        Ok(Innovation { y_bar, m, s })
    }

    fn information_cholesky(
        &self,
    ) -> Result<nalgebra::Cholesky<f64, nalgebra::Dyn>, EstimationError> {
        self.j
            .clone()
            .cholesky()
            .ok_or(EstimationError::NotPositiveDefinite(
                "parameter information",
            ))
    }

    /// Forgets the velocity error: it becomes unknown (σ `sigma_mps` per
    /// axis), independent of the attitude, the wander and the parameters.
    /// What a motion whose velocity the sensor model cannot follow (a
    /// unit lifted and turned by hand, with effects beyond the model in
    /// it) leaves at the next rest: the attitude it carries through the
    /// motion still informs the parameters; its velocity no longer does.
    pub fn forget_velocity(&mut self, sigma_mps: f64) {
        self.nav.forget_velocity(sigma_mps);
        self.v.rows_mut(3, 3).fill(0.0);
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
    /// passes make small. The wander states stay: like the parameters,
    /// they are fed back only between passes, through the estimate.
    pub fn take_navigation_errors(&mut self) -> (Vector3<f64>, Vector3<f64>) {
        let x = self.nav.take_navigation();
        (
            Vector3::new(x[0], x[1], x[2]),
            Vector3::new(x[3], x[4], x[5]),
        )
    }

    /// The sensitivity V of the navigation errors accumulated since the
    /// last call (scaled parameters), leaving V zero: with no updates in
    /// between, that is the B of the whole stretch, which the least-squares
    /// cross-check needs.
    pub fn take_sensitivity(&mut self) -> DMatrix<f64> {
        let v = self.v.rows(0, NAV).into_owned();
        self.v.fill(0.0);
        v
    }

    /// The sensitivity V of the navigation errors to the (scaled)
    /// parameters, 6 × n_p.
    pub fn sensitivity(&self) -> DMatrix<f64> {
        self.v.rows(0, NAV).into_owned()
    }

    /// The scaled parameter estimate J⁻¹ h: the constant part of each
    /// parameter (the one the innovations' sensitivity M refers to).
    pub fn scaled_estimate(&self) -> Result<DVector<f64>, EstimationError> {
        Ok(self.information_cholesky()?.solve(&self.h))
    }

    /// Parameter estimates (SI) and their 1-σ (SI) over the `elapsed_s`
    /// seconds walked: a wandering bias as its mean over that time (SPEC
    /// §2a; the whole run at the end).
    pub fn parameters(&self, elapsed_s: f64) -> Result<(Vec<f64>, Vec<f64>), EstimationError> {
        let (p, cov) = self.run_mean(elapsed_s, self.n_p)?;
        Ok((0..self.n_p)
            .map(|i| {
                let s = self.scale[i];
                (p[i] * s, cov[(i, i)].max(0.0).sqrt() * s)
            })
            .unzip())
    }

    /// 1-σ (SI) of the first `n` parameters with the others known (the
    /// inverse of their block of the information: the information of a
    /// set of columns does not depend on which other columns ride along,
    /// so this is the σ a filter carrying only those `n` would report),
    /// wandering biases as their mean over `elapsed_s`.
    pub fn leading_parameter_sigma_si(
        &self,
        n: usize,
        elapsed_s: f64,
    ) -> Result<Vec<f64>, EstimationError> {
        let (_, cov) = self.run_mean(elapsed_s, n)?;
        Ok((0..n)
            .map(|i| cov[(i, i)].max(0.0).sqrt() * self.scale[i])
            .collect())
    }

    /// Parameter covariance (SI), wandering biases as their mean over
    /// `elapsed_s`.
    pub fn parameter_covariance_si(&self, elapsed_s: f64) -> Result<DMatrix<f64>, EstimationError> {
        let (_, mut cov) = self.run_mean(elapsed_s, self.n_p)?;
        for i in 0..self.n_p {
            for k in 0..self.n_p {
                cov[(i, k)] *= self.scale[i] * self.scale[k];
            }
        }
        Ok(cov)
    }

    /// The first `n` scaled parameters (the others known) and their
    /// covariance, each wandering bias b turned into its mean over
    /// `elapsed_s`, b + (∫ w dt)/elapsed. The integral state s is
    /// x̄_s + V_s p, so with P = J⁻¹: cov(p, s) = P V_sᵀ and
    /// cov(s) = P̄_ss + V_s P V_sᵀ.
    fn run_mean(
        &self,
        elapsed_s: f64,
        n: usize,
    ) -> Result<(DVector<f64>, DMatrix<f64>), EstimationError> {
        let j = self.j.view((0, 0), (n, n)).into_owned();
        let chol = j.cholesky().ok_or(EstimationError::NotPositiveDefinite(
            "parameter information",
        ))?;
        let mut p = chol.solve(&self.h.rows(0, n));
        let mut cov = chol.inverse();
        let first = [Group::GyroBias.first(), Group::AccelBias.first()];
        // (parameter index, integral state index) of each wandering bias.
        let pairs: Vec<(usize, usize)> = (0..6)
            .filter_map(|axis| {
                let param = first[axis / 3] + axis % 3;
                self.nav
                    .integral_of(axis)
                    .filter(|_| param < n && elapsed_s > 0.0)
                    .map(|k| (param, k))
            })
            .collect();
        if pairs.is_empty() {
            return Ok((p, cov));
        }
        let m = pairs.len();
        let v_s = DMatrix::from_fn(m, n, |r, c| self.v[(pairs[r].1, c)]);
        let s_hat = DVector::from_fn(m, |r, _| self.nav.x[pairs[r].1]) + &v_s * &p;
        let cov_ps = &cov * v_s.transpose(); // n × m
        let p_bar_ss = DMatrix::from_fn(m, m, |r, c| self.nav.p[(pairs[r].1, pairs[c].1)]);
        let cov_ss = p_bar_ss + &v_s * &cov_ps;
        // p_rm = p + D s, D[param, r] = 1/(elapsed · scale).
        let mut d = DMatrix::zeros(n, m);
        for (r, &(param, _)) in pairs.iter().enumerate() {
            d[(param, r)] = 1.0 / (elapsed_s * self.scale[param]);
        }
        p += &d * s_hat;
        let cross = &cov_ps * d.transpose();
        cov = &cov + &cross + cross.transpose() + &d * cov_ss * d.transpose();
        Ok((p, (&cov + cov.transpose()) * 0.5))
    }
}

#[cfg(test)]
#[path = "filter_tests.rs"]
mod tests;
