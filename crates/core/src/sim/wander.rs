//! The wandering part w(t) of each bias (SPEC §2a): bias instability, whose
//! Allan deviation has the flicker floor 0.664·B, and rate random walk,
//! whose Allan deviation is K·√(τ/3). Each gyro and accelerometer axis
//! wanders on its own; a record carries ∫ w dt over its interval.
//!
//! Flicker as a sum of Gauss–Markov processes (the project's choice). A
//! first-order Gauss–Markov process of variance q and correlation time T
//! has the two-sided spectrum 2qT / (1 + (2πfT)²). Summed over times
//! T_i = T_0 rⁱ spaced evenly in log T, each of variance s², the sum tends
//! (one term per ln r of ln T) to
//!
//! ```text
//! Σ_i 2 s² T_i / (1 + (2πf T_i)²) ≈ (2 s² / ln r) ∫ dT / (1 + (2πfT)²) = s² / (2 f ln r)
//! ```
//!
//! between 1/(2πT_max) and 1/(2πT_0). Flicker of bias instability B has
//! the two-sided spectrum B² / (2πf) (IEEE Std 952 Annex C, whose Allan
//! variance is then (2 ln 2/π) B²), so s² = B² ln r / π. The sum stops at
//! both ends; the processes beyond either end would act, on the τ inside
//! the band, as white noise (T ≪ τ: Allan variance 2qT/τ, Σ T over the
//! missing ones s² T_0/(r − 1)) or as a random walk (T ≫ τ: 2qτ/(3T),
//! Σ 1/T over the missing ones 1/(T_max (r − 1))). Giving each end process
//! the variance s² · r/(r − 1) instead of s² stands in for its missing
//! tail exactly in both limits. With r = 3, T_0 = 0.1 s and T_max ≥ 1e6 s
//! the exact Allan variance of the sum (`flicker_avar`) stays within
//! 0.1 % of the floor (0.05 % in deviation) from 10 s to T_max/10, and
//! within 1 % in deviation down to 1 s: the unit test below checks it.
//!
//! The times do not depend on the run except that T_max reaches at least
//! ten times its length, so a short run has the same processes as any run
//! up to 1e5 s. Each process is started from its stationary distribution
//! and advanced exactly, x ← φx + s√(1 − φ²)·z with φ = exp(−Δt/T), over
//! each record's actual interval; the random walk starts at 0 and gains
//! K√Δt·z. A record carries ∫ w dt over its interval: exactly (the
//! integral's Gaussian law given the step's start and end, one more
//! normal) for a process faster than ten nominal steps, whose record
//! averages would otherwise be too noisy at low rates (at 1 Hz the
//! trapezoid would raise the floor at 10 s by 6 %); by the trapezoid
//! (w(t_{k−1}) + w(t_k))/2 · Δt_k for the slower ones and the walk, where
//! it changes the Allan deviation by less than 0.05 %.
//!
//! Random streams (ChaCha8 of the run's seed; 0–2 are the white noise,
//! random parameters and hand turns): 3 gyro instability, 4 accelerometer
//! instability, 5 gyro random walk, 6 accelerometer random walk. Each
//! draws x, y, z in turn: first every process's start, then at each record
//! for each process in order of its time one normal (its new value) and,
//! for the exactly integrated ones, a second (its integral).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::sensor_noise::Noise;
use crate::model::units::{DEG_PER_H, UG};
use crate::model::Group;

/// The shortest correlation time, s.
pub const SHORTEST_S: f64 = 0.1;
/// The ratio between neighbouring correlation times.
pub const RATIO: f64 = 3.0;
/// The longest correlation time reaches at least this, s …
pub const LONGEST_AT_LEAST_S: f64 = 1e6;
/// … and at least this many times the run's length.
pub const REACH: f64 = 10.0;

/// The random streams of the wander (see the module docs).
pub const STREAM_GYRO_INSTABILITY: u64 = 3;
pub const STREAM_ACCEL_INSTABILITY: u64 = 4;
pub const STREAM_GYRO_RANDOM_WALK: u64 = 5;
pub const STREAM_ACCEL_RANDOM_WALK: u64 = 6;

/// The correlation times for a run of `run_s` seconds.
pub fn flicker_times_s(run_s: f64) -> Vec<f64> {
    let longest = LONGEST_AT_LEAST_S.max(REACH * run_s);
    let mut times = vec![SHORTEST_S];
    while times[times.len() - 1] < longest {
        times.push(times[times.len() - 1] * RATIO);
    }
    times
}

/// Each process's variance per B²: ln r/π, the two end ones r/(r − 1)
/// times that.
pub fn flicker_variances(n: usize) -> Vec<f64> {
    let s2 = RATIO.ln() / std::f64::consts::PI;
    let end = RATIO / (RATIO - 1.0);
    (0..n)
        .map(|i| if i == 0 || i + 1 == n { s2 * end } else { s2 })
        .collect()
}

/// The exact Allan variance at τ of the sum of processes with these
/// times and variances (continuous time): per process
/// q T²/τ² · (2x − 3 + 4e^{−x} − e^{−2x}), x = τ/T.
pub fn flicker_avar(times: &[f64], variances: &[f64], tau_s: f64) -> f64 {
    times
        .iter()
        .zip(variances)
        .map(|(t, q)| {
            let x = tau_s / t;
            let shape = if x < 1e-3 {
                // The closed form cancels; its series: 2x³/3 − x⁴/2.
                x * x * x * (2.0 / 3.0 - 0.5 * x)
            } else {
                2.0 * x - 3.0 + 4.0 * (-x).exp() - (-2.0 * x).exp()
            };
            q * t * t / (tau_s * tau_s) * shape
        })
        .sum()
}

/// The run means of the wandering parts (truth `bias_mean_over_run`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BiasMean {
    /// deg/h.
    pub gyro: [f64; 3],
    /// µg.
    pub accel: [f64; 3],
}

impl BiasMean {
    /// The run mean of parameter `i`'s wander (canonical order and units):
    /// its bias's for the six biases, nothing for the others. What a run
    /// can see of a wandering bias is its truth plus this.
    pub fn of_parameter(&self, i: usize) -> f64 {
        let (g, a) = (Group::GyroBias.first(), Group::AccelBias.first());
        match i {
            _ if (g..g + 3).contains(&i) => self.gyro[i - g],
            _ if (a..a + 3).contains(&i) => self.accel[i - a],
            _ => 0.0,
        }
    }
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

fn stream(seed: u64, n: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(n);
    rng
}

/// How one process moves over a step of Δt, per unit variance weight s:
/// x ← φx + drive·z₁, and its integral over the step, exact for a fast
/// process (see [`Transition::new`]) and the trapezoid for a slow one.
#[derive(Clone, Copy, Debug)]
struct Transition {
    phi: f64,
    drive: f64,
    /// Exact integral: I = lead·x_a + gain·(x_b − φ x_a) + spread·z₂.
    exact: Option<(f64, f64, f64)>,
}

impl Transition {
    /// Over Δt = `dt` for a process of time `t` and standard deviation
    /// `sd`. Given x_a, (x_b, I = ∫x) is Gaussian with E[x_b] = φx_a,
    /// E[I] = T(1 − φ)x_a, Var x_b = s²(1 − φ²), Cov = s²T(1 − φ)², and
    /// Var I = s²T²(2h − 3 + 4φ − φ²), h = Δt/T: `gain` is Cov/Var x_b and
    /// `spread` the root of Var I − Cov²/Var x_b. A process slower than
    /// [`EXACT_BELOW`] steps takes the trapezoid instead: its error in
    /// the white level, (1 + φ)/(1 − φ)·Δt against 2T, is below 0.05 %
    /// there, while the closed form loses its digits to cancellation.
    fn new(t: f64, sd: f64, dt: f64, exact: bool) -> Self {
        let phi = (-dt / t).exp();
        let exact = exact.then(|| {
            let h = dt / t;
            let var_i = sd * sd * t * t * (2.0 * h - 3.0 + 4.0 * phi - phi * phi);
            let gain = t * (1.0 - phi) / (1.0 + phi);
            let var_b = sd * sd * (1.0 - phi * phi);
            let spread = (var_i - gain * gain * var_b).max(0.0).sqrt();
            (t * (1.0 - phi), gain, spread)
        });
        Transition {
            phi,
            drive: sd * (1.0 - phi * phi).sqrt(),
            exact,
        }
    }
}

/// A process is integrated exactly when its time is below this many
/// nominal steps.
pub const EXACT_BELOW: f64 = 10.0;

/// One triad's flicker processes, in units of B.
struct MarkovSum {
    b: f64,
    state: [Vec<f64>; 3],
    rng: ChaCha8Rng,
}

impl MarkovSum {
    fn new(b: f64, sd: &[f64], mut rng: ChaCha8Rng) -> Self {
        let state = [(); 3].map(|_| sd.iter().map(|s| s * normal(&mut rng)).collect());
        MarkovSum { b, state, rng }
    }

    /// Advances every process; adds w at the step's end to `w` and ∫ w dt
    /// over it to `integral`.
    fn advance(&mut self, steps: &[Transition], dt: f64, w: &mut [f64], integral: &mut [f64]) {
        for (axis, x) in self.state.iter_mut().enumerate() {
            let (mut sum, mut area) = (0.0, 0.0);
            for (x, tr) in x.iter_mut().zip(steps) {
                let x_a = *x;
                *x = tr.phi * x_a + tr.drive * normal(&mut self.rng);
                area += match tr.exact {
                    Some((lead, gain, spread)) => {
                        lead * x_a + gain * (*x - tr.phi * x_a) + spread * normal(&mut self.rng)
                    }
                    None => 0.5 * (x_a + *x) * dt,
                };
                sum += *x;
            }
            w[axis] += self.b * sum;
            integral[axis] += self.b * area;
        }
    }

    fn value(&self, w: &mut [f64]) {
        for (axis, x) in self.state.iter().enumerate() {
            w[axis] += self.b * x.iter().sum::<f64>();
        }
    }
}

/// One triad's random walk.
struct RandomWalk {
    k: f64,
    w: [f64; 3],
    rng: ChaCha8Rng,
}

impl RandomWalk {
    /// Advances the walk; adds w at the step's end to `w` and the
    /// trapezoid of ∫ w dt to `integral`.
    fn advance(&mut self, dt: f64, w: &mut [f64], integral: &mut [f64]) {
        let step = self.k * dt.sqrt();
        for (axis, x) in self.w.iter_mut().enumerate() {
            let x_a = *x;
            *x += step * normal(&mut self.rng);
            w[axis] += *x;
            integral[axis] += 0.5 * (x_a + *x) * dt;
        }
    }
}

/// The six wandering biases (gyro x, y, z, then accelerometer x, y, z),
/// SI, streamed record by record.
pub struct BiasWander {
    times: Vec<f64>,
    sd: Vec<f64>,
    /// Which processes are integrated exactly.
    exact: Vec<bool>,
    /// The transitions over the nominal step.
    nominal: (f64, Vec<Transition>),
    flicker: [Option<MarkovSum>; 2],
    walk: [Option<RandomWalk>; 2],
    /// w at the end of the last record.
    w: [f64; 6],
    integral: [f64; 6],
    elapsed: f64,
}

impl BiasWander {
    /// The wander of `noise` for a run of `run_s` seconds at nominal step
    /// `dt`; `None` when the biases do not wander.
    pub fn new(noise: &Noise, seed: u64, run_s: f64, dt: f64) -> Option<Self> {
        if !noise.has_wander() {
            return None;
        }
        let times = flicker_times_s(run_s);
        let sd: Vec<f64> = flicker_variances(times.len())
            .iter()
            .map(|v| v.sqrt())
            .collect();
        let [b_g, b_a] = noise.bias_instability_si();
        let [k_g, k_a] = noise.random_walk_si();
        let flicker = |b: f64, n| (b > 0.0).then(|| MarkovSum::new(b, &sd, stream(seed, n)));
        let walk = |k: f64, n| {
            (k > 0.0).then(|| RandomWalk {
                k,
                w: [0.0; 3],
                rng: stream(seed, n),
            })
        };
        let mut wander = BiasWander {
            exact: times.iter().map(|t| *t < EXACT_BELOW * dt).collect(),
            nominal: (dt, Vec::new()),
            flicker: [
                flicker(b_g, STREAM_GYRO_INSTABILITY),
                flicker(b_a, STREAM_ACCEL_INSTABILITY),
            ],
            walk: [
                walk(k_g, STREAM_GYRO_RANDOM_WALK),
                walk(k_a, STREAM_ACCEL_RANDOM_WALK),
            ],
            w: [0.0; 6],
            integral: [0.0; 6],
            elapsed: 0.0,
            times,
            sd,
        };
        wander.nominal = (dt, wander.transitions(dt));
        for (f, w) in wander.flicker.iter().zip(wander.w.chunks_mut(3)) {
            if let Some(f) = f {
                f.value(w);
            }
        }
        Some(wander)
    }

    fn transitions(&self, dt: f64) -> Vec<Transition> {
        (0..self.times.len())
            .map(|i| Transition::new(self.times[i], self.sd[i], dt, self.exact[i]))
            .collect()
    }

    /// Advances over a record of length `dt`: ∫ w dt over it, gyro rad
    /// and accelerometer m/s.
    pub fn step(&mut self, dt: f64) -> [f64; 6] {
        let fresh;
        let steps = if dt == self.nominal.0 {
            &self.nominal.1
        } else {
            fresh = self.transitions(dt);
            &fresh
        };
        let (mut w, mut out) = ([0.0; 6], [0.0; 6]);
        for ((f, w), out) in self
            .flicker
            .iter_mut()
            .zip(w.chunks_mut(3))
            .zip(out.chunks_mut(3))
        {
            if let Some(f) = f {
                f.advance(steps, dt, w, out);
            }
        }
        for ((r, w), out) in self
            .walk
            .iter_mut()
            .zip(w.chunks_mut(3))
            .zip(out.chunks_mut(3))
        {
            if let Some(r) = r {
                r.advance(dt, w, out);
            }
        }
        for (sum, add) in self.integral.iter_mut().zip(out) {
            *sum += add;
        }
        self.w = w;
        self.elapsed += dt;
        out
    }

    /// w now (at the end of the last record), SI.
    pub fn value(&self) -> [f64; 6] {
        self.w
    }

    /// The mean of w over every record so far, from t = 0, in reporting
    /// units.
    pub fn mean(&self) -> BiasMean {
        let m = |c: usize, unit: f64| {
            if self.elapsed > 0.0 {
                self.integral[c] / self.elapsed / unit
            } else {
                0.0
            }
        };
        BiasMean {
            gyro: [0, 1, 2].map(|c| m(c, DEG_PER_H)),
            accel: [3, 4, 5].map(|c| m(c, UG)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// IEEE Std 952's flicker floor of the Allan variance per B².
    const FLICKER_FLOOR: f64 = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;

    /// The construction's exact Allan variance is the floor (2 ln 2/π) B²
    /// within 0.1 % from 10 s to a tenth of the longest time, for a short
    /// run and a long one alike.
    #[test]
    fn the_flicker_floor_is_flat_from_ten_seconds_to_the_run_length() {
        for run_s in [600.0, 7200.0, 1e6] {
            let times = flicker_times_s(run_s);
            let variances = flicker_variances(times.len());
            assert!(times[times.len() - 1] >= REACH * run_s);
            let longest = times[times.len() - 1];
            let mut tau = 10.0;
            while tau <= longest / 10.0 {
                let ratio = flicker_avar(&times, &variances, tau) / FLICKER_FLOOR;
                assert!(
                    (ratio - 1.0).abs() < 1e-3,
                    "run {run_s} s, τ {tau} s: {ratio}"
                );
                tau *= 1.25;
            }
        }
    }

    #[test]
    fn the_times_are_log_spaced_from_a_tenth_of_a_second() {
        let times = flicker_times_s(3600.0);
        assert_eq!(times[0], SHORTEST_S);
        assert!(times
            .windows(2)
            .all(|w| (w[1] / w[0] - RATIO).abs() < 1e-12));
        // 0.1 s · 3¹⁵ ≈ 1.4e6 s; a run of 1e6 s reaches 1e7 s.
        assert_eq!(times.len(), 16);
        assert_eq!(flicker_times_s(1e6).len(), 18);
    }

    #[test]
    fn no_wander_without_instability_or_random_walk() {
        assert!(BiasWander::new(&Noise::white(0.001, 5.0), 1, 100.0, 0.01).is_none());
    }

    #[test]
    fn a_random_walk_starts_at_zero() {
        let noise = Noise {
            gyro_rrw_deg_h_rt_h: 1.0,
            ..Noise::default()
        };
        let mut w = BiasWander::new(&noise, 1, 100.0, 0.1).unwrap();
        assert_eq!(w.value(), [0.0; 6]);
        let first = w.step(0.1);
        // The trapezoid from w(0) = 0: half the new value times Δt.
        assert_eq!(first[0], 0.5 * w.value()[0] * 0.1);
        assert_eq!(&w.value()[3..], &[0.0; 3]);
    }
}
