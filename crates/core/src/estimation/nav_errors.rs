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

use nalgebra::{DMatrix, DVector, Matrix6};

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

    /// Propagates the estimate and covariance over one window.
    pub fn propagate(&mut self, w: &WindowModel, steps: &[WanderStep]) {
        let x = std::mem::replace(&mut self.x, DVector::zeros(0));
        self.x = self
            .transition_left(
                w,
                steps,
                &DMatrix::from_column_slice(x.len(), 1, x.as_slice()),
            )
            .column(0)
            .into_owned();
        // A P Aᵀ = A (A P)ᵀ for symmetric P.
        let ap = self.transition_left(w, steps, &self.p);
        let mut p = self.transition_left(w, steps, &ap.transpose());
        self.add_process_noise(&mut p, w, steps);
        self.p = (&p + p.transpose()) * 0.5;
    }

    /// A·M for the window's transition A (M has one row per state): how
    /// the sensitivity V and the estimate move.
    pub fn transition_left(
        &self,
        w: &WindowModel,
        steps: &[WanderStep],
        m: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let mut out = m.clone();
        let phi = DMatrix::from_column_slice(NAV, NAV, w.phi.as_slice());
        let mut nav = phi * m.rows(0, NAV);
        let n_w = self.wander.len();
        if n_w > 0 {
            // The wander's coupling into the navigation, one column per
            // component: its axis's bias column times its mean decay.
            let g = DMatrix::from_fn(NAV, n_w, |r, i| {
                w.coupling[(r, self.wander[i].axis)] * steps[i].mean_decay
            });
            nav.gemm(1.0, &g, &m.rows(NAV, n_w), 1.0);
        }
        for (i, (c, s)) in self.wander.iter().zip(steps).enumerate() {
            if let Some(k) = self.integral[c.axis] {
                let a = w.t * s.mean_decay;
                for col in 0..m.ncols() {
                    out[(k, col)] += a * m[(NAV + i, col)];
                }
            }
            out.row_mut(NAV + i).scale_mut(s.decay);
        }
        out.rows_mut(0, NAV).copy_from(&nav);
        out
    }

    /// Adds the window's process noise: white noise on the navigation
    /// block, and each component's new noise entering its own state, the
    /// navigation (half of it acts over the window, as a random walk's
    /// increment grows through it) and its axis's integral (likewise).
    fn add_process_noise(&self, p: &mut DMatrix<f64>, w: &WindowModel, steps: &[WanderStep]) {
        let mut nav = p.view((0, 0), (NAV, NAV)).into_owned();
        nav += DMatrix::from_column_slice(NAV, NAV, w.q_white.as_slice());
        p.view_mut((0, 0), (NAV, NAV)).copy_from(&nav);
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
        let got = e.transition_left(&w, &steps, &m);
        assert!((got - &a * &m).norm() < 1e-12);
        let p0 = e.p.clone();
        e.propagate(&w, &steps);
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
