//! The compensation file's thermal terms (SPEC §3a, CONTRACT §5a): how the
//! 24 parameters move with the unit's temperature, in the file's own SI
//! layout, for a navigation computer that reads its temperature sensor.
//!
//! ```text
//! term(T) = term + linear ΔT + quadratic ΔT²,   ΔT = T − 25 °C
//! b_g(T, Ṫ) = b_g(T) + k Ṫ
//! ```

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::layout::{matrix, rows};
use crate::calib::thermal_states::RunThermal;
use crate::estimation::effect_columns::EffectParameter;
use crate::model::thermal::{ThermalTruth, REFERENCE_C};
use crate::model::{ErrorParameters, N_PARAMS, PARAMETERS};
use crate::thermal::ThermalModel;

/// Where a file's thermal terms come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ThermalSource {
    /// The calibration's own in-run thermal states (one run across
    /// temperature): linear terms and k.
    Run,
    /// A unit's thermal model fitted across its runs at several
    /// temperatures: linear terms and, where significant, quadratic ones.
    Unit,
}

/// One coefficient per parameter, laid out as the file lays out the
/// parameters (SI per °C, or per °C²).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TermSet {
    pub gyro_bias_rad_per_s: [f64; 3],
    pub gyro_scale_misalignment: [[f64; 3]; 3],
    pub accel_bias_m_per_s2: [f64; 3],
    pub accel_scale_misalignment: [[f64; 3]; 3],
    pub accel_quadratic_s2_per_m: [f64; 3],
}

impl TermSet {
    /// From coefficients in canonical order, SI.
    fn from_si(si: &[f64; N_PARAMS]) -> Self {
        let p = ErrorParameters { si: *si };
        TermSet {
            gyro_bias_rad_per_s: p.b_g().into(),
            gyro_scale_misalignment: rows(&p.k_g()),
            accel_bias_m_per_s2: p.b_a().into(),
            accel_scale_misalignment: rows(&p.k_a()),
            accel_quadratic_s2_per_m: p.d_a().into(),
        }
    }

    /// The coefficients in canonical order, SI.
    pub fn si(&self) -> [f64; N_PARAMS] {
        ErrorParameters::from_parts(
            &Vector3::from(self.gyro_bias_rad_per_s),
            &matrix(&self.gyro_scale_misalignment),
            &Vector3::from(self.accel_bias_m_per_s2),
            &matrix(&self.accel_scale_misalignment),
            &Vector3::from(self.accel_quadratic_s2_per_m),
        )
        .si
    }
}

/// How the file's terms move with temperature.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThermalTerms {
    pub source: ThermalSource,
    /// The temperature the file's terms are stated at, °C (25).
    pub reference_c: f64,
    /// The temperatures the model was found over, °C: beyond them it is
    /// extrapolation.
    pub range_c: [f64; 2],
    pub linear_per_c: TermSet,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quadratic_per_c2: Option<TermSet>,
    /// k: gyro bias per rate of change of temperature, (rad/s) per (°C/s).
    pub gyro_bias_rad_per_s_per_c_per_s: [f64; 3],
}

impl ThermalTerms {
    /// A run's in-run thermal states.
    pub fn of_run(t: &RunThermal) -> Self {
        let mut linear = [0.0; N_PARAMS];
        for (c, info) in linear.iter_mut().zip(PARAMETERS.iter()) {
            if let Some(l) = t.parameters.get(info.name).and_then(|p| p.linear) {
                *c = l.value * info.si_per_unit;
            }
        }
        let k_si = EffectParameter::GyroBiasRate(0).si_per_unit();
        let k = ["x", "y", "z"].map(|a| t.gyro_bias_rate.get(a).map_or(0.0, |k| k.value * k_si));
        ThermalTerms {
            source: ThermalSource::Run,
            reference_c: REFERENCE_C,
            range_c: t.range_c,
            linear_per_c: TermSet::from_si(&linear),
            quadratic_per_c2: None,
            gyro_bias_rad_per_s_per_c_per_s: k,
        }
    }

    /// A simulator's thermal truth (SPEC §3a), over `range_c`.
    pub fn of_truth(truth: &ThermalTruth, range_c: [f64; 2]) -> Self {
        let si = |c: fn(&ThermalTruth, usize) -> f64| {
            std::array::from_fn(|i| c(truth, i) * PARAMETERS[i].si_per_unit)
        };
        let quadratic: [f64; N_PARAMS] = si(ThermalTruth::quadratic);
        let k_si = EffectParameter::GyroBiasRate(0).si_per_unit();
        ThermalTerms {
            source: ThermalSource::Run,
            reference_c: REFERENCE_C,
            range_c,
            linear_per_c: TermSet::from_si(&si(ThermalTruth::linear)),
            quadratic_per_c2: quadratic
                .iter()
                .any(|q| *q != 0.0)
                .then(|| TermSet::from_si(&quadratic)),
            gyro_bias_rad_per_s_per_c_per_s: truth.gyro_bias_rate().map(|k| k * k_si),
        }
    }

    /// A unit's thermal model across runs (no k: soaked runs hold Ṫ at
    /// zero).
    pub fn of_unit(m: &ThermalModel) -> Self {
        let (mut linear, mut quadratic) = ([0.0; N_PARAMS], [0.0; N_PARAMS]);
        for (i, info) in PARAMETERS.iter().enumerate() {
            if let Some(p) = m.parameters.get(info.name) {
                linear[i] = p.linear.map_or(0.0, |t| t.value * info.si_per_unit);
                quadratic[i] = p.quadratic.map_or(0.0, |t| t.value * info.si_per_unit);
            }
        }
        ThermalTerms {
            source: ThermalSource::Unit,
            reference_c: REFERENCE_C,
            range_c: m.range_c,
            linear_per_c: TermSet::from_si(&linear),
            quadratic_per_c2: quadratic
                .iter()
                .any(|q| *q != 0.0)
                .then(|| TermSet::from_si(&quadratic)),
            gyro_bias_rad_per_s_per_c_per_s: [0.0; 3],
        }
    }

    /// The parameters at `temperature_c` from those at the reference.
    pub fn parameters_at(
        &self,
        at_reference: &ErrorParameters,
        temperature_c: f64,
    ) -> ErrorParameters {
        let d = temperature_c - self.reference_c;
        let linear = self.linear_per_c.si();
        let quadratic = self.quadratic_per_c2.as_ref().map(TermSet::si);
        let mut out = *at_reference;
        for (i, v) in out.si.iter_mut().enumerate() {
            *v += linear[i] * d + quadratic.map_or(0.0, |q| q[i] * d * d);
        }
        out
    }

    /// The gyro bias k Ṫ adds at `rate_c_per_s`, rad/s.
    pub fn gyro_bias_from_rate(&self, rate_c_per_s: f64) -> Vector3<f64> {
        Vector3::from(self.gyro_bias_rad_per_s_per_c_per_s) * rate_c_per_s
    }

    /// Every number finite, the range ordered.
    pub fn validate(&self) -> Result<(), String> {
        let finite = self.linear_per_c.si().iter().all(|v| v.is_finite())
            && self
                .quadratic_per_c2
                .as_ref()
                .map(|q| q.si().iter().all(|v| v.is_finite()))
                .unwrap_or(true)
            && self
                .gyro_bias_rad_per_s_per_c_per_s
                .iter()
                .all(|v| v.is_finite())
            && self.reference_c.is_finite()
            && self.range_c.iter().all(|v| v.is_finite());
        if !finite {
            return Err("thermal: every term must be finite".into());
        }
        if self.range_c[0] > self.range_c[1] {
            return Err("thermal.range_c must be [low, high]".into());
        }
        Ok(())
    }
}
