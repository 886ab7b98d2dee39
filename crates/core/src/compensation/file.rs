//! The compensation file: a calibration's 24 parameters as the matrices
//! and vectors a navigation computer loads, in SI, with their σ, where they
//! came from and the convention that gives them meaning.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::convention::Convention;
use super::layout::{matrix, rows};
use super::thermal::ThermalTerms;
use crate::calib::CalibrationResult;
use crate::model::params::ParameterError;
use crate::model::{ErrorParameters, N_PARAMS, PARAMETERS};
use crate::thermal::ThermalModel;

/// The `format` tag every compensation file carries, by which a reader
/// tells it from a calibration result.
pub const FORMAT_TAG: &str = "sinscal-compensation";
/// The layout version this code writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// The model a file states when it was made from bare parameters.
const BASE_MODEL: &str = "base-24";

/// Errors reading a compensation file (or a result to make one from).
#[derive(Debug, thiserror::Error)]
pub enum CompensationError {
    #[error("not valid JSON: {0}")]
    Json(#[from] serde_json::Error),
    #[error("neither a compensation file (\"format\": \"{FORMAT_TAG}\") nor a calibration result")]
    UnknownDocument,
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Parameters(#[from] ParameterError),
}

/// Where the parameters came from. Every field but `model` may be absent:
/// a file made from a result on the command line knows no run id.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit_serial: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub run_id: Option<String>,
    /// The document the parameters were read from (a path, a URL).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// The error model of the calibration (`base-24`, `base-24+…`).
    pub model: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub records: Option<u64>,
    /// The result's model check: `false` means the 24 parameters did not
    /// explain the run, and compensating with them may not either.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_check_adequate: Option<bool>,
    /// Effect states the calibration estimated that this file does not
    /// apply (it holds the 24 base parameters only).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects_not_applied: Vec<String>,
    /// The acceptance verdict on the result when the file was made
    /// (`accepted`, `rejected`, `needs_review`; `unjudged` for a result
    /// never judged): a loader can refuse a file that is not `accepted`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<String>,
    /// Who took the file of a result that is not accepted, and why.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict_override: Option<VerdictOverride>,
}

/// An engineer's decision to release the compensation of a result the
/// acceptance did not accept.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VerdictOverride {
    /// The token (or signed-in session's token) that asked.
    pub by: String,
    pub reason: String,
}

/// One sensor triad's terms. Matrices are row = sensor, column = input
/// axis; `inverse_i_plus_k` is (I + K)⁻¹, given so a loader need not
/// invert, and checked against K on reading.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GyroTerms {
    pub bias_rad_per_s: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_sigma_rad_per_s: Option<[f64; 3]>,
    /// K_g: scale factors on the diagonal, misalignments (rad) above it,
    /// zeros below it by the definition of the body frame.
    pub scale_misalignment: [[f64; 3]; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_misalignment_sigma: Option<[[f64; 3]; 3]>,
    pub inverse_i_plus_k: [[f64; 3]; 3],
}

/// The accelerometer triad's terms (see [`GyroTerms`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AccelTerms {
    pub bias_m_per_s2: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_sigma_m_per_s2: Option<[f64; 3]>,
    /// K_a: scale factors on the diagonal, misalignments (rad) off it.
    pub scale_misalignment: [[f64; 3]; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_misalignment_sigma: Option<[[f64; 3]; 3]>,
    pub inverse_i_plus_k: [[f64; 3]; 3],
    /// diag(D_a), s²/m.
    pub quadratic_s2_per_m: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quadratic_sigma_s2_per_m: Option<[f64; 3]>,
}

/// A calibration as a navigation computer loads it (CONTRACT §5a).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompensationFile {
    pub format: String,
    pub format_version: u32,
    pub sinscal_version: String,
    pub provenance: Provenance,
    pub convention: Convention,
    pub gyro: GyroTerms,
    pub accel: AccelTerms,
    /// How the terms move with temperature, when a thermal model is known
    /// (the calibration's in-run states, or the unit's model across runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<ThermalTerms>,
}

fn inverse_rows(k: &Matrix3<f64>) -> [[f64; 3]; 3] {
    // I + K is within 1e-2 of I for any unit worth calibrating; a singular
    // one is refused by `validate` before a file is written or used.
    rows(
        &(Matrix3::identity() + k)
            .try_inverse()
            .unwrap_or_else(Matrix3::zeros),
    )
}

impl CompensationFile {
    /// A file for `params` (SI), with σ in SI (canonical order) when known.
    pub fn from_parameters(
        params: &ErrorParameters,
        sigma_si: Option<&[f64; N_PARAMS]>,
        provenance: Provenance,
    ) -> Self {
        // The σ vector laid out like the parameters, so the model's own
        // accessors place each σ where its value goes.
        let sig = sigma_si.map(|s| ErrorParameters { si: *s });
        let (k_g, k_a) = (params.k_g(), params.k_a());
        CompensationFile {
            format: FORMAT_TAG.into(),
            format_version: FORMAT_VERSION,
            sinscal_version: env!("CARGO_PKG_VERSION").into(),
            provenance,
            convention: Convention::current(),
            gyro: GyroTerms {
                bias_rad_per_s: params.b_g().into(),
                bias_sigma_rad_per_s: sig.map(|s| s.b_g().into()),
                scale_misalignment: rows(&k_g),
                scale_misalignment_sigma: sig.map(|s| rows(&s.k_g())),
                inverse_i_plus_k: inverse_rows(&k_g),
            },
            accel: AccelTerms {
                bias_m_per_s2: params.b_a().into(),
                bias_sigma_m_per_s2: sig.map(|s| s.b_a().into()),
                scale_misalignment: rows(&k_a),
                scale_misalignment_sigma: sig.map(|s| rows(&s.k_a())),
                inverse_i_plus_k: inverse_rows(&k_a),
                quadratic_s2_per_m: params.d_a().into(),
                quadratic_sigma_s2_per_m: sig.map(|s| s.d_a().into()),
            },
            thermal: None,
        }
    }

    /// A file for a calibration result: its 24 values and σ, converted from
    /// the canonical units to SI. `provenance` supplies what the result
    /// does not hold (serial, run id, source); the rest is filled from it.
    pub fn from_result(
        result: &CalibrationResult,
        provenance: Provenance,
    ) -> Result<Self, CompensationError> {
        let values = result
            .parameters
            .iter()
            .map(|(k, p)| (k.clone(), p.value))
            .collect();
        let params = ErrorParameters::from_canonical(&values)?;
        let mut sigma = [0.0; N_PARAMS];
        for (s, info) in sigma.iter_mut().zip(PARAMETERS.iter()) {
            // from_canonical has checked every name is present.
            *s = result.parameters[info.name].sigma * info.si_per_unit;
        }
        let provenance = Provenance {
            model: result.model.to_string(),
            estimator: Some(result.estimator.to_string()),
            records: Some(result.records),
            model_check_adequate: result.model_check.as_ref().map(|c| c.adequate),
            effects_not_applied: result.effects.keys().cloned().collect(),
            ..provenance
        };
        let mut file = Self::from_parameters(&params, Some(&sigma), provenance);
        file.thermal = result.thermal.as_ref().map(ThermalTerms::of_run);
        file.validate()?;
        Ok(file)
    }

    /// A file for a unit's thermal model across its runs: its values and
    /// σ at 25 °C, and its coefficients as the thermal terms.
    pub fn from_thermal_model(
        model: &ThermalModel,
        provenance: Provenance,
    ) -> Result<Self, CompensationError> {
        let (mut values, mut sigma) = (std::collections::BTreeMap::new(), [0.0; N_PARAMS]);
        for (s, info) in sigma.iter_mut().zip(PARAMETERS.iter()) {
            let p = model.parameters.get(info.name).ok_or_else(|| {
                CompensationError::Invalid(format!("the thermal model has no {}", info.name))
            })?;
            values.insert(info.name.to_string(), p.value);
            *s = p.sigma * info.si_per_unit;
        }
        let params = ErrorParameters::from_canonical(&values)?;
        let mut file = Self::from_parameters(&params, Some(&sigma), provenance);
        file.thermal = Some(ThermalTerms::of_unit(model));
        file.validate()?;
        Ok(file)
    }

    /// The parameters at `temperature_c`: the file's own without thermal
    /// terms.
    pub fn parameters_at(&self, temperature_c: f64) -> ErrorParameters {
        let p = self.parameters();
        match &self.thermal {
            Some(t) => t.parameters_at(&p, temperature_c),
            None => p,
        }
    }

    /// The 24 parameters the file holds, in SI.
    pub fn parameters(&self) -> ErrorParameters {
        ErrorParameters::from_parts(
            &Vector3::from(self.gyro.bias_rad_per_s),
            &matrix(&self.gyro.scale_misalignment),
            &Vector3::from(self.accel.bias_m_per_s2),
            &matrix(&self.accel.scale_misalignment),
            &Vector3::from(self.accel.quadratic_s2_per_m),
        )
    }

    /// Their 1-σ in SI (canonical order), when the file has them.
    pub fn sigma(&self) -> Option<[f64; N_PARAMS]> {
        let g = &self.gyro;
        let a = &self.accel;
        let s = ErrorParameters::from_parts(
            &Vector3::from(g.bias_sigma_rad_per_s?),
            &matrix(&g.scale_misalignment_sigma?),
            &Vector3::from(a.bias_sigma_m_per_s2?),
            &matrix(&a.scale_misalignment_sigma?),
            &Vector3::from(a.quadratic_sigma_s2_per_m?),
        );
        Some(s.si)
    }

    /// Checks what a loader relies on: the tag and version, finite values,
    /// K_g upper triangular, I + K invertible and the stated inverses
    /// agreeing with K.
    pub fn validate(&self) -> Result<(), CompensationError> {
        let invalid = |m: String| Err(CompensationError::Invalid(m));
        if self.format != FORMAT_TAG {
            return invalid(format!("format is {:?}, not {FORMAT_TAG:?}", self.format));
        }
        if self.format_version != FORMAT_VERSION {
            return invalid(format!(
                "format_version {} is not {FORMAT_VERSION}, the one this version reads",
                self.format_version
            ));
        }
        if let Some(t) = &self.thermal {
            t.validate().map_err(CompensationError::Invalid)?;
        }
        let params = self.parameters();
        if let Some(i) = params.si.iter().position(|v| !v.is_finite()) {
            return invalid(format!("{} is not finite", PARAMETERS[i].name));
        }
        let k_g = &self.gyro.scale_misalignment;
        if k_g[1][0] != 0.0 || k_g[2][0] != 0.0 || k_g[2][1] != 0.0 {
            return invalid(
                "gyro scale_misalignment must be upper triangular (the body frame is the gyros')"
                    .into(),
            );
        }
        for (what, k, inv) in [
            ("gyro", params.k_g(), &self.gyro.inverse_i_plus_k),
            ("accel", params.k_a(), &self.accel.inverse_i_plus_k),
        ] {
            // Far beyond any sensor: a file with such a matrix is corrupt.
            if k.abs().max() > 0.1 {
                return invalid(format!("{what} scale_misalignment has an entry beyond 0.1"));
            }
            let product = (Matrix3::identity() + k) * matrix(inv);
            if (product - Matrix3::identity()).abs().max() > 1e-12 {
                return invalid(format!(
                    "{what} inverse_i_plus_k is not the inverse of I + scale_misalignment"
                ));
            }
        }
        Ok(())
    }

    /// Pretty JSON, newline-terminated.
    pub fn to_json(&self) -> String {
        // Serializing plain numbers and strings cannot fail.
        let mut text = serde_json::to_string_pretty(self).unwrap_or_default();
        text.push('\n');
        text
    }

    /// Reads and validates a compensation file.
    pub fn from_json(text: &[u8]) -> Result<Self, CompensationError> {
        let file: CompensationFile = serde_json::from_slice(text)?;
        file.validate()?;
        Ok(file)
    }

    /// Reads either a compensation file or a calibration result (made
    /// into a file with `provenance`), told apart by the `format` tag.
    pub fn load(text: &[u8], provenance: Provenance) -> Result<Self, CompensationError> {
        let value: serde_json::Value = serde_json::from_slice(text)?;
        if value.get("format").and_then(|f| f.as_str()) == Some(FORMAT_TAG) {
            let file: CompensationFile = serde_json::from_value(value)?;
            file.validate()?;
            return Ok(file);
        }
        if value.get("parameters").is_some() && value.get("estimator").is_some() {
            let result: CalibrationResult = serde_json::from_value(value)?;
            return Self::from_result(&result, provenance);
        }
        Err(CompensationError::UnknownDocument)
    }

    /// A file for bare parameters with no σ (a simulator's truth).
    pub fn from_truth(params: &ErrorParameters) -> Self {
        let provenance = Provenance {
            model: BASE_MODEL.into(),
            source: Some("truth".into()),
            ..Provenance::default()
        };
        Self::from_parameters(params, None, provenance)
    }
}
