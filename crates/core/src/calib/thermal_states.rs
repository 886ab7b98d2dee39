//! What a calibration with in-run thermal states reports (SPEC §3a's
//! thermal model form): each parameter at 25 °C, the linear coefficients
//! the filter carried, the gyro bias against Ṫ, and the temperatures the
//! run covered. The 25 °C values are the result's `parameters`; they are
//! repeated here so that the object is a whole model a unit can load.

use std::collections::BTreeMap;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::estimation::effect_columns::EffectParameter;
use crate::model::{ErrorParameters, N_PARAMS, PARAMETERS};

/// A coefficient with its 1-σ.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Term {
    pub value: f64,
    pub sigma: f64,
}

/// One parameter of a run's thermal model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunThermalParameter {
    /// At 25 °C, canonical unit.
    pub value: f64,
    pub sigma: f64,
    pub unit: String,
    /// Per °C; present for the parameters the filter carried it for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear: Option<Term>,
    /// Covariance of (value, linear), row-major, canonical units: the two
    /// come from one run and are correlated (a run mostly above 25 °C
    /// reaches the 25 °C value through the coefficient).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub covariance: Vec<f64>,
}

/// A run's thermal model (SPEC §3a JSON).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunThermal {
    pub parameters: BTreeMap<String, RunThermalParameter>,
    /// k per gyro (`x`, `y`, `z`), deg/h per (°C/min).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub gyro_bias_rate: BTreeMap<String, Term>,
    /// The temperatures the run covered, °C.
    pub range_c: [f64; 2],
}

impl RunThermal {
    /// Parameter `name` at `temperature_c` with its σ, from the linear
    /// model and the covariance of its two terms.
    pub fn at(&self, name: &str, temperature_c: f64) -> Option<(f64, f64)> {
        let p = self.parameters.get(name)?;
        let d = temperature_c - crate::model::thermal::REFERENCE_C;
        Some(match (p.linear, p.covariance.as_slice()) {
            (Some(l), [vv, vl, _, ll]) => (
                p.value + l.value * d,
                (vv + 2.0 * vl * d + ll * d * d).max(0.0).sqrt(),
            ),
            (Some(l), _) => (
                p.value + l.value * d,
                (p.sigma.powi(2) + (l.sigma * d).powi(2)).sqrt(),
            ),
            (None, _) => (p.value, p.sigma),
        })
    }
}

/// The filter's answer with thermal states, in SPEC §3a form.
///
/// `params` are the 25 °C parameters; `effect_states` and
/// `effect_values` (SI) the model's effect states after the base 24, of
/// which the thermal ones are read; `covariance` the last pass's
/// parameter covariance (SI, base 24 then the effect states).
pub(crate) fn run_thermal(
    params: &ErrorParameters,
    effect_states: &[EffectParameter],
    effect_values: &[f64],
    covariance: &DMatrix<f64>,
    range_c: [f64; 2],
) -> RunThermal {
    let sd = |i: usize| covariance[(i, i)].max(0.0).sqrt();
    let mut parameters = BTreeMap::new();
    for (i, info) in PARAMETERS.iter().enumerate() {
        let u = info.si_per_unit;
        let mut p = RunThermalParameter {
            value: params.canonical(i),
            sigma: sd(i) / u,
            unit: info.unit.to_string(),
            linear: None,
            covariance: Vec::new(),
        };
        let linear_state = effect_states
            .iter()
            .position(|s| *s == EffectParameter::ThermalLinear(i));
        if let Some(j) = linear_state {
            let k = N_PARAMS + j;
            p.linear = Some(Term {
                value: effect_values[j] / u,
                sigma: sd(k) / u,
            });
            let u2 = u * u;
            p.covariance = vec![
                covariance[(i, i)] / u2,
                covariance[(i, k)] / u2,
                covariance[(k, i)] / u2,
                covariance[(k, k)] / u2,
            ];
        }
        parameters.insert(info.name.to_string(), p);
    }
    let mut gyro_bias_rate = BTreeMap::new();
    for (j, s) in effect_states.iter().enumerate() {
        if let EffectParameter::GyroBiasRate(axis) = *s {
            let u = s.si_per_unit();
            gyro_bias_rate.insert(
                ["x", "y", "z"][axis].to_string(),
                Term {
                    value: effect_values[j] / u,
                    sigma: sd(N_PARAMS + j) / u,
                },
            );
        }
    }
    RunThermal {
        parameters,
        gyro_bias_rate,
        range_c,
    }
}

/// Whether a state is one of the thermal ones, reported in the thermal
/// object rather than among the effects.
pub(crate) fn is_thermal(state: EffectParameter) -> bool {
    matches!(
        state,
        EffectParameter::ThermalLinear(_)
            | EffectParameter::ThermalQuadratic(_)
            | EffectParameter::GyroBiasRate(_)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_value_away_from_25_c_carries_the_covariance() {
        let states = vec![
            EffectParameter::ThermalLinear(0),
            EffectParameter::GyroBiasRate(2),
        ];
        let u = PARAMETERS[0].si_per_unit;
        let k_u = states[1].si_per_unit();
        let mut cov = DMatrix::zeros(N_PARAMS + 2, N_PARAMS + 2);
        for i in 0..N_PARAMS {
            cov[(i, i)] = 1e-30;
        }
        // σ(value) 0.002 deg/h, σ(linear) 1e-4 deg/h/°C, correlation −0.9.
        cov[(0, 0)] = (0.002 * u).powi(2);
        cov[(N_PARAMS, N_PARAMS)] = (1e-4 * u).powi(2);
        cov[(0, N_PARAMS)] = -0.9 * 0.002 * 1e-4 * u * u;
        cov[(N_PARAMS, 0)] = cov[(0, N_PARAMS)];
        cov[(N_PARAMS + 1, N_PARAMS + 1)] = (0.003 * k_u).powi(2);
        let params = ErrorParameters::paper();
        let m = run_thermal(
            &params,
            &states,
            &[5e-4 * u, 0.01 * k_u],
            &cov,
            [10.0, 50.0],
        );
        let b = &m.parameters["gyro_bias_x"];
        let l = b.linear.unwrap();
        assert!((l.value - 5e-4).abs() < 1e-15 && (l.sigma - 1e-4).abs() < 1e-15);
        assert!(m.parameters["gyro_scale_x"].linear.is_none());
        assert!((m.gyro_bias_rate["z"].value - 0.01).abs() < 1e-15);
        let (v, s) = m.at("gyro_bias_x", 45.0).unwrap();
        assert!((v - (b.value + 20.0 * 5e-4)).abs() < 1e-12);
        let expect =
            (0.002f64.powi(2) - 2.0 * 0.9 * 0.002 * 1e-4 * 20.0 + (1e-4 * 20.0f64).powi(2)).sqrt();
        assert!((s - expect).abs() < 1e-12, "{s} {expect}");
        let json = serde_json::to_string(&m).unwrap();
        let back: RunThermal = serde_json::from_str(&json).unwrap();
        assert_eq!(back.parameters.len(), N_PARAMS);
        assert_eq!(back.gyro_bias_rate, m.gyro_bias_rate);
        assert!(json.contains(r#""range_c":[10.0,50.0]"#), "{json}");
    }
}
