//! Floor vibration (SPEC §2a): the base shakes with a zero-mean,
//! band-limited acceleration without moving on average.
//!
//! The project's model: each navigation axis (east, north, up) shakes on
//! its own with a sum of M = 40 sinusoids, a^n_i(t) = Σ_j A cos(ω_j t + φ_j),
//! A = r·√(2/M) so that the mean square over time is r²; the frequencies
//! are stratified over the band (one uniform draw in each of M equal
//! sub-bands, so no two coincide) and the phases uniform. The velocity
//! v^n_i(t) = Σ_j (A/ω_j) sin(ω_j t + φ_j) and the displacement
//! −Σ_j (A/ω_j²) cos(ω_j t + φ_j) are bounded and zero-mean. The base is
//! shaking before the run starts (the sinusoids run from t = −∞). Draws:
//! ChaCha8 stream 7 of the run's seed, east then north then up, for each
//! sinusoid its frequency then its phase.
//!
//! The accelerometers sense the vibration in body axes through (I + K_a).
//! The increment is integrated in closed form: with ω_nb^b the body's turn
//! rate relative to n (n is fixed to the Earth),
//!
//! ```text
//! ∫ C_n^b a^n dt = [C_n^b v^n] + ∫ ω_nb^b × (C_n^b v^n) dt
//! ```
//!
//! At rest ω_nb^b = 0 and a record's vibration is an exact difference of
//! the bounded velocity, so the increments of a dwell sum to C_n^b Δv^n;
//! during a turn the small second term (turn rate times the vibration's
//! velocity) is integrated by 5-point Gauss–Legendre quadrature on pieces
//! of at most a third of the band's shortest period (exact to parts in 1e9
//! of that term). The vibration enters neither the quadratic
//! terms nor the g-sensitivity (with the paper's magnitudes and 30 µg a
//! zero-mean 0.03 µg and 1e-6 deg/h), nor the gyros.

use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::sensor_noise::Vibration;
use super::trajectory::{Motion, Trajectory};
use crate::model::units::UG;

/// The vibration's random stream.
pub const STREAM_VIBRATION: u64 = 7;
/// Sinusoids per axis.
pub const TONES: usize = 40;

/// 5-point Gauss–Legendre nodes and weights on [−1, 1].
const GL: [(f64, f64); 5] = [
    (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
    (-0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (0.0, 0.568_888_888_888_888_9),
    (0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (0.906_179_845_938_664, 0.236_926_885_056_189_1),
];

#[derive(Clone, Copy, Debug)]
struct Tone {
    omega: f64,
    phase: f64,
}

/// The base's vibration and its integral in body axes along a trajectory.
#[derive(Clone, Debug)]
pub struct FloorVibration {
    amplitude: f64,
    tones: [Vec<Tone>; 3],
    highest_hz: f64,
    omega_ie_n: Vector3<f64>,
    /// The last C_n^b v^n evaluated, and its time: each record's start is
    /// the previous record's end.
    last: Option<(f64, Vector3<f64>)>,
    /// Each sinusoid's phase as (cos, sin), carried from record to record.
    phasors: Phasors,
}

/// Sinusoids stepped by rotation: a record one nominal step after the last
/// turns each phasor by ω·Δt (four products) instead of evaluating a sine
/// at a large argument. Every [`REANCHOR`] steps, and whenever the step is
/// not the nominal one (jitter, a delayed or cut interval), the phasors are
/// evaluated afresh, so the rounding carried is that of a few thousand
/// rotations: parts in 1e10 of the velocity (1e-15 m/s at 30 µg), and
/// each record remains an exact difference of the velocities stepped.
#[derive(Clone, Debug)]
struct Phasors {
    step: f64,
    turn: [Vec<(f64, f64)>; 3],
    at: Option<f64>,
    steps: u32,
    phase: [Vec<(f64, f64)>; 3],
}

/// Rotations between fresh evaluations of the phasors.
const REANCHOR: u32 = 4096;

impl FloorVibration {
    /// The vibration of `v` at a site turning with `omega_ie_n`, sensed in
    /// records of nominal step `dt`; `None` when its rms is zero.
    pub fn new(v: &Vibration, seed: u64, omega_ie_n: Vector3<f64>, dt: f64) -> Option<Self> {
        if v.rms_ug <= 0.0 {
            return None;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(STREAM_VIBRATION);
        let [lo, hi] = v.band_hz;
        let width = (hi - lo) / TONES as f64;
        let tones = [(); 3].map(|_| {
            (0..TONES)
                .map(|j| {
                    let f = lo + (j as f64 + rng.gen::<f64>()) * width;
                    Tone {
                        omega: std::f64::consts::TAU * f,
                        phase: std::f64::consts::TAU * rng.gen::<f64>(),
                    }
                })
                .collect()
        });
        let turn = tones.clone().map(|axis: Vec<Tone>| {
            axis.iter()
                .map(|w| ((w.omega * dt).cos(), (w.omega * dt).sin()))
                .collect()
        });
        Some(FloorVibration {
            amplitude: v.rms_ug * UG * (2.0 / TONES as f64).sqrt(),
            phasors: Phasors {
                step: dt,
                turn,
                at: None,
                steps: 0,
                phase: [Vec::new(), Vec::new(), Vec::new()],
            },
            tones,
            highest_hz: hi,
            omega_ie_n,
            last: None,
        })
    }

    fn sum(&self, term: impl Fn(&Tone) -> f64) -> Vector3<f64> {
        Vector3::from_fn(|i, _| self.amplitude * self.tones[i].iter().map(&term).sum::<f64>())
    }

    /// The base's acceleration in n, m/s².
    pub fn acceleration_n(&self, t: f64) -> Vector3<f64> {
        self.sum(|w| (w.omega * t + w.phase).cos())
    }

    /// The base's velocity in n, m/s.
    pub fn velocity_n(&self, t: f64) -> Vector3<f64> {
        self.sum(|w| (w.omega * t + w.phase).sin() / w.omega)
    }

    /// The base's displacement in n from its mean place, m.
    pub fn displacement_n(&self, t: f64) -> Vector3<f64> {
        self.sum(|w| -(w.omega * t + w.phase).cos() / (w.omega * w.omega))
    }

    /// C_n^b v^n at t, from the last value when t is its time.
    fn body_velocity(&mut self, traj: &Trajectory, t: f64) -> Vector3<f64> {
        if let Some((t_last, v)) = self.last {
            if t_last == t {
                return v;
            }
        }
        let v = traj.kinematics(t).c_b_n.transpose() * self.stepped_velocity_n(t);
        self.last = Some((t, v));
        v
    }

    /// v^n(t) from the phasors: turned one step when t is one nominal step
    /// after their time, evaluated afresh otherwise.
    fn stepped_velocity_n(&mut self, t: f64) -> Vector3<f64> {
        let p = &mut self.phasors;
        let one_step =
            p.at.is_some_and(|at| ((t - at) - p.step).abs() <= 1e-9 * p.step && p.steps < REANCHOR);
        if one_step {
            for (phase, turn) in p.phase.iter_mut().zip(&p.turn) {
                for ((c, s), (tc, ts)) in phase.iter_mut().zip(turn) {
                    (*c, *s) = (*c * tc - *s * ts, *s * tc + *c * ts);
                }
            }
            p.steps += 1;
        } else {
            for (phase, tones) in p.phase.iter_mut().zip(&self.tones) {
                *phase = tones
                    .iter()
                    .map(|w| {
                        let (s, c) = (w.omega * t + w.phase).sin_cos();
                        (c, s)
                    })
                    .collect();
            }
            p.steps = 0;
        }
        p.at = Some(t);
        Vector3::from_fn(|i, _| {
            self.amplitude
                * p.phase[i]
                    .iter()
                    .zip(&self.tones[i])
                    .map(|((_, s), w)| s / w.omega)
                    .sum::<f64>()
        })
    }

    /// ∫ C_n^b a^n dt over [ta, tb], body axes, m/s.
    pub fn integral_b(&mut self, traj: &Trajectory, ta: f64, tb: f64) -> Vector3<f64> {
        let start = self.body_velocity(traj, ta);
        let end = self.body_velocity(traj, tb);
        end - start + self.turning_part(traj, ta, tb)
    }

    /// ∫ ω_nb^b × (C_n^b v^n) dt over [ta, tb]: zero at rest.
    fn turning_part(&self, traj: &Trajectory, ta: f64, tb: f64) -> Vector3<f64> {
        let mut out = Vector3::zeros();
        let bps = traj.breakpoints();
        let mut i = bps.partition_point(|&b| b <= ta);
        let mut u0 = ta;
        while u0 < tb {
            let u1 = if i < bps.len() && bps[i] < tb {
                bps[i]
            } else {
                tb
            };
            let mid = 0.5 * (u0 + u1);
            let seg = traj.segment_index(mid, 0);
            let turning = mid >= 0.0
                && mid < traj.duration()
                && !matches!(traj.segments()[seg].motion, Motion::Dwell);
            if turning && u1 > u0 {
                let pieces = ((u1 - u0) * self.highest_hz * 3.0).ceil().max(1.0) as usize;
                let h = (u1 - u0) / pieces as f64;
                for p in 0..pieces {
                    let centre = u0 + (p as f64 + 0.5) * h;
                    for (x, w) in GL {
                        let t = centre + 0.5 * h * x;
                        let k = traj.kinematics_in(seg, t);
                        let c_n_b: Matrix3<f64> = k.c_b_n.transpose();
                        let omega_nb_b = k.omega_ib_b - c_n_b * self.omega_ie_n;
                        let v_b = c_n_b * self.velocity_n(t);
                        out += omega_nb_b.cross(&v_b) * (0.5 * h * w);
                    }
                }
            }
            u0 = u1;
            i += 1;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vibration() -> FloorVibration {
        let v = Vibration {
            rms_ug: 30.0,
            band_hz: [2.0, 30.0],
        };
        FloorVibration::new(&v, 5, Vector3::zeros(), 0.01).unwrap()
    }

    #[test]
    fn velocity_is_the_integral_of_acceleration() {
        let v = vibration();
        let (ta, tb) = (12.3, 12.31);
        let mut sum = Vector3::zeros();
        let n = 2000;
        for s in 0..n {
            let t = ta + (s as f64 + 0.5) * (tb - ta) / n as f64;
            sum += v.acceleration_n(t) * ((tb - ta) / n as f64);
        }
        let diff = v.velocity_n(tb) - v.velocity_n(ta);
        assert!(
            (sum - diff).norm() < 1e-6 * diff.norm().max(1e-9),
            "{sum} {diff}"
        );
    }

    #[test]
    fn stepped_phasors_follow_the_closed_form() {
        let mut v = vibration();
        let mut worst: f64 = 0.0;
        for k in 0..10_000u32 {
            // A jump now and then re-anchors, as a jittered record would.
            let t = 1000.0 + f64::from(k) * 0.01 + if k % 3001 == 7 { 1e-4 } else { 0.0 };
            let exact = v.velocity_n(t);
            worst = worst.max((v.stepped_velocity_n(t) - exact).norm() / exact.norm());
        }
        assert!(worst < 1e-9, "{worst}");
    }

    #[test]
    fn the_rms_is_as_asked() {
        let v = vibration();
        let n = 400_000;
        let mut sq = Vector3::zeros();
        for s in 0..n {
            let a = v.acceleration_n(s as f64 * 0.0037);
            sq += a.component_mul(&a);
        }
        for i in 0..3 {
            let rms = (sq[i] / n as f64).sqrt() / UG;
            assert!((rms / 30.0 - 1.0).abs() < 0.02, "axis {i}: {rms} µg");
        }
    }
}
