//! What a simulated unit's sensors add beyond the error model: white noise
//! (SPEC §2) and the real sensor's wandering biases, pulse outputs, floor
//! vibration and time stamps (SPEC §2a), in the units of the truth JSON's
//! `"noise"` object. Every field but the white densities is absent (zero)
//! by default, and a truth without them simulates as it always did.

use serde::{Deserialize, Serialize};

use crate::model::units::{ARCSEC, DEG_PER_H, DEG_PER_RT_H, UG, UG_PER_RT_HZ};

/// √h in s^½: a density per √h is the same density per √s over 60.
const RT_HOUR_S: f64 = 60.0;

/// Floor vibration: the base's band-limited acceleration, each navigation
/// axis independent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vibration {
    /// RMS acceleration of each axis, µg.
    pub rms_ug: f64,
    /// The band, Hz: [lo, hi], 0 < lo ≤ hi.
    pub band_hz: [f64; 2],
}

/// Records lost by the logger: those stamped in [start, start + duration).
/// JSON: `[t_start_s, duration_s]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "[f64; 2]", into = "[f64; 2]")]
pub struct Gap {
    pub start_s: f64,
    pub duration_s: f64,
}

impl From<[f64; 2]> for Gap {
    fn from([start_s, duration_s]: [f64; 2]) -> Self {
        Gap {
            start_s,
            duration_s,
        }
    }
}

impl From<Gap> for [f64; 2] {
    fn from(g: Gap) -> Self {
        [g.start_s, g.duration_s]
    }
}

impl Gap {
    /// Whether a record stamped `t` is lost.
    pub fn holds(&self, t: f64) -> bool {
        t >= self.start_s && t < self.start_s + self.duration_s
    }
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// The sensors' noise (SPEC §2, §2a).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// Gyro angle random walk, deg/√h.
    #[serde(default)]
    pub gyro_arw_deg_rt_h: f64,
    /// Accelerometer velocity random walk, µg/√Hz.
    #[serde(default)]
    pub accel_vrw_ug_rt_hz: f64,
    /// Gyro bias instability B, deg/h: Allan floor 0.664·B.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gyro_bias_instability_deg_h: f64,
    /// Accelerometer bias instability B, µg.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_bias_instability_ug: f64,
    /// Gyro rate random walk K, deg/h/√h.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gyro_rrw_deg_h_rt_h: f64,
    /// Accelerometer (acceleration) random walk K, µg/√h.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_rw_ug_rt_h: f64,
    /// Gyro pulse weight, arcsec.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gyro_quantum_arcsec: f64,
    /// Accelerometer pulse weight, m/s.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_quantum_mps: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vibration: Option<Vibration>,
    /// Every step within ±j % of the nominal step.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub time_jitter_pct: f64,
    /// The project's own field (not SPEC's): records the logger lost.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gaps: Vec<Gap>,
}

impl Noise {
    /// The defaults of `sinscal simulate`: 0.0003 deg/√h, 5 µg/√Hz.
    pub fn default_navigation_grade() -> Self {
        Noise {
            gyro_arw_deg_rt_h: 0.0003,
            accel_vrw_ug_rt_hz: 5.0,
            ..Noise::default()
        }
    }

    /// White noise only (SPEC §2).
    pub fn white(gyro_arw_deg_rt_h: f64, accel_vrw_ug_rt_hz: f64) -> Self {
        Noise {
            gyro_arw_deg_rt_h,
            accel_vrw_ug_rt_hz,
            ..Noise::default()
        }
    }

    /// `sinscal simulate --real-sensor`: a typical navigation-grade RLG
    /// unit on a lab floor, its white noise that of
    /// [`Noise::default_navigation_grade`].
    pub fn real_navigation_grade() -> Self {
        Noise {
            gyro_bias_instability_deg_h: 0.002,
            accel_bias_instability_ug: 3.0,
            gyro_rrw_deg_h_rt_h: 0.0003,
            accel_rw_ug_rt_h: 3.0,
            gyro_quantum_arcsec: 1.0,
            accel_quantum_mps: 1e-4,
            vibration: Some(Vibration {
                rms_ug: 30.0,
                band_hz: [2.0, 30.0],
            }),
            ..Noise::default_navigation_grade()
        }
    }

    /// ARW in rad/√s.
    pub fn arw_si(&self) -> f64 {
        self.gyro_arw_deg_rt_h * DEG_PER_RT_H
    }

    /// VRW in (m/s)/√s.
    pub fn vrw_si(&self) -> f64 {
        self.accel_vrw_ug_rt_hz * UG_PER_RT_HZ
    }

    /// Bias instability B, gyro rad/s and accelerometer m/s².
    pub fn bias_instability_si(&self) -> [f64; 2] {
        [
            self.gyro_bias_instability_deg_h * DEG_PER_H,
            self.accel_bias_instability_ug * UG,
        ]
    }

    /// Random walk K, gyro rad/s/√s and accelerometer m/s²/√s.
    pub fn random_walk_si(&self) -> [f64; 2] {
        [
            self.gyro_rrw_deg_h_rt_h * DEG_PER_H / RT_HOUR_S,
            self.accel_rw_ug_rt_h * UG / RT_HOUR_S,
        ]
    }

    /// Pulse weights, gyro rad and accelerometer m/s (0: no pulses).
    pub fn quanta_si(&self) -> [f64; 2] {
        [self.gyro_quantum_arcsec * ARCSEC, self.accel_quantum_mps]
    }

    /// Whether the biases wander (instability or random walk).
    pub fn has_wander(&self) -> bool {
        self.bias_instability_si()
            .iter()
            .chain(self.random_walk_si().iter())
            .any(|x| *x > 0.0)
    }

    /// Checks every value; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        let non_negative = |name: &str, x: f64| {
            if x.is_finite() && x >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name} {x} must be finite and ≥ 0"))
            }
        };
        for (name, x) in [
            ("gyro_arw_deg_rt_h", self.gyro_arw_deg_rt_h),
            ("accel_vrw_ug_rt_hz", self.accel_vrw_ug_rt_hz),
            (
                "gyro_bias_instability_deg_h",
                self.gyro_bias_instability_deg_h,
            ),
            ("accel_bias_instability_ug", self.accel_bias_instability_ug),
            ("gyro_rrw_deg_h_rt_h", self.gyro_rrw_deg_h_rt_h),
            ("accel_rw_ug_rt_h", self.accel_rw_ug_rt_h),
            ("gyro_quantum_arcsec", self.gyro_quantum_arcsec),
            ("accel_quantum_mps", self.accel_quantum_mps),
            ("time_jitter_pct", self.time_jitter_pct),
        ] {
            non_negative(name, x)?;
        }
        if self.time_jitter_pct >= 100.0 {
            return Err(format!(
                "time_jitter_pct {} must be below 100 (a step must stay positive)",
                self.time_jitter_pct
            ));
        }
        if let Some(v) = &self.vibration {
            non_negative("vibration.rms_ug", v.rms_ug)?;
            let [lo, hi] = v.band_hz;
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
                return Err(format!(
                    "vibration.band_hz [{lo}, {hi}] must be finite with 0 < lo ≤ hi"
                ));
            }
        }
        for (i, g) in self.gaps.iter().enumerate() {
            if !(g.start_s.is_finite() && g.start_s >= 0.0) {
                return Err(format!(
                    "gaps[{i}] start {} must be finite and ≥ 0",
                    g.start_s
                ));
            }
            if !(g.duration_s.is_finite() && g.duration_s > 0.0) {
                return Err(format!(
                    "gaps[{i}] duration {} must be finite and > 0",
                    g.duration_s
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_alone_serializes_as_before() {
        let text = serde_json::to_string(&Noise::white(0.001, 5.0)).unwrap();
        assert_eq!(
            text,
            r#"{"gyro_arw_deg_rt_h":0.001,"accel_vrw_ug_rt_hz":5.0}"#
        );
    }

    #[test]
    fn real_sensor_fields_round_trip() {
        let text = r#"{"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5,
            "gyro_bias_instability_deg_h": 0.002, "accel_bias_instability_ug": 3,
            "gyro_rrw_deg_h_rt_h": 0.0003, "accel_rw_ug_rt_h": 3,
            "gyro_quantum_arcsec": 1, "accel_quantum_mps": 1e-4,
            "vibration": {"rms_ug": 30, "band_hz": [2, 30]},
            "time_jitter_pct": 5, "gaps": [[100, 2.5]]}"#;
        let noise: Noise = serde_json::from_str(text).unwrap();
        assert!(noise.validate().is_ok());
        assert_eq!(noise.gaps[0].duration_s, 2.5);
        let back: Noise = serde_json::from_value(serde_json::to_value(&noise).unwrap()).unwrap();
        assert_eq!(back, noise);
        assert!(serde_json::from_str::<Noise>(r#"{"gyro_bias_instabilty_deg_h": 1}"#).is_err());
    }

    #[test]
    fn bad_values_are_refused_by_name() {
        let cases: [(&str, Noise); 6] = [
            (
                "gyro_rrw_deg_h_rt_h",
                Noise {
                    gyro_rrw_deg_h_rt_h: -1.0,
                    ..Noise::default()
                },
            ),
            (
                "accel_bias_instability_ug",
                Noise {
                    accel_bias_instability_ug: f64::NAN,
                    ..Noise::default()
                },
            ),
            (
                "accel_quantum_mps",
                Noise {
                    accel_quantum_mps: f64::INFINITY,
                    ..Noise::default()
                },
            ),
            (
                "time_jitter_pct",
                Noise {
                    time_jitter_pct: 100.0,
                    ..Noise::default()
                },
            ),
            (
                "vibration.band_hz",
                Noise {
                    vibration: Some(Vibration {
                        rms_ug: 1.0,
                        band_hz: [0.0, 10.0],
                    }),
                    ..Noise::default()
                },
            ),
            (
                "gaps[0]",
                Noise {
                    gaps: vec![Gap::from([10.0, -1.0])],
                    ..Noise::default()
                },
            ),
        ];
        for (field, noise) in cases {
            let err = noise.validate().unwrap_err();
            assert!(err.contains(field), "{field}: {err}");
        }
    }
}
