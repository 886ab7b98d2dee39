//! The filter's "bias-free" part: the navigation errors (attitude φ and
//! velocity δv, in n) and, on a unit whose biases wander (SPEC §2a), the
//! wander states and the running integral of each wandering bias.
//!
//! State layout: φ (0..3), δv (3..6), the wander components (one per
//! `WanderComponent`), then one integral ∫ w dt per bias axis that has
//! components. The integral is what turns the constant bias the filter
//! carries into the bias averaged over the run (SPEC §2a: a calibration
//! reports the run mean), with its covariance.
//!
//! The transition over a window has a fixed shape: the navigation block
//! exp(F T), the wander's coupling into it (its own decay averaged over
//! the window times the bias columns the window accumulated), the
//! components' decays on a diagonal, and each integral adding its axis's
//! components. It is applied as that structure, never as a dense matrix:
//! with the full real-sensor model the state has some forty entries, and
//! a dense product per window would cost more than the records do.

use nalgebra::{Cholesky, DMatrix, DVector, Matrix3, Matrix6, Vector3, Vector6, U3};

use super::wander::{WanderComponent, WanderStep};

/// Navigation-error states: φ (0..3), δv (3..6).
pub const NAV: usize = 6;

/// What one window does to the bias-free states.
pub struct WindowModel<'a> {
    /// exp(F T) of the navigation errors.
    pub phi: &'a Matrix6<f64>,
    /// White-noise covariance of the navigation errors over the window.
    pub q_white: &'a Matrix6<f64>,
    /// How a constant body bias on each axis (gyro x, y, z, accelerometer
    /// x, y, z; SI) moves [φ; δv] over the window.
    pub coupling: &'a Matrix6<f64>,
    pub t: f64,
}

/// The bias-free states and their covariance.
#[derive(Clone, Debug)]
pub struct NavErrors {
    pub x: DVector<f64>,
    pub p: DMatrix<f64>,
    wander: Vec<WanderComponent>,
    /// State index of each bias axis's integral, if it wanders.
    integral: [Option<usize>; 6],
}

impl NavErrors {
    /// Zero errors with navigation covariance `p0_nav`, and the wander
    /// components at their stationary (or, for a random walk, zero)
    /// variance; with `run_means`, the integrals that turn the biases into
    /// their run means.
    pub fn new(p0_nav: &Matrix6<f64>, wander: Vec<WanderComponent>, run_means: bool) -> Self {
        let mut integral = [None; 6];
        let mut n = NAV + wander.len();
        for c in &wander {
            if run_means && integral[c.axis].is_none() {
                integral[c.axis] = Some(n);
                n += 1;
            }
        }
        let mut p = DMatrix::zeros(n, n);
        p.view_mut((0, 0), (NAV, NAV)).copy_from(p0_nav);
        for (i, c) in wander.iter().enumerate() {
            p[(NAV + i, NAV + i)] = c.initial_variance();
        }
        NavErrors {
            x: DVector::zeros(n),
            p,
            wander,
            integral,
        }
    }

    /// Number of states.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// The wander components, in state order.
    pub fn wander(&self) -> &[WanderComponent] {
        &self.wander
    }

    /// The state index of bias axis `axis`'s integral ∫ w dt, if it wanders.
    pub fn integral_of(&self, axis: usize) -> Option<usize> {
        self.integral[axis]
    }

    /// The wander components' steps over a window of `t` seconds.
    pub fn wander_steps(&self, t: f64) -> Vec<WanderStep> {
        self.wander.iter().map(|c| c.step(t)).collect()
    }

    /// The window's transition A, in its structure.
    pub fn transition(&self, w: &WindowModel, steps: &[WanderStep]) -> Transition {
        let components = self
            .wander
            .iter()
            .zip(steps)
            .map(|(c, s)| ComponentStep {
                axis: c.axis,
                mean_decay: s.mean_decay,
                decay: s.decay,
                integral: self.integral[c.axis].map(|k| (k, w.t * s.mean_decay)),
            })
            .collect();
        Transition {
            phi: *w.phi,
            coupling: *w.coupling,
            components,
        }
    }

    /// Propagates the estimate and covariance over one window whose
    /// transition `a` is [`NavErrors::transition`]'s.
    pub fn propagate(&mut self, a: &Transition, w: &WindowModel, steps: &[WanderStep]) {
        a.apply(self.x.as_mut_slice());
        // A P Aᵀ = A (A P)ᵀ for symmetric P.
        a.apply_columns(&mut self.p);
        self.p.transpose_mut();
        a.apply_columns(&mut self.p);
        self.add_process_noise(w, steps);
        symmetrise(&mut self.p);
    }

    /// Adds the window's process noise: white noise on the navigation
    /// block, and each component's new noise entering its own state, the
    /// navigation (half of it acts over the window, as a random walk's
    /// increment grows through it) and its axis's integral (likewise).
    fn add_process_noise(&mut self, w: &WindowModel, steps: &[WanderStep]) {
        let p = &mut self.p;
        for c in 0..NAV {
            for r in 0..NAV {
                p[(r, c)] += w.q_white[(r, c)];
            }
        }
        for (i, (c, s)) in self.wander.iter().zip(steps).enumerate() {
            if s.noise_variance <= 0.0 {
                continue;
            }
            // The noise's input vector is zero but on the navigation
            // rows, its own state and its axis's integral: a rank-one
            // update on those rows and columns only.
            let mut idx = [0usize; NAV + 2];
            let mut l = [0.0; NAV + 2];
            for r in 0..NAV {
                idx[r] = r;
                l[r] = 0.5 * w.coupling[(r, c.axis)];
            }
            idx[NAV] = NAV + i;
            l[NAV] = 1.0;
            let used = match self.integral[c.axis] {
                Some(k) => {
                    idx[NAV + 1] = k;
                    l[NAV + 1] = 0.5 * w.t;
                    NAV + 2
                }
                None => NAV + 1,
            };
            for a in 0..used {
                for b in 0..used {
                    p[(idx[a], idx[b])] += s.noise_variance * l[a] * l[b];
                }
            }
        }
    }

    /// The zero-velocity update of the bias-free states with the
    /// bias-free innovation `y_bar` (the observed velocity less the
    /// estimate's) and the measurement's covariance `r`. Returns the
    /// innovation's covariance, its factor and the gain (`None` if the
    /// covariance is not positive definite); P in the Joseph form, expanded
    /// for a measurement that selects the velocity rows:
    /// P − K P_v·ᵀ − P_·v Kᵀ + K S Kᵀ.
    pub fn update_velocity(
        &mut self,
        y_bar: &Vector3<f64>,
        r: &Matrix3<f64>,
    ) -> Option<VelocityUpdate> {
        let n = self.len();
        // Row i of P_·v: state i's covariance with the velocity.
        let p_v: Vec<Vector3<f64>> = (0..n)
            .map(|i| Vector3::new(self.p[(i, 3)], self.p[(i, 4)], self.p[(i, 5)]))
            .collect();
        let s = Matrix3::from_fn(|i, j| p_v[3 + i][j]) + r;
        let chol = s.cholesky()?;
        let s_inv = chol.inverse();
        let k: Vec<Vector3<f64>> = p_v.iter().map(|pv| s_inv * pv).collect();
        for (i, ki) in k.iter().enumerate() {
            self.x[i] += ki.dot(y_bar);
        }
        // −K P_v·ᵀ − P_·v Kᵀ + K S Kᵀ = (K S − P_·v) Kᵀ − K P_v·ᵀ, row r
        // and column c; written on both sides of the diagonal from one
        // value, so P stays exactly symmetric.
        let ks_pv: Vec<Vector3<f64>> = k.iter().zip(&p_v).map(|(k, pv)| s * k - pv).collect();
        for c in 0..n {
            for r in 0..=c {
                let d = ks_pv[r].dot(&k[c]) - k[r].dot(&p_v[c]);
                let v = 0.5 * (self.p[(r, c)] + self.p[(c, r)]) + d;
                self.p[(r, c)] = v;
                self.p[(c, r)] = v;
            }
        }
        let gain = DMatrix::from_fn(n, 3, |i, j| k[i][j]);
        Some(VelocityUpdate { s, chol, gain })
    }

    /// The velocity error made unknown: σ `sigma_mps` per axis,
    /// uncorrelated with every other state, mean zero.
    pub fn forget_velocity(&mut self, sigma_mps: f64) {
        for i in 3..6 {
            self.x[i] = 0.0;
            self.p.row_mut(i).fill(0.0);
            self.p.column_mut(i).fill(0.0);
            self.p[(i, i)] = sigma_mps * sigma_mps;
        }
    }

    /// Takes the navigation errors' estimate out (for feedback into the
    /// navigation); the wander and integral states stay, being open loop.
    pub fn take_navigation(&mut self) -> [f64; NAV] {
        let out = std::array::from_fn(|i| self.x[i]);
        self.x.rows_mut(0, NAV).fill(0.0);
        out
    }
}

/// What a zero-velocity update made: the innovation's covariance S, its
/// Cholesky factor, and the gain K (one row per state).
pub struct VelocityUpdate {
    pub s: Matrix3<f64>,
    pub chol: Cholesky<f64, U3>,
    pub gain: DMatrix<f64>,
}

/// A window's transition of the bias-free states in its structure: the
/// navigation block exp(F T), the wander's coupling into the navigation
/// errors (each component through its axis's bias column, times its mean
/// decay), each component's decay, and its share of its axis's integral.
/// Applied a column at a time, never as a dense matrix: with the full
/// real-sensor model the state has some forty entries, and a dense product
/// per window would cost more than the records do.
pub struct Transition {
    phi: Matrix6<f64>,
    coupling: Matrix6<f64>,
    components: Vec<ComponentStep>,
}

struct ComponentStep {
    axis: usize,
    mean_decay: f64,
    decay: f64,
    /// The axis's integral state and the component's gain into it (T
    /// times its mean decay).
    integral: Option<(usize, f64)>,
}

impl Transition {
    /// A·m for one column m (one entry per state), in place. An axis's
    /// components share its bias column, so they are summed on the axis
    /// first (with many components a column costs a third of the dense
    /// coupling's product).
    pub fn apply(&self, m: &mut [f64]) {
        let mut bias = Vector6::zeros();
        for (i, c) in self.components.iter().enumerate() {
            let w = m[NAV + i];
            bias[c.axis] += c.mean_decay * w;
            if let Some((k, a)) = c.integral {
                m[k] += a * w;
            }
            m[NAV + i] = w * c.decay;
        }
        let mut nav = self.phi * Vector6::from_column_slice(&m[..NAV]);
        if !self.components.is_empty() {
            nav += self.coupling * bias;
        }
        m[..NAV].copy_from_slice(nav.as_slice());
    }

    /// A·M for M with one row per state, in place: how the sensitivity V
    /// and the covariance move.
    pub fn apply_columns(&self, m: &mut DMatrix<f64>) {
        let n = m.nrows();
        if n == 0 {
            return;
        }
        for col in m.as_mut_slice().chunks_exact_mut(n) {
            self.apply(col);
        }
    }
}

/// (P + Pᵀ)/2, in place.
fn symmetrise(p: &mut DMatrix<f64>) {
    for c in 0..p.ncols() {
        for r in 0..c {
            let v = 0.5 * (p[(r, c)] + p[(c, r)]);
            p[(r, c)] = v;
            p[(c, r)] = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::wander::WanderKind;

    fn window<'a>(
        phi: &'a Matrix6<f64>,
        q: &'a Matrix6<f64>,
        g: &'a Matrix6<f64>,
    ) -> WindowModel<'a> {
        WindowModel {
            phi,
            q_white: q,
            coupling: g,
            t: 1.0,
        }
    }

    /// The structured transition equals the dense one written out.
    #[test]
    fn structured_transition_matches_the_dense_matrix() {
        let wander = vec![
            WanderComponent {
                axis: 1,
                kind: WanderKind::Markov {
                    tau_s: 30.0,
                    variance: 4.0,
                },
            },
            WanderComponent {
                axis: 4,
                kind: WanderKind::RandomWalk { density: 0.5 },
            },
            WanderComponent {
                axis: 1,
                kind: WanderKind::Markov {
                    tau_s: 900.0,
                    variance: 1.0,
                },
            },
        ];
        let mut e = NavErrors::new(&(Matrix6::identity() * 0.1), wander, true);
        assert_eq!(e.len(), 6 + 3 + 2);
        let phi = Matrix6::from_fn(|r, c| {
            if r == c {
                1.0
            } else {
                0.01 * (r + 2 * c) as f64
            }
        });
        let q = Matrix6::identity() * 1e-3;
        let g = Matrix6::from_fn(|r, c| 0.1 * (1 + r) as f64 - 0.05 * c as f64);
        let w = window(&phi, &q, &g);
        let steps = e.wander_steps(w.t);
        let n = e.len();
        let mut a = DMatrix::<f64>::identity(n, n);
        a.view_mut((0, 0), (6, 6)).copy_from(&phi);
        for (i, c) in e.wander.iter().enumerate() {
            for r in 0..6 {
                a[(r, 6 + i)] = g[(r, c.axis)] * steps[i].mean_decay;
            }
            a[(6 + i, 6 + i)] = steps[i].decay;
            let k = e.integral_of(c.axis).unwrap();
            a[(k, 6 + i)] = steps[i].mean_decay;
        }
        let m = DMatrix::from_fn(n, 4, |r, c| (r as f64 * 0.7 + c as f64).sin());
        let transition = e.transition(&w, &steps);
        let mut got = m.clone();
        transition.apply_columns(&mut got);
        assert!((got - &a * &m).norm() < 1e-12);
        let p0 = e.p.clone();
        e.propagate(&transition, &w, &steps);
        let dense = &a * &p0 * a.transpose();
        // The white block and the components' noise come on top.
        let extra = &e.p - dense;
        assert!(
            (extra[(0, 0)]
                - 1e-3
                - 0.25 * g[(0, 1)].powi(2) * steps[0].noise_variance
                - 0.25 * g[(0, 1)].powi(2) * steps[2].noise_variance
                - 0.25 * g[(0, 4)].powi(2) * steps[1].noise_variance)
                .abs()
                < 1e-12
        );
        assert!((extra[(7, 7)] - steps[1].noise_variance).abs() < 1e-15);
    }
}
