//! Effects outside the 24-parameter model (SPEC §3), in their JSON form
//! (canonical units) with SI accessors.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::units::{DEG_PER_H, DEG_PER_H_PER_G, HOUR, PPM, UG};

/// Lever arms of the three accelerometers from the reference point, mm,
/// in body axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeverArms {
    pub x: [f64; 3],
    pub y: [f64; 3],
    pub z: [f64; 3],
}

impl LeverArms {
    /// r_i in metres: row i is accelerometer i's position.
    pub fn r_b(&self) -> [Vector3<f64>; 3] {
        [self.x, self.y, self.z].map(|r| Vector3::from(r) * 1e-3)
    }
}

/// Linear bias drift: deg/h per hour for the gyros, µg per hour for the
/// accelerometers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BiasDrift {
    #[serde(default)]
    pub gyro: [f64; 3],
    #[serde(default)]
    pub accel: [f64; 3],
}

impl BiasDrift {
    /// ḃ_g in rad/s².
    pub fn gyro_si(&self) -> Vector3<f64> {
        Vector3::from(self.gyro) * (DEG_PER_H / HOUR)
    }

    /// ḃ_a in m/s³.
    pub fn accel_si(&self) -> Vector3<f64> {
        Vector3::from(self.accel) * (UG / HOUR)
    }
}

/// The effects a run may carry beyond the base model. Each is absent by
/// default.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_lever_arm: Option<LeverArms>,
    /// G, deg/h/g, row-major.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro_g_sensitivity: Option<[f64; 9]>,
    /// τ, ms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_delay: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_drift: Option<BiasDrift>,
    /// A_g, ppm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro_scale_asymmetry: Option<[f64; 3]>,
}

impl Effects {
    pub fn none() -> Self {
        Self::default()
    }

    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// G in (rad/s)/(m/s²).
    pub fn gyro_g_sensitivity_si(&self) -> Option<Matrix3<f64>> {
        self.gyro_g_sensitivity
            .map(|g| Matrix3::from_row_slice(&g) * DEG_PER_H_PER_G)
    }

    /// τ in seconds (0 when absent).
    pub fn accel_delay_s(&self) -> f64 {
        self.accel_delay.unwrap_or(0.0) * 1e-3
    }

    /// A_g, dimensionless.
    pub fn gyro_scale_asymmetry_si(&self) -> Option<Vector3<f64>> {
        self.gyro_scale_asymmetry.map(|a| Vector3::from(a) * PPM)
    }

    /// Names of the effects present (SPEC §3 names).
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.accel_lever_arm.is_some() {
            v.push("accel_lever_arm");
        }
        if self.gyro_g_sensitivity.is_some() {
            v.push("gyro_g_sensitivity");
        }
        if self.accel_delay.is_some() {
            v.push("accel_delay");
        }
        if self.bias_drift.is_some() {
            v.push("bias_drift");
        }
        if self.gyro_scale_asymmetry.is_some() {
            v.push("gyro_scale_asymmetry");
        }
        v
    }

    /// Checks every value is finite and the delay is non-negative.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |name: &str, vals: &[f64]| {
            if vals.iter().all(|v| v.is_finite()) {
                Ok(())
            } else {
                Err(format!("effect {name} has a non-finite value"))
            }
        };
        if let Some(l) = &self.accel_lever_arm {
            finite("accel_lever_arm", &[l.x, l.y, l.z].concat())?;
        }
        if let Some(g) = &self.gyro_g_sensitivity {
            finite("gyro_g_sensitivity", g)?;
        }
        if let Some(d) = self.accel_delay {
            finite("accel_delay", &[d])?;
            if d < 0.0 {
                return Err(format!("accel_delay {d} ms is negative"));
            }
        }
        if let Some(b) = &self.bias_drift {
            finite("bias_drift", &[b.gyro, b.accel].concat())?;
        }
        if let Some(a) = &self.gyro_scale_asymmetry {
            finite("gyro_scale_asymmetry", a)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_form_of_spec_section_3() {
        let e: Effects = serde_json::from_str(
            r#"{"accel_lever_arm": {"x": [50, 0, 0], "y": [0, 30, 0], "z": [0, 0, 0]},
                "gyro_g_sensitivity": [0.01, 0, 0, 0, 0, 0, 0, 0, 0],
                "accel_delay": 1.5,
                "bias_drift": {"gyro": [0.01, 0, 0], "accel": [10, 0, 0]},
                "gyro_scale_asymmetry": [50, 0, 0]}"#,
        )
        .unwrap();
        assert_eq!(e.names().len(), 5);
        assert_eq!(e.accel_lever_arm.unwrap().r_b()[0].x, 0.05);
        assert!((e.accel_delay_s() - 1.5e-3).abs() < 1e-18);
        let g = e.gyro_g_sensitivity_si().unwrap();
        assert!((g[(0, 0)] / (0.01 * DEG_PER_H / crate::nav::earth::G0) - 1.0).abs() < 1e-14);
        assert!(serde_json::from_str::<Effects>(r#"{"accel_delya": 1}"#).is_err());
    }
}
