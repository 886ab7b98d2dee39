//! Record generation: the true increments of each record interval,
//! integrated from the trajectory, then the error model (SPEC §2), the
//! effects (SPEC §3) and seeded noise.
//!
//! Integration is Gauss–Legendre quadrature on pieces split at every
//! breakpoint of the rate profiles (where the angular acceleration jumps),
//! with pieces further divided so that none turns more than 0.05 rad (nor,
//! in a flip, advances the phase of its lift and shift by more); on such
//! pieces the 5-point rule is exact to far below 1e-12 of the increment. Dwells are integrated in closed form. ∫|ω_i| dt (scale-factor
//! asymmetry) is also split at the zeros of ω_i, where it has a kink.
//!
//! Choices where SPEC is silent (also in the crate docs):
//! - g-sensitivity G f^b is added to the gyro output beside the bias,
//!   outside (I + K_g), with f^b the specific force at the reference point;
//! - with `accel_delay`, the whole accelerometer channel lags: motion terms,
//!   lever arms, quadratic terms and bias drift are all evaluated over the
//!   delayed interval;
//! - with a thermal model (SPEC §3a) the parameters of each record are
//!   those at the temperature of its interval's midpoint (the gyro's
//!   interval, and the accelerometer's own when it lags), and k Ṫ is
//!   integrated exactly as k (T(t_k) − T(t_k − Δt)); an interval in
//!   which a ramp starts or stops is cut there and each piece takes its
//!   own midpoint (`thermal_pieces`); see `params_over` for why the
//!   midpoint is far below 1e-10 rad of the exact integral;
//! - noise is drawn from a ChaCha8 stream seeded with `seed`: per record
//!   three gyro then three accelerometer standard normal deviates;
//! - a real sensor (SPEC §2a) adds, in this order, to each record: the
//!   floor vibration inside the accelerometer channel, through (I + K_a)
//!   (`vibration`); the white noise, over the record's actual interval;
//!   the wandering biases (`wander`); then the pulse count of the whole
//!   (`pulses`). Records are stamped by `stamps` (jitter, gaps); a lost
//!   record is still made, so every state runs on through a gap.

use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::pulses::PulseCounter;
use super::scheme::Scheme;
use super::stamps::Stamps;
use super::trajectory::{Kinematics, Motion, Trajectory};
use super::vibration::FloorVibration;
use super::wander::{BiasMean, BiasWander};
use crate::model::thermal::REFERENCE_C;
use crate::model::{Effects, ErrorParameters, TemperatureHistory, ThermalTruth};
use crate::nav::attitude::rotvec_to_dcm;
use crate::nav::Site;
use crate::record::Record;

use super::sensor_noise::Noise;

/// Everything a simulated run depends on.
#[derive(Clone, Debug)]
pub struct SimConfig {
    pub site: Site,
    pub sample_rate_hz: f64,
    pub scheme: Scheme,
    pub params: ErrorParameters,
    pub effects: Effects,
    pub noise: Noise,
    /// Rotation vector φ in n, degrees: C_b^n(0) = exp([φ×]).
    pub initial_attitude_error_deg: [f64; 3],
    pub seed: u64,
    /// SPEC §3a: how the parameters move with temperature; `params` are
    /// then the values at 25 °C. `None`: they do not move.
    pub thermal: Option<ThermalTruth>,
    /// SPEC §3a: the unit's temperature through the run. `None`: 25 °C,
    /// and the run states no temperature.
    pub temperature: Option<TemperatureHistory>,
}

impl SimConfig {
    /// Whether the run's records carry a `temp_c` column: a temperature
    /// history other than a soak (a soak is stated once, as metadata
    /// `temperature_c`).
    pub fn temperature_column(&self) -> bool {
        self.temperature
            .as_ref()
            .is_some_and(|h| h.soak_c().is_none())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("invalid scheme: {0}")]
    Scheme(String),
    #[error("invalid site: {0}")]
    Site(String),
    #[error("invalid sample rate {0} Hz: must be finite and > 0")]
    Rate(f64),
    #[error("invalid effects: {0}")]
    Effects(String),
    /// The message names the field.
    #[error("invalid noise: {0}")]
    Noise(String),
    #[error("invalid temperature: {0}")]
    Temperature(String),
}

/// 5-point Gauss–Legendre nodes and weights on [−1, 1].
const GL_NODES: [f64; 5] = [
    -0.906_179_845_938_664,
    -0.538_469_310_105_683_1,
    0.0,
    0.538_469_310_105_683_1,
    0.906_179_845_938_664,
];
const GL_WEIGHTS: [f64; 5] = [
    0.236_926_885_056_189_1,
    0.478_628_670_499_366_5,
    0.568_888_888_888_888_9,
    0.478_628_670_499_366_5,
    0.236_926_885_056_189_1,
];

/// Largest angle one quadrature piece may turn, rad.
const MAX_PIECE_ANGLE: f64 = 0.05;

/// Calls `f(t, weight)` at 5-point Gauss–Legendre nodes over [a, b], cut
/// into pieces that each turn at most `MAX_PIECE_ANGLE` of the `span`.
fn gauss_legendre(a: f64, b: f64, span: f64, mut f: impl FnMut(f64, f64)) {
    let pieces = ((span / MAX_PIECE_ANGLE).ceil() as usize).max(1);
    let h = (b - a) / pieces as f64;
    for p in 0..pieces {
        let mid = a + (p as f64 + 0.5) * h;
        for (x, w) in GL_NODES.iter().zip(GL_WEIGHTS.iter()) {
            f(mid + 0.5 * h * x, 0.5 * h * w);
        }
    }
}

/// Integrals of the true motion over one gyro interval.
#[derive(Default)]
struct GyroIntegrals {
    dtheta: Vector3<f64>,
    f: Vector3<f64>,
    abs_omega: Vector3<f64>,
}

/// Integrals of what each accelerometer senses over its interval: ∫a_i dt
/// (a_i = f^b without lever arms) and ∫(e_iᵀ a_i)² dt.
#[derive(Default)]
struct AccelIntegrals {
    a: [Vector3<f64>; 3],
    a_sq: Vector3<f64>,
}

/// A stream of simulated records; memory does not depend on the run length.
pub struct Simulator {
    traj: Trajectory,
    params: ErrorParameters,
    effects: Effects,
    dt: f64,
    n_records: u64,
    k: u64,
    rng: ChaCha8Rng,
    sigma_gyro: f64,
    sigma_accel: f64,
    delay: f64,
    lever_b: Option<[Vector3<f64>; 3]>,
    g_sens: Option<Matrix3<f64>>,
    asym: Option<Vector3<f64>>,
    drift_gyro: Vector3<f64>,
    drift_accel: Vector3<f64>,
    thermal: Option<ThermalTruth>,
    temperature: Option<TemperatureHistory>,
    hint: usize,
    stamps: Stamps,
    /// Records the logger loses (in gaps), and records written so far.
    n_lost: u64,
    written: u64,
    wander: Option<BiasWander>,
    vibration: Option<FloorVibration>,
    pulses: Option<PulseCounter>,
}

/// Prepares the record stream of a configuration.
pub fn simulate(cfg: &SimConfig) -> Result<Simulator, SimError> {
    Simulator::new(cfg)
}

impl Simulator {
    pub fn new(cfg: &SimConfig) -> Result<Self, SimError> {
        let rate = cfg.sample_rate_hz;
        if !(rate.is_finite() && rate > 0.0) {
            return Err(SimError::Rate(rate));
        }
        cfg.site.validate().map_err(SimError::Site)?;
        cfg.effects.validate().map_err(SimError::Effects)?;
        if let Some(h) = &cfg.temperature {
            h.validate()
                .map_err(|e| SimError::Temperature(e.to_string()))?;
        }
        cfg.noise.validate().map_err(SimError::Noise)?;
        let phi = Vector3::from(cfg.initial_attitude_error_deg).map(f64::to_radians);
        let traj = Trajectory::new(&cfg.scheme, &rotvec_to_dcm(&phi), &cfg.site)
            .map_err(SimError::Scheme)?;
        let dt = 1.0 / rate;
        // t_k = kΔt for k = 1 … floor(T/Δt); the epsilon keeps an exact
        // multiple from losing its last record to rounding.
        let n_records = (traj.duration() * rate + 1e-9).floor() as u64;
        let drift = cfg.effects.bias_drift;
        let noise = &cfg.noise;
        let stamps = Stamps::new(rate, noise.time_jitter_pct, cfg.seed, &noise.gaps);
        let [q_gyro, q_accel] = noise.quanta_si();
        Ok(Simulator {
            n_lost: stamps.count_lost(n_records),
            written: 0,
            stamps,
            wander: BiasWander::new(noise, cfg.seed, traj.duration(), dt),
            vibration: noise
                .vibration
                .and_then(|v| FloorVibration::new(&v, cfg.seed, cfg.site.omega_ie_n(), dt)),
            pulses: PulseCounter::new(q_gyro, q_accel),
            params: cfg.params,
            effects: cfg.effects,
            dt,
            n_records,
            k: 0,
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            sigma_gyro: cfg.noise.arw_si() * dt.sqrt(),
            sigma_accel: cfg.noise.vrw_si() * dt.sqrt(),
            delay: cfg.effects.accel_delay_s(),
            lever_b: cfg.effects.accel_lever_arm.map(|l| l.r_b()),
            g_sens: cfg.effects.gyro_g_sensitivity_si(),
            asym: cfg.effects.gyro_scale_asymmetry_si(),
            drift_gyro: drift.map_or_else(Vector3::zeros, |d| d.gyro_si()),
            drift_accel: drift.map_or_else(Vector3::zeros, |d| d.accel_si()),
            thermal: cfg.thermal.filter(|m| !m.is_zero()),
            temperature: cfg.temperature.clone(),
            traj,
            hint: 0,
        })
    }

    pub fn trajectory(&self) -> &Trajectory {
        &self.traj
    }

    /// Number of records the run holds (those lost in gaps left out).
    pub fn n_records(&self) -> u64 {
        self.n_records - self.n_lost
    }

    /// The mean of each wandering bias over every record made so far, from
    /// t = 0 (those lost in gaps included): after the last record, the
    /// truth's `bias_mean_over_run`. `None` when the biases do not wander.
    pub fn bias_mean_over_run(&self) -> Option<BiasMean> {
        self.wander.as_ref().map(BiasWander::mean)
    }

    pub fn dt(&self) -> f64 {
        self.dt
    }

    pub fn effects(&self) -> &Effects {
        &self.effects
    }

    /// The unit's temperature at `t`, °C, when the run has a temperature
    /// (history or soak).
    pub fn temperature_c(&self, t: f64) -> Option<f64> {
        self.temperature.as_ref().map(|h| h.temperature_c(t))
    }

    /// T(t), 25 °C when the run has no temperature.
    fn temperature_or_reference(&self, t: f64) -> f64 {
        self.temperature_c(t).unwrap_or(REFERENCE_C)
    }

    /// The parameters in force over an interval: at its midpoint's
    /// temperature. Midpoint rather than per quadrature node, because
    /// temperature moves slowly: the neglected term is
    ///
    /// ```text
    /// ∫ (p(t) − p(t_m)) x(t) dt ≈ ṗ ∫ (t − t_m) x(t) dt  ≤ ṗ · |ẋ| Δt³ / 12
    /// ```
    ///
    /// which with ṗ = 1 ppm/°C at 1 °C/min and a turn's 0.35 rad/s² is
    /// 5e-16 rad at 100 Hz. A bias linear in T is linear in t over an
    /// interval where T ramps, and the midpoint integrates it exactly; a
    /// quadratic one leaves p2 Ṫ² Δt³ / 12, 1e-19 rad for p2 = 0.001
    /// deg/h/°C² at 1 °C/min. The rate term k Ṫ is integrated exactly.
    fn params_over(&self, ta: f64, tb: f64) -> ErrorParameters {
        match &self.thermal {
            Some(m) => m.params_at(&self.params, self.temperature_or_reference(0.5 * (ta + tb))),
            None => self.params,
        }
    }

    /// Calls `f(kinematics, weight)` at quadrature nodes covering
    /// [ta, tb], so that Σ weight·g(kinematics) ≈ ∫ g dt.
    fn quadrature(&mut self, ta: f64, tb: f64, mut f: impl FnMut(&Kinematics, f64)) {
        let bps = self.traj.breakpoints();
        let mut i = bps.partition_point(|&b| b <= ta);
        let mut u0 = ta;
        loop {
            let u1 = if i < bps.len() && bps[i] < tb {
                bps[i]
            } else {
                tb
            };
            if u1 > u0 {
                let mid = 0.5 * (u0 + u1);
                let seg = self.traj.segment_index(mid, self.hint);
                self.hint = seg;
                let resting = mid < 0.0
                    || matches!(self.traj.segments()[seg].motion, Motion::Dwell)
                    || mid >= self.traj.duration();
                if resting {
                    // Constant integrand: one node is exact.
                    f(&self.traj.kinematics_in(seg, mid), u1 - u0);
                } else {
                    let traj = &self.traj;
                    gauss_legendre(u0, u1, traj.angle_span(seg, u0, u1), |t, w| {
                        f(&traj.kinematics_in(seg, t), w)
                    });
                }
            }
            if u1 >= tb {
                break;
            }
            u0 = u1;
            i += 1;
        }
    }

    /// ∫|ω_i| dt over [ta, tb] per axis, split at the zeros of ω_i.
    fn integrate_abs_rate(&mut self, ta: f64, tb: f64) -> Vector3<f64> {
        let mut out = Vector3::zeros();
        let bps: Vec<f64> = {
            let b = self.traj.breakpoints();
            let lo = b.partition_point(|&x| x <= ta);
            let hi = b.partition_point(|&x| x < tb);
            b[lo..hi].to_vec()
        };
        let mut edges = Vec::with_capacity(bps.len() + 2);
        edges.push(ta);
        edges.extend(bps);
        edges.push(tb);
        for w in edges.windows(2) {
            let (u0, u1) = (w[0], w[1]);
            if u1 <= u0 {
                continue;
            }
            let seg = self.traj.segment_index(0.5 * (u0 + u1), self.hint);
            for axis in 0..3 {
                let omega = |t: f64| self.traj.kinematics_in(seg, t).omega_ib_b[axis];
                // Sample, find sign changes, locate each zero by bisection.
                const SAMPLES: usize = 8;
                let mut cuts = vec![u0];
                let mut prev_t = u0;
                let mut prev_v = omega(u0);
                for s in 1..=SAMPLES {
                    let t = u0 + (u1 - u0) * s as f64 / SAMPLES as f64;
                    let v = omega(t);
                    if prev_v * v < 0.0 {
                        let (mut lo, mut hi, mut lo_v) = (prev_t, t, prev_v);
                        for _ in 0..200 {
                            let m = 0.5 * (lo + hi);
                            if m <= lo || m >= hi {
                                break;
                            }
                            let mv = omega(m);
                            if mv * lo_v > 0.0 {
                                lo = m;
                                lo_v = mv;
                            } else {
                                hi = m;
                            }
                        }
                        cuts.push(0.5 * (lo + hi));
                    }
                    prev_t = t;
                    prev_v = v;
                }
                cuts.push(u1);
                for c in cuts.windows(2) {
                    let span = self.traj.angle_span(seg, c[0], c[1]);
                    gauss_legendre(c[0], c[1], span, |t, w| out[axis] += w * omega(t).abs());
                }
            }
        }
        out
    }

    fn gyro_integrals(&mut self, ta: f64, tb: f64) -> GyroIntegrals {
        let mut g = GyroIntegrals::default();
        self.quadrature(ta, tb, |k, w| {
            g.dtheta += k.omega_ib_b * w;
            g.f += k.f_b * w;
        });
        if self.asym.is_some() {
            g.abs_omega = self.integrate_abs_rate(ta, tb);
        }
        g
    }

    fn accel_integrals(&mut self, ta: f64, tb: f64) -> AccelIntegrals {
        let mut a = AccelIntegrals::default();
        match self.lever_b {
            None => self.quadrature(ta, tb, |k, w| {
                for (i, ai) in a.a.iter_mut().enumerate() {
                    *ai += k.f_b * w;
                    a.a_sq[i] += k.f_b[i] * k.f_b[i] * w;
                }
            }),
            Some(r) => self.quadrature(ta, tb, |k, w| {
                let om = k.omega_ib_b;
                for i in 0..3 {
                    let ai = k.f_b + k.omega_dot_ib_b.cross(&r[i]) + om.cross(&om.cross(&r[i]));
                    a.a[i] += ai * w;
                    a.a_sq[i] += ai[i] * ai[i] * w;
                }
            }),
        }
        a
    }

    /// The noise-free record over (t_prev, t], `dt` long (the nominal step
    /// unless the stamps jitter), from the integrals.
    fn record(&mut self, t_prev: f64, t: f64, dt: f64) -> Record {
        let mut dtheta = Vector3::zeros();
        let mut int_f = Vector3::zeros();
        let mut int_abs_omega = Vector3::zeros();
        let edges = self.thermal_pieces(t_prev, t);
        for w in edges.windows(2) {
            // One piece is the whole record, whose Δt is the nominal one.
            let len = if edges.len() == 2 { dt } else { w[1] - w[0] };
            let gi = self.gyro_integrals(w[0], w[1]);
            dtheta += self.params_over(w[0], w[1]).apply_gyro(&gi.dtheta, len);
            int_f += gi.f;
            int_abs_omega += gi.abs_omega;
        }
        if let (Some(m), Some(h)) = (&self.thermal, &self.temperature) {
            // k Ṫ integrated exactly: k times the change of T.
            dtheta += m.gyro_angle_from_change(h.temperature_c(t) - h.temperature_c(t_prev));
        }
        // ∫ ḃ t dt over the interval.
        dtheta += self.drift_gyro * (0.5 * (t * t - t_prev * t_prev));
        if let Some(g) = self.g_sens {
            dtheta += g * int_f;
        }
        if let Some(asym) = self.asym {
            dtheta += asym.component_mul(&int_abs_omega);
        }

        // A lagging accelerometer channel lags in temperature too: its
        // parameters are those of the interval it integrates.
        let (ta, tb) = (t_prev - self.delay, t - self.delay);
        let mut dv = Vector3::zeros();
        let edges = self.thermal_pieces(ta, tb);
        for w in edges.windows(2) {
            let len = if edges.len() == 2 { dt } else { w[1] - w[0] };
            let ai = self.accel_integrals(w[0], w[1]);
            let p = self.params_over(w[0], w[1]);
            let i_ka = Matrix3::identity() + p.k_a();
            let (b_a, d_a) = (p.b_a(), p.d_a());
            for i in 0..3 {
                dv[i] += i_ka.row(i).dot(&ai.a[i].transpose()) + b_a[i] * len + d_a[i] * ai.a_sq[i];
            }
            if let Some(v) = &mut self.vibration {
                dv += i_ka * v.integral_b(&self.traj, w[0], w[1]);
            }
        }
        dv += self.drift_accel * (0.5 * (tb * tb - ta * ta));

        Record {
            t,
            dtheta: dtheta.into(),
            dv: dv.into(),
        }
    }

    /// Edges of the pieces of [ta, tb] on which T(t) is linear: the
    /// interval cut where a temperature ramp starts or stops, so that the
    /// parameters' midpoint rule (`params_over`) never straddles a kink,
    /// where it would be off by p1 ΔṪ Δt² / 8.
    fn thermal_pieces(&self, ta: f64, tb: f64) -> Vec<f64> {
        let mut edges = vec![ta];
        if let (Some(_), Some(h)) = (&self.thermal, &self.temperature) {
            let mut u = ta;
            while let Some(b) = h.next_break_after(u).filter(|b| *b < tb) {
                edges.push(b);
                u = b;
            }
        }
        edges.push(tb);
        edges
    }
}

impl Iterator for Simulator {
    type Item = Record;

    fn next(&mut self) -> Option<Record> {
        while self.k < self.n_records {
            self.k += 1;
            let (t_prev, t) = self.stamps.interval(self.k);
            let jittered = self.stamps.jittered();
            let dt = if jittered { t - t_prev } else { self.dt };
            let mut r = self.record(t_prev, t, dt);
            if self.sigma_gyro > 0.0 || self.sigma_accel > 0.0 {
                // White noise over the record's own interval.
                let scale = if jittered { (dt / self.dt).sqrt() } else { 1.0 };
                for i in 0..3 {
                    let z: f64 = StandardNormal.sample(&mut self.rng);
                    r.dtheta[i] += self.sigma_gyro * scale * z;
                }
                for i in 0..3 {
                    let z: f64 = StandardNormal.sample(&mut self.rng);
                    r.dv[i] += self.sigma_accel * scale * z;
                }
            }
            if let Some(w) = &mut self.wander {
                let drift = w.step(dt);
                for i in 0..3 {
                    r.dtheta[i] += drift[i];
                    r.dv[i] += drift[3 + i];
                }
            }
            if let Some(p) = &mut self.pulses {
                p.count(&mut r);
            }
            if !self.stamps.lost(t) {
                self.written += 1;
                return Some(r);
            }
        }
        None
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = (self.n_records() - self.written) as usize;
        (left, Some(left))
    }
}

impl ExactSizeIterator for Simulator {}
