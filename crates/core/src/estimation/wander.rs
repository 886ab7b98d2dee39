//! The wandering part of each bias (SPEC §2a) as filter states.
//!
//! Bias instability is flicker noise: its Allan deviation is flat at
//! 0.664·B from about 10 s to the run's length. No finite state model has
//! that spectrum exactly, but a few first-order Gauss–Markov processes
//! with decay times spread evenly in log τ over the same span do: with
//! their variances fitted to the flat floor, four of them over 10 s …
//! 3.2 h stay within 2 % of it (three within 7 %), which is far below
//! what the Allan curve of a real run can tell apart. Each is a stationary
//! process (its start is drawn from its own variance, as the unit's bias
//! was wandering before the run began). The bias random walk K is one
//! more state per axis, a Wiener process that starts at zero.
//!
//! Only the sum of an axis's components acts on the navigation; the
//! filter carries them apart because they decay at different rates.

use super::noise_model::NoiseModel;

/// 2 ln 2 / π: the flicker floor of the Allan variance per B².
const FLICKER_FLOOR: f64 = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;

/// Shortest τ at which the floor must hold (SPEC §2a: from 10 s).
const FLOOR_FROM_S: f64 = 10.0;

/// The floor is held to this many run lengths: flicker has power at every
/// low frequency, and what lies below the run's own shows within it as a
/// slow drift that only components longer than the run can carry.
const FLOOR_BEYOND_RUN: f64 = 10.0;

/// Largest relative error of the bank's Allan deviation against the
/// floor; the bank grows until it is met.
const FLOOR_TOLERANCE: f64 = 0.05;

/// Most Gauss–Markov processes per axis.
const MAX_COMPONENTS: usize = 6;

/// How one wander state evolves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WanderKind {
    /// First-order Gauss–Markov: decay time τ (s) and stationary variance
    /// (SI bias units squared).
    Markov { tau_s: f64, variance: f64 },
    /// Wiener process of density K² (SI bias units squared per second),
    /// zero at the start.
    RandomWalk { density: f64 },
}

/// One state of a bias's wandering part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WanderComponent {
    /// The bias axis: gyro x, y, z (0..3), accelerometer x, y, z (3..6).
    pub axis: usize,
    pub kind: WanderKind,
}

/// A component over a window of `t` seconds: the state's decay d, the
/// mean of its decay over the window a (its share of the window's bias
/// integral), and the variance q of the noise it gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WanderStep {
    pub decay: f64,
    pub mean_decay: f64,
    pub noise_variance: f64,
}

impl WanderComponent {
    /// Variance at the run's start.
    pub fn initial_variance(&self) -> f64 {
        match self.kind {
            WanderKind::Markov { variance, .. } => variance,
            WanderKind::RandomWalk { .. } => 0.0,
        }
    }

    /// The exact discretisation over a window of `t` seconds.
    pub fn step(&self, t: f64) -> WanderStep {
        match self.kind {
            WanderKind::Markov { tau_s, variance } => {
                let x = t / tau_s;
                let decay = (-x).exp();
                // (1 − e^{−x})/x, by its series where x is tiny.
                let mean_decay = if x < 1e-6 {
                    1.0 - 0.5 * x
                } else {
                    -(-x).exp_m1() / x
                };
                WanderStep {
                    decay,
                    mean_decay,
                    noise_variance: variance * -(-2.0 * x).exp_m1(),
                }
            }
            WanderKind::RandomWalk { density } => WanderStep {
                decay: 1.0,
                mean_decay: 1.0,
                noise_variance: density * t,
            },
        }
    }
}

impl WanderComponent {
    /// Covariance of the component's means over two windows of the run,
    /// `a` and `b` ((start, end), seconds from the run's start): the
    /// double integral of its autocovariance over the windows, divided by
    /// their lengths. A Markov state is stationary, e^{−|Δt|/τ} times its
    /// variance; a random walk starts at zero, K² min(s, t).
    pub fn window_mean_covariance(&self, a: (f64, f64), b: (f64, f64)) -> f64 {
        let (len_a, len_b) = (a.1 - a.0, b.1 - b.0);
        // ∫∫ f(t − s) over the windows from the even h with h'' = f.
        let rectangle =
            |h: &dyn Fn(f64) -> f64| h(b.1 - a.0) - h(b.1 - a.1) - h(b.0 - a.0) + h(b.0 - a.1);
        match self.kind {
            WanderKind::Markov { tau_s, variance } => {
                let h = |x: f64| tau_s * x.abs() + tau_s * tau_s * (-x.abs() / tau_s).exp_m1();
                variance * rectangle(&h) / (len_a * len_b)
            }
            WanderKind::RandomWalk { density } => {
                // min(s, t) = (s + t − |t − s|)/2.
                let cube = |x: f64| x.abs().powi(3) / 6.0;
                let sum = len_a * len_b * (0.5 * (a.0 + a.1) + 0.5 * (b.0 + b.1));
                density * 0.5 * (sum - rectangle(&cube)) / (len_a * len_b)
            }
        }
    }
}

/// The wander states a noise model needs over a run of `run_s` seconds:
/// per bias axis, the flicker bank for its instability and a random walk
/// for its K, each only where the term is non-zero.
pub fn wander_components(model: &NoiseModel, run_s: f64) -> Vec<WanderComponent> {
    let mut out = Vec::new();
    let bank = flicker_bank(run_s);
    for (axis, (instability, random_walk)) in model.bias_axes().into_iter().enumerate() {
        if instability > 0.0 {
            let floor = FLICKER_FLOOR * instability * instability;
            out.extend(bank.iter().map(|&(tau_s, weight)| WanderComponent {
                axis,
                kind: WanderKind::Markov {
                    tau_s,
                    variance: weight * floor,
                },
            }));
        }
        if random_walk > 0.0 {
            out.push(WanderComponent {
                axis,
                kind: WanderKind::RandomWalk {
                    density: random_walk * random_walk,
                },
            });
        }
    }
    out
}

/// Allan variance at τ of a Gauss–Markov process of unit variance and
/// decay time `tau_c`.
pub fn markov_allan_variance(tau: f64, tau_c: f64) -> f64 {
    let x = tau / tau_c;
    // 2/x · (1 − (3 − 4e^{−x} + e^{−2x})/(2x)); for small x the bracket
    // cancels to x²/3, so use the series there.
    if x < 1e-3 {
        return 2.0 * x / 3.0 * (1.0 - 0.375 * x);
    }
    let bracket = 1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x);
    2.0 / x * bracket
}

/// The decay times and variances (per unit of the floor's Allan variance)
/// of the fewest Gauss–Markov processes whose summed Allan deviation stays
/// within [`FLOOR_TOLERANCE`] of a flat floor over [10 s, run length]:
/// decay times evenly spaced in log from half the shortest τ to half the
/// longest, variances by least squares on the floor (a component the fit
/// drives negative is dropped and the rest refitted).
pub fn flicker_bank(run_s: f64) -> Vec<(f64, f64)> {
    let hi = FLOOR_BEYOND_RUN * run_s.max(4.0 * FLOOR_FROM_S);
    let lo = FLOOR_FROM_S.min(hi / 4.0);
    let taus: Vec<f64> = (0..60)
        .map(|i| lo * (hi / lo).powf(i as f64 / 59.0))
        .collect();
    let mut best = Vec::new();
    for m in 2..=MAX_COMPONENTS {
        let decay: Vec<f64> = (0..m)
            .map(|i| 0.5 * lo * (hi / lo).powf(i as f64 / (m - 1) as f64))
            .collect();
        let bank = fit_to_floor(&decay, &taus);
        let worst = taus
            .iter()
            .map(|&t| {
                let a: f64 = bank
                    .iter()
                    .map(|(c, w)| w * markov_allan_variance(t, *c))
                    .sum();
                (a.sqrt() - 1.0).abs()
            })
            .fold(0.0, f64::max);
        best = bank;
        if worst <= FLOOR_TOLERANCE {
            break;
        }
    }
    best
}

/// Non-negative least squares of the unit floor on the components' Allan
/// variances at `taus`: the plain solution, dropping any component it
/// makes negative, until none is.
fn fit_to_floor(decay: &[f64], taus: &[f64]) -> Vec<(f64, f64)> {
    let mut active: Vec<f64> = decay.to_vec();
    loop {
        let a = nalgebra::DMatrix::from_fn(taus.len(), active.len(), |r, c| {
            markov_allan_variance(taus[r], active[c])
        });
        let b = nalgebra::DVector::from_element(taus.len(), 1.0);
        let Ok(w) = a.svd(true, true).solve(&b, 1e-14) else {
            return Vec::new();
        };
        match w.iter().position(|x| *x <= 0.0) {
            Some(i) if active.len() > 1 => {
                active.remove(i);
            }
            _ => return active.iter().copied().zip(w.iter().copied()).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::noise_model::TriadNoise;

    #[test]
    fn markov_allan_variance_has_its_limits() {
        // τ ≪ τc: a random walk of density 2σ²/τc, Allan variance K²τ/3.
        let v = markov_allan_variance(1.0, 1e4);
        assert!((v / (2.0 / 1e4 / 3.0) - 1.0).abs() < 1e-3, "{v}");
        // τ ≫ τc: white, 2σ²τc/τ.
        let v = markov_allan_variance(1e6, 10.0);
        assert!((v / (2.0 * 10.0 / 1e6) - 1.0).abs() < 1e-4, "{v}");
        // Continuous through the series' switch.
        let (a, b) = (
            markov_allan_variance(0.999e-3, 1.0),
            markov_allan_variance(1.001e-3, 1.0),
        );
        assert!((a / b - 1.0).abs() < 3e-3);
    }

    #[test]
    fn the_bank_holds_the_flicker_floor_over_the_run() {
        for run_s in [600.0, 3000.0, 11_700.0, 40_000.0] {
            let bank = flicker_bank(run_s);
            assert!(bank.len() <= 5, "{run_s}: {bank:?}");
            for i in 0..40 {
                let tau = 10.0 * (run_s / 10.0).powf(i as f64 / 39.0);
                let a: f64 = bank
                    .iter()
                    .map(|(c, w)| w * markov_allan_variance(tau, *c))
                    .sum();
                assert!(
                    (a.sqrt() - 1.0).abs() <= FLOOR_TOLERANCE,
                    "{run_s} s, τ {tau}: {a}"
                );
            }
        }
    }

    #[test]
    fn window_means_have_their_closed_forms() {
        let markov = WanderComponent {
            axis: 0,
            kind: WanderKind::Markov {
                tau_s: 50.0,
                variance: 4.0,
            },
        };
        let walk = WanderComponent {
            axis: 0,
            kind: WanderKind::RandomWalk { density: 3.0 },
        };
        // Against a midpoint double sum of the autocovariance.
        let numeric = |c: &WanderComponent, a: (f64, f64), b: (f64, f64)| {
            let n = 400;
            let (da, db) = ((a.1 - a.0) / n as f64, (b.1 - b.0) / n as f64);
            let mut sum = 0.0;
            for i in 0..n {
                let s = a.0 + (i as f64 + 0.5) * da;
                for j in 0..n {
                    let t = b.0 + (j as f64 + 0.5) * db;
                    sum += match c.kind {
                        WanderKind::Markov { tau_s, variance } => {
                            variance * (-(t - s).abs() / tau_s).exp()
                        }
                        WanderKind::RandomWalk { density } => density * s.min(t),
                    };
                }
            }
            sum / (n * n) as f64
        };
        for (a, b) in [
            ((0.0, 100.0), (0.0, 100.0)),
            ((20.0, 80.0), (150.0, 400.0)),
            ((500.0, 560.0), (30.0, 90.0)),
            ((10.0, 200.0), (100.0, 300.0)),
        ] {
            for c in [&markov, &walk] {
                let (exact, sum) = (c.window_mean_covariance(a, b), numeric(c, a, b));
                assert!(
                    (exact / sum - 1.0).abs() < 1e-3,
                    "{c:?} {a:?} {b:?}: {exact} {sum}"
                );
            }
        }
        // The limits: a short window of a slow process is its variance;
        // a walk's mean over [0, T] has variance K²T/3.
        let slow = WanderComponent {
            axis: 0,
            kind: WanderKind::Markov {
                tau_s: 1e7,
                variance: 2.0,
            },
        };
        assert!(
            (slow.window_mean_covariance((0.0, 10.0), (5e3, 5e3 + 10.0)) / 2.0 - 1.0).abs() < 1e-3
        );
        assert!((walk.window_mean_covariance((0.0, 90.0), (0.0, 90.0)) - 3.0 * 30.0).abs() < 1e-9);
    }

    #[test]
    fn components_follow_the_model() {
        let mut m = NoiseModel::white(1e-7, 1e-5);
        m.accel = TriadNoise::isotropic(1e-5, 0.0, 3e-5, 0.0);
        m.gyro.random_walk = [0.0, 1e-10, 0.0];
        let c = wander_components(&m, 11_700.0);
        let per_axis = flicker_bank(11_700.0).len();
        assert_eq!(c.len(), 3 * per_axis + 1);
        assert!(c
            .iter()
            .filter(|c| c.axis < 3)
            .all(|c| c.axis == 1 && matches!(c.kind, WanderKind::RandomWalk { .. })));
        // A Markov step keeps the stationary variance.
        let k = c.iter().find(|c| c.axis == 3).unwrap();
        let s = k.step(1.0);
        let v0 = k.initial_variance();
        assert!((s.decay * s.decay * v0 + s.noise_variance - v0).abs() < 1e-12 * v0);
    }
}
