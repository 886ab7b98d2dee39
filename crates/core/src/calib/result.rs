//! What a calibration produces (SPEC §5 result, and more).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::effect_model::ErrorModel;
use super::gaps::GapReport;
use super::misfit::ModelCheck;
use super::segment::RunSegment;
use super::thermal_states::RunThermal;
use crate::estimation::NoiseModel;
use crate::model::units::{ARCSEC, DEG_PER_H, DEG_PER_RT_H, HOUR, UG, UG_PER_RT_HZ};
use crate::model::Grade;

/// One estimated parameter in its canonical unit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParameterEstimate {
    pub value: f64,
    /// The estimator's own 1-σ.
    pub sigma: f64,
    pub unit: String,
}

/// What produced a result's estimates, spelled in the result as SPEC §5
/// and earlier results have it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ResultEstimator {
    /// The systematic Kalman filter.
    #[default]
    #[serde(rename = "kf")]
    Kf,
    /// The velocity-error-rate least squares.
    #[serde(rename = "lsq")]
    Lsq,
    /// A diagnosis's refit: the filter's pass, then the velocity gap's
    /// least squares with the named effects as states.
    #[serde(rename = "kf, then gap least squares with effect states")]
    KfThenGapFit,
}

impl ResultEstimator {
    pub fn as_str(self) -> &'static str {
        match self {
            ResultEstimator::Kf => "kf",
            ResultEstimator::Lsq => "lsq",
            ResultEstimator::KfThenGapFit => "kf, then gap least squares with effect states",
        }
    }
}

impl std::fmt::Display for ResultEstimator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Estimates and σ over the run (final pass), decimated for plotting.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Convergence {
    /// Parameter names, the columns of `value` and `sigma`.
    pub names: Vec<String>,
    /// Times, s.
    pub t: Vec<f64>,
    /// value[i][j]: parameter j at time t[i], canonical units. Single
    /// precision (7 digits): the history is for plotting, the final
    /// values are in `parameters`, and it is most of a stored result.
    pub value: Vec<Vec<f32>>,
    pub sigma: Vec<Vec<f32>>,
}

/// The post-fit velocity residual of one dwell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DwellResidual {
    /// 1-based dwell number.
    pub dwell: usize,
    pub t_start: f64,
    pub t_end: f64,
    /// RMS of the zero-velocity innovations (E, N, U), m/s.
    pub rms_mps: [f64; 3],
    /// Velocity drift over the dwell left after the fit (E, N, U), m/s².
    pub drift_mps2: [f64; 3],
}

/// Attitude found by the alignment (start of the first dwell).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AlignmentReport {
    pub roll_deg: f64,
    pub pitch_deg: f64,
    pub heading_deg: f64,
    /// Seconds of data the alignment used.
    pub duration_s: f64,
}

/// One parameter compared between the two estimators.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CrossCheckEntry {
    pub name: String,
    pub kf: f64,
    pub lsq: f64,
    pub lsq_sigma: f64,
    /// |kf − lsq| / √(σ_kf² + σ_lsq²).
    pub normalized_difference: f64,
    pub flagged: bool,
}

/// The least-squares cross-check of a filter result.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CrossCheck {
    pub method: String,
    pub entries: Vec<CrossCheckEntry>,
    /// Names of parameters whose estimates differ by more than 3 combined σ.
    pub flagged: Vec<String>,
}

/// The unit's temperature over the run (SPEC §3a): what a thermal model
/// places the result at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunTemperature {
    pub mean_c: f64,
    pub min_c: f64,
    pub max_c: f64,
    /// Largest rate of change over the run, °C/min (0 for a soaked run).
    pub max_rate_c_per_min: f64,
}

impl RunTemperature {
    /// A run soaked at one temperature (metadata `temperature_c`).
    pub fn soaked(temperature_c: f64) -> Self {
        RunTemperature {
            mean_c: temperature_c,
            min_c: temperature_c,
            max_c: temperature_c,
            max_rate_c_per_min: 0.0,
        }
    }
}

/// A calibration result. `parameters` is SPEC §5's; the rest tells how far
/// to trust it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CalibrationResult {
    pub estimator: ResultEstimator,
    /// The error model: `base-24`, or `base-24+<effect>…` when effect
    /// states were added.
    pub model: ErrorModel,
    pub parameters: BTreeMap<String, ParameterEstimate>,
    /// Parameters of effects outside the base model, when modelled.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub effects: BTreeMap<String, ParameterEstimate>,
    pub warnings: Vec<String>,
    /// Parameters (and effect states) the run left poorly observable: σ
    /// above half the prior, so much of the estimate is the prior's. The
    /// same parameters are named in `warnings`; absent when none (and in
    /// results stored before the list existed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub poorly_observable: Vec<String>,
    /// The unit's grade the priors were sized for: given, or named by the
    /// run's gyro noise; absent in results stored before grades existed
    /// (all navigation units).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade: Option<Grade>,
    pub passes: u32,
    pub records: u64,
    pub duration_s: f64,
    pub alignment: AlignmentReport,
    /// Noise densities the filter used (measured from the dwells unless
    /// given): deg/√h and µg/√Hz.
    pub noise_arw_deg_rt_h: f64,
    pub noise_vrw_ug_rt_hz: f64,
    /// The whole noise model the filter assumed (SPEC §2a), per axis, and
    /// where it came from; absent in results stored before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_model: Option<CalibrationNoise>,
    pub segments: Vec<RunSegment>,
    /// Gaps in the time stamps (SPEC §2a: records lost), each bridged at
    /// rest and named in `warnings`; absent when none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gaps: Vec<GapReport>,
    pub dwell_residuals: Vec<DwellResidual>,
    pub convergence: Convergence,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cross_check: Option<CrossCheck>,
    /// Whether the model explains the run (SPEC §5), from the filter's
    /// last pass (one is made at the least squares' answer when it runs
    /// alone); absent only in results stored before the check existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_check: Option<ModelCheck>,
    /// The run's temperature, when its metadata or data state it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<RunTemperature>,
    /// With in-run thermal states (model `…+thermal`): the run's thermal
    /// model, SPEC §3a's form; `parameters` are then the values at 25 °C.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<RunThermal>,
    /// When the run's metadata declares a scheme: how many of its
    /// positions the calibration found at rest.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scheme_coverage: Option<SchemeCoverage>,
}

/// A run's dwells against the positions of the scheme it declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SchemeCoverage {
    pub dwells_found: usize,
    pub positions_declared: usize,
}

/// The noise model a calibration assumed, per body axis (x, y, z), in
/// SPEC §2 and §2a's units and names: what its σ and model check rest on.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NoiseModelReport {
    pub gyro_arw_deg_rt_h: [f64; 3],
    pub gyro_quantum_arcsec: [f64; 3],
    pub gyro_bias_instability_deg_h: [f64; 3],
    pub gyro_rrw_deg_h_rt_h: [f64; 3],
    pub accel_vrw_ug_rt_hz: [f64; 3],
    pub accel_quantum_mps: [f64; 3],
    pub accel_bias_instability_ug: [f64; 3],
    pub accel_rw_ug_rt_h: [f64; 3],
}

/// Where a calibration's noise model came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseSource {
    /// Stated by the caller (`--noise` options).
    Given,
    /// Read from the run's dwells (Allan curves, pulse quanta): white
    /// noise, no §2a term seen.
    Measured,
    /// Started from the dwells' reading and fitted to the run's own
    /// zero-velocity innovations (maximum likelihood).
    Fitted,
}

/// The noise model a calibration assumed: its σ and its model check rest
/// on it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationNoise {
    pub source: NoiseSource,
    #[serde(flatten)]
    pub model: NoiseModelReport,
    /// Likelihood evaluations the fit spent (with `fitted`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_evaluations: Option<usize>,
    /// With `fitted` and a model held for the unit
    /// (`EstimateOptions::noise_reference`): whether this run's noise is
    /// still that model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<NoiseReferenceTest>,
    /// Wander the run's innovations asked for that its dwells did not
    /// show (a white model's screen, CONTRACT §2a).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unseen_wander: Option<UnseenWanderReport>,
}

/// The wander term a white model's run asked for most, and what was done.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UnseenWanderReport {
    /// The term as the result names it, e.g. "accelerometer bias random
    /// walk".
    pub term: String,
    /// Its size where the screen found it, in `unit`.
    pub size: f64,
    pub unit: String,
    /// The rise of ln L over the white model.
    pub gain_ln_l: f64,
    /// The noise model was then fitted, as asked
    /// (`EstimateOptions::fit_unseen_wander`); false: the white one stands.
    pub fitted: bool,
}

/// A likelihood-ratio test of the noise model held for a unit (its
/// characterisation) against the model fitted to one of its runs, over the
/// same pass.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseReferenceTest {
    /// 2 (ln L of the likeliest model the fit found, every term free −
    /// ln L of the held one), the likelihood the fit maximises (the
    /// parameters held at the pass's estimate).
    pub statistic: f64,
    /// The same with the parameters integrated out instead of held: not
    /// what the fit maximised, so it may be negative (the held model the
    /// likelier); a large value here as well rules out that holding the
    /// parameters at their estimate is what favours the fit.
    pub marginal_statistic: f64,
    /// The fit's free terms, the statistic's χ² degrees of freedom.
    pub degrees_of_freedom: usize,
    /// The χ² law's 99 % point.
    pub threshold: f64,
    /// The statistic is within the threshold: the run cannot tell its
    /// noise from the held model.
    pub consistent: bool,
}

impl CalibrationResult {
    /// The 24 parameters as a text table in canonical order, with warnings
    /// and the cross-check's flags.
    pub fn table(&self) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:<20} {:>14} {:>12}  unit        ({} estimator, {}, {} passes{})",
            "parameter",
            "value",
            "1-sigma",
            self.estimator,
            self.model,
            self.passes,
            self.grade.map_or(String::new(), |g| format!(", {g} grade"))
        );
        for info in crate::model::PARAMETERS.iter() {
            if let Some(p) = self.parameters.get(info.name) {
                let flag = self
                    .cross_check
                    .as_ref()
                    .is_some_and(|c| c.flagged.iter().any(|f| f == info.name));
                let _ = writeln!(
                    out,
                    "{:<20} {:>14.5} {:>12.5}  {:<10}{}",
                    info.name,
                    p.value,
                    p.sigma,
                    p.unit,
                    if flag { "  cross-check differs" } else { "" }
                );
            }
        }
        for (name, p) in &self.effects {
            let _ = writeln!(
                out,
                "{:<20} {:>14.5} {:>12.5}  {}",
                name, p.value, p.sigma, p.unit
            );
        }
        if let Some(t) = &self.thermal {
            let _ = writeln!(
                out,
                "thermal coefficients over {:.1}–{:.1} °C (per °C; k per °C/min):",
                t.range_c[0], t.range_c[1]
            );
            for info in crate::model::PARAMETERS.iter() {
                if let Some(l) = t.parameters.get(info.name).and_then(|p| p.linear) {
                    let _ = writeln!(
                        out,
                        "{:<20} {:>14.6} {:>12.6}  {}/degC",
                        info.name, l.value, l.sigma, info.unit
                    );
                }
            }
            for (axis, k) in &t.gyro_bias_rate {
                let _ = writeln!(
                    out,
                    "{:<20} {:>14.6} {:>12.6}  deg/h/(degC/min)",
                    format!("gyro_bias_rate_{axis}"),
                    k.value,
                    k.sigma
                );
            }
        }
        for w in &self.warnings {
            let _ = writeln!(out, "warning: {w}");
        }
        if let Some(check) = &self.model_check {
            let _ = writeln!(out, "model check: {}", check.summary);
        }
        out
    }

    /// Value of a parameter by canonical name.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.parameters.get(name).map(|p| p.value)
    }

    pub fn sigma(&self, name: &str) -> Option<f64> {
        self.parameters.get(name).map(|p| p.sigma)
    }
}

/// The result's account of the noise model (the toolkit's type knows no
/// result).
impl NoiseModel {
    /// The model in canonical units, per axis, for the result.
    pub fn report(&self) -> NoiseModelReport {
        let rt_h = HOUR.sqrt();
        let per = |v: [f64; 3], unit: f64| v.map(|x| x / unit);
        NoiseModelReport {
            gyro_arw_deg_rt_h: per(self.gyro.white, DEG_PER_RT_H),
            gyro_quantum_arcsec: per(self.gyro.quantum, ARCSEC),
            gyro_bias_instability_deg_h: per(self.gyro.instability, DEG_PER_H),
            gyro_rrw_deg_h_rt_h: per(self.gyro.random_walk, DEG_PER_H / rt_h),
            accel_vrw_ug_rt_hz: per(self.accel.white, UG_PER_RT_HZ),
            accel_quantum_mps: self.accel.quantum,
            accel_bias_instability_ug: per(self.accel.instability, UG),
            accel_rw_ug_rt_h: per(self.accel.random_walk, UG / rt_h),
        }
    }
}
