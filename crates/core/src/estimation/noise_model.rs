//! The noise model a calibration assumes (SPEC §2 and §2a): per body axis
//! of each triad, the white noise (ARW, VRW), the pulse quantum, the bias
//! instability B and the bias random walk K, in SI.
//!
//! White noise drives the navigation errors directly; a quantum is a
//! bounded error of the accumulated increments (it never accumulates);
//! B and K are a wandering part of each bias, which the filter carries as
//! states (`wander`). The model is either given (`EstimateOptions::noise`)
//! or measured from the run.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::model::units::{ARCSEC, DEG_PER_H, DEG_PER_RT_H, HOUR, UG, UG_PER_RT_HZ};

/// A sensor noise model in canonical units, one value per triad: SPEC §2's
/// white noise and §2a's real-sensor terms (the truth file's `noise` names;
/// an absent term is zero).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NoiseDensity {
    pub gyro_arw_deg_rt_h: f64,
    pub accel_vrw_ug_rt_hz: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gyro_bias_instability_deg_h: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_bias_instability_ug: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gyro_rrw_deg_h_rt_h: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_rw_ug_rt_h: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gyro_quantum_arcsec: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_quantum_mps: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl NoiseDensity {
    /// White noise only (SPEC §2): ARW in deg/√h, VRW in µg/√Hz.
    pub const fn white(gyro_arw_deg_rt_h: f64, accel_vrw_ug_rt_hz: f64) -> Self {
        NoiseDensity {
            gyro_arw_deg_rt_h,
            accel_vrw_ug_rt_hz,
            gyro_bias_instability_deg_h: 0.0,
            accel_bias_instability_ug: 0.0,
            gyro_rrw_deg_h_rt_h: 0.0,
            accel_rw_ug_rt_h: 0.0,
            gyro_quantum_arcsec: 0.0,
            accel_quantum_mps: 0.0,
        }
    }
}

/// One triad's noise, SI, per body axis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriadNoise {
    /// White-noise density: rad/√s (gyro), m/s/√s (accelerometer).
    pub white: [f64; 3],
    /// Pulse quantum of the increments: rad, m/s; 0 for none.
    pub quantum: [f64; 3],
    /// Bias instability B (the Allan floor is 0.664·B): rad/s, m/s².
    pub instability: [f64; 3],
    /// Bias random walk K (Allan K·√(τ/3)): rad/s/√s, m/s²/√s.
    pub random_walk: [f64; 3],
}

impl TriadNoise {
    /// The same values on every axis.
    pub fn isotropic(white: f64, quantum: f64, instability: f64, random_walk: f64) -> Self {
        TriadNoise {
            white: [white; 3],
            quantum: [quantum; 3],
            instability: [instability; 3],
            random_walk: [random_walk; 3],
        }
    }

    /// Whether the bias wanders on any axis.
    pub fn wanders(&self) -> bool {
        self.instability
            .iter()
            .chain(&self.random_walk)
            .any(|v| *v > 0.0)
    }

    /// The white density of the three axes as one isotropic value: their
    /// RMS (what the estimators that take one density per triad use).
    pub fn white_rms(&self) -> f64 {
        (self.white.iter().map(|w| w * w).sum::<f64>() / 3.0).sqrt()
    }

    /// The spectral density matrix of the white noise in n for the body
    /// attitude `c_b_n`: C diag(N²) Cᵀ.
    pub fn white_density_n(&self, c_b_n: &Matrix3<f64>) -> Matrix3<f64> {
        let d = Matrix3::from_diagonal(&Vector3::from(self.white.map(|w| w * w)));
        c_b_n * d * c_b_n.transpose()
    }

    /// The covariance in n of the quantization error of a sum of
    /// increments: each body axis's remainder is uniform over one quantum
    /// (variance q²/12), rotated by `c_b_n`.
    pub fn quantization_covariance_n(&self, c_b_n: &Matrix3<f64>) -> Matrix3<f64> {
        let d = Matrix3::from_diagonal(&Vector3::from(self.quantum.map(|q| q * q / 12.0)));
        c_b_n * d * c_b_n.transpose()
    }

    fn floored(mut self, min_white: f64) -> Self {
        for w in &mut self.white {
            *w = w.max(min_white);
        }
        self
    }
}

/// Both triads' noise.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoiseModel {
    pub gyro: TriadNoise,
    pub accel: TriadNoise,
}

impl NoiseModel {
    /// The model a [`NoiseDensity`] states (canonical units, one value per
    /// triad).
    pub fn from_density(d: &NoiseDensity) -> Self {
        NoiseModel {
            gyro: TriadNoise::isotropic(
                d.gyro_arw_deg_rt_h * DEG_PER_RT_H,
                d.gyro_quantum_arcsec * ARCSEC,
                d.gyro_bias_instability_deg_h * DEG_PER_H,
                d.gyro_rrw_deg_h_rt_h * DEG_PER_H / HOUR.sqrt(),
            ),
            accel: TriadNoise::isotropic(
                d.accel_vrw_ug_rt_hz * UG_PER_RT_HZ,
                d.accel_quantum_mps,
                d.accel_bias_instability_ug * UG,
                d.accel_rw_ug_rt_h * UG / HOUR.sqrt(),
            ),
        }
    }

    /// White noise only, the same on every axis (rad/√s, m/s/√s).
    pub fn white(arw: f64, vrw: f64) -> Self {
        NoiseModel {
            gyro: TriadNoise::isotropic(arw, 0.0, 0.0, 0.0),
            accel: TriadNoise::isotropic(vrw, 0.0, 0.0, 0.0),
        }
    }

    /// Whether any bias wanders.
    pub fn wanders(&self) -> bool {
        self.gyro.wanders() || self.accel.wanders()
    }

    /// Whether any channel outputs pulses.
    pub fn pulses(&self) -> bool {
        self.gyro
            .quantum
            .iter()
            .chain(&self.accel.quantum)
            .any(|q| *q > 0.0)
    }

    /// The model with its wandering terms (instability, random walk)
    /// removed: white noise and pulses only.
    pub fn without_wander(&self) -> Self {
        let mut m = *self;
        for t in [&mut m.gyro, &mut m.accel] {
            t.instability = [0.0; 3];
            t.random_walk = [0.0; 3];
        }
        m
    }

    /// White noise only: section 2's sensor, without any §2a term.
    pub fn is_white(&self) -> bool {
        !self.wanders() && !self.pulses()
    }

    /// Every white density raised to at least the floors given (a
    /// noise-free run still needs a well-posed filter).
    pub fn floored(self, min_arw: f64, min_vrw: f64) -> Self {
        NoiseModel {
            gyro: self.gyro.floored(min_arw),
            accel: self.accel.floored(min_vrw),
        }
    }

    /// The six bias axes (gyro x, y, z, accelerometer x, y, z) with their
    /// instability and random walk, SI.
    pub fn bias_axes(&self) -> [(f64, f64); 6] {
        std::array::from_fn(|i| {
            let t = if i < 3 { &self.gyro } else { &self.accel };
            (t.instability[i % 3], t.random_walk[i % 3])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_units_become_si() {
        let d = NoiseDensity {
            gyro_arw_deg_rt_h: 0.0003,
            accel_vrw_ug_rt_hz: 5.0,
            gyro_bias_instability_deg_h: 0.002,
            accel_bias_instability_ug: 3.0,
            gyro_rrw_deg_h_rt_h: 0.0003,
            accel_rw_ug_rt_h: 3.0,
            gyro_quantum_arcsec: 1.0,
            accel_quantum_mps: 1e-4,
        };
        let m = NoiseModel::from_density(&d);
        assert!((m.gyro.white[1] - 0.0003 * DEG_PER_RT_H).abs() < 1e-20);
        assert!((m.gyro.quantum[2] - 4.8481368e-6).abs() < 1e-12);
        assert!((m.accel.instability[0] - 3.0 * 9.80665e-6).abs() < 1e-15);
        // 3 µg/√h is 3 µg after an hour: K·√3600 s.
        assert!((m.accel.random_walk[0] * 3600f64.sqrt() - 3.0 * UG).abs() < 1e-15);
        assert!(m.wanders());
        assert!(!NoiseModel::white(1e-7, 1e-5).wanders());
    }

    #[test]
    fn densities_rotate_into_the_navigation_frame() {
        let mut t = TriadNoise::isotropic(0.0, 0.0, 0.0, 0.0);
        t.white = [1.0, 2.0, 3.0];
        t.quantum = [0.0, 0.0, 12f64.sqrt()];
        // Body x → north, y → east, z → down.
        let c = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
        let q = t.white_density_n(&c);
        assert_eq!(q.diagonal(), Vector3::new(4.0, 1.0, 9.0));
        let r = t.quantization_covariance_n(&c);
        assert!((r[(2, 2)] - 1.0).abs() < 1e-15 && r[(0, 0)] == 0.0);
    }
}
