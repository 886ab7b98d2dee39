//! A unit's thermal model from runs soaked at several temperatures (SPEC
//! §3a): per parameter its value at 25 °C, the linear coefficient, and the
//! quadratic one where the runs show it; a check that the runs fit a
//! smooth model; prediction with σ inside the fitted range.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::fit::{fit_polynomial, PolyFit, Sample};
use super::ThermalError;
use crate::calib::ParameterEstimate;
use crate::estimation::quantile::{chi2_upper, normal_upper};
use crate::model::{ParameterInfo, PARAMETERS};

/// The reference temperature of SPEC §3a: p is the value at 25 °C.
pub const REFERENCE_C: f64 = 25.0;

/// Chance, per model, that some parameter gets a quadratic term the unit
/// does not have. Each parameter's test takes its share (both tails), so
/// over 24 parameters a false quadratic term is rare, while a real one of
/// a few σ of its estimate is kept.
pub const FALSE_QUADRATIC_RATE: f64 = 0.01;

/// Chance that a model of runs that do fit it is called inadequate.
pub const FALSE_ALARM_RATE: f64 = 0.001;

/// Temperatures closer than this are one temperature for the fit.
const SAME_TEMPERATURE_C: f64 = 0.5;

/// One calibrated run and the temperature it was soaked at.
#[derive(Clone, Debug)]
pub struct SoakedRun {
    /// What names the run in the model's check (a file, a run id).
    pub label: String,
    pub temperature_c: f64,
    pub parameters: BTreeMap<String, ParameterEstimate>,
}

/// A coefficient with its 1-σ (the in-run thermal result's, one form for
/// both models).
pub use crate::calib::thermal_states::Term;

/// One parameter's model (SPEC §3a's form, and what prediction needs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThermalParameter {
    /// At 25 °C.
    pub value: f64,
    pub sigma: f64,
    pub unit: String,
    /// Per °C.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear: Option<Term>,
    /// Per °C²; present only where the runs show it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quadratic: Option<Term>,
    /// Covariance of (value, linear[, quadratic]), row-major: prediction
    /// away from 25 °C needs their correlation, not only their σ.
    pub covariance: Vec<f64>,
    /// Σ (residual/σ)² of the runs about the fit, and its degrees of
    /// freedom.
    pub chi2: f64,
    pub dof: usize,
}

impl ThermalParameter {
    fn fit(&self) -> PolyFit {
        let mut coefficients = vec![self.value];
        coefficients.extend(self.linear.map(|t| t.value));
        coefficients.extend(self.quadratic.map(|t| t.value));
        PolyFit {
            coefficients,
            covariance: self.covariance.clone(),
            chi2: self.chi2,
            dof: self.dof,
            standardized: Vec::new(),
        }
    }
}

/// A run's estimate of a parameter far from the fitted curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outlier {
    pub run: String,
    pub temperature_c: f64,
    pub parameter: String,
    /// Residual over its σ (leverage accounted for).
    pub z: f64,
}

/// Whether the runs fit a smooth model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThermalCheck {
    pub adequate: bool,
    /// Σ χ² over the parameters, its degrees of freedom and its bound at
    /// [`FALSE_ALARM_RATE`].
    pub chi2: f64,
    pub dof: usize,
    pub threshold: f64,
    /// Bound on one run's |z| (Bonferroni over runs and parameters).
    pub z_threshold: f64,
    /// Every run and parameter beyond it, largest first.
    pub outliers: Vec<Outlier>,
    pub summary: String,
}

/// A run the model was fitted from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FittedRun {
    pub label: String,
    pub temperature_c: f64,
}

/// A unit's thermal model (SPEC §3a JSON, with the fit's check).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThermalModel {
    pub parameters: BTreeMap<String, ThermalParameter>,
    /// The temperatures fitted over, °C: prediction outside is
    /// extrapolation.
    pub range_c: [f64; 2],
    pub runs: Vec<FittedRun>,
    pub check: ThermalCheck,
}

/// A parameter's value at a temperature.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Prediction {
    pub value: f64,
    pub sigma: f64,
    /// Outside the fitted range (asked for explicitly).
    pub extrapolated: bool,
}

/// The z beyond which a quadratic coefficient is kept.
pub fn quadratic_z() -> f64 {
    normal_upper(FALSE_QUADRATIC_RATE / (2.0 * PARAMETERS.len() as f64))
}

/// Fits every parameter the runs share: the value at 25 °C and a linear
/// coefficient, plus a quadratic one where it is significant (three or
/// more temperatures, |p2| beyond [`quadratic_z`] of its σ).
pub fn fit_thermal_model(runs: &[SoakedRun]) -> Result<ThermalModel, ThermalError> {
    let temperatures = distinct_temperatures(runs)?;
    let range_c = [temperatures[0], temperatures[temperatures.len() - 1]];
    let z_threshold =
        normal_upper(FALSE_ALARM_RATE / (2.0 * (runs.len() * PARAMETERS.len()).max(1) as f64));
    let mut parameters = BTreeMap::new();
    let mut outliers = Vec::new();
    for p in PARAMETERS.iter() {
        if let Some(fit) = fit_parameter(p, runs, temperatures.len(), z_threshold, &mut outliers)? {
            parameters.insert(p.name.to_string(), fit);
        }
    }
    if parameters.is_empty() {
        return Err(ThermalError::Input(
            "the runs share no parameter of SPEC §2".into(),
        ));
    }
    Ok(ThermalModel {
        check: thermal_check(&parameters, outliers, z_threshold),
        parameters,
        range_c,
        runs: runs
            .iter()
            .map(|r| FittedRun {
                label: r.label.clone(),
                temperature_c: r.temperature_c,
            })
            .collect(),
    })
}

/// The runs' temperatures, sorted, those within `SAME_TEMPERATURE_C` of
/// each other counted once; at least two are needed.
fn distinct_temperatures(runs: &[SoakedRun]) -> Result<Vec<f64>, ThermalError> {
    let mut temperatures: Vec<f64> = runs.iter().map(|r| r.temperature_c).collect();
    if let Some(bad) = temperatures.iter().find(|t| !t.is_finite()) {
        return Err(ThermalError::Input(format!("a run's temperature is {bad}")));
    }
    temperatures.sort_by(f64::total_cmp);
    temperatures.dedup_by(|a, b| (*a - *b).abs() < SAME_TEMPERATURE_C);
    if temperatures.len() < 2 {
        return Err(ThermalError::Input(format!(
            "the {} runs span one temperature; a thermal model needs runs at two or more",
            runs.len()
        )));
    }
    Ok(temperatures)
}

/// One parameter's polynomial in ΔT (`None` when a run lacks it): linear,
/// quadratic where three or more temperatures make the square
/// significant. Runs beyond `z_threshold` of the fit go to `outliers`.
fn fit_parameter(
    p: &ParameterInfo,
    runs: &[SoakedRun],
    n_temperatures: usize,
    z_threshold: f64,
    outliers: &mut Vec<Outlier>,
) -> Result<Option<ThermalParameter>, ThermalError> {
    let samples: Vec<Sample> = runs
        .iter()
        .filter_map(|r| {
            r.parameters.get(p.name).map(|e| Sample {
                delta_t_c: r.temperature_c - REFERENCE_C,
                value: e.value,
                sigma: e.sigma,
            })
        })
        .collect();
    if samples.len() < runs.len() {
        return Ok(None);
    }
    let linear = fit_polynomial(&samples, 1).ok_or_else(|| {
        ThermalError::Input(format!("{}: the runs do not determine a slope", p.name))
    })?;
    let quadratic = (n_temperatures >= 3)
        .then(|| fit_polynomial(&samples, 2))
        .flatten()
        .filter(|q| (q.coefficients[2] / q.sigma(2)).abs() > quadratic_z());
    let fit = quadratic.unwrap_or(linear);
    for (r, z) in runs.iter().zip(&fit.standardized) {
        if z.abs() > z_threshold {
            outliers.push(Outlier {
                run: r.label.clone(),
                temperature_c: r.temperature_c,
                parameter: p.name.to_string(),
                z: *z,
            });
        }
    }
    let term = |k: usize| Term {
        value: fit.coefficients[k],
        sigma: fit.sigma(k),
    };
    Ok(Some(ThermalParameter {
        value: fit.coefficients[0],
        sigma: fit.sigma(0),
        unit: p.unit.to_string(),
        linear: Some(term(1)),
        quadratic: (fit.order() == 2).then(|| term(2)),
        covariance: fit.covariance.clone(),
        chi2: fit.chi2,
        dof: fit.dof,
    }))
}

/// Whether the runs fit the model: the pooled χ² against its bound, and
/// no run beyond `z_threshold` on any parameter (worst first).
fn thermal_check(
    parameters: &BTreeMap<String, ThermalParameter>,
    mut outliers: Vec<Outlier>,
    z_threshold: f64,
) -> ThermalCheck {
    // Summed in SPEC §2's order, as the parameters were fitted.
    let (chi2, dof) = PARAMETERS
        .iter()
        .filter_map(|p| parameters.get(p.name))
        .fold((0.0, 0), |(chi2, dof), p| (chi2 + p.chi2, dof + p.dof));
    outliers.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
    let threshold = if dof > 0 {
        chi2_upper(dof as f64, FALSE_ALARM_RATE)
    } else {
        f64::INFINITY
    };
    let adequate = chi2 <= threshold && outliers.is_empty();
    let summary = if adequate {
        format!(
            "adequate: the runs fit a smooth model (χ² {chi2:.0} over {dof}, bound {threshold:.0})"
        )
    } else if let Some(o) = outliers.first() {
        format!(
            "inadequate: run {} at {:.1} °C leaves the model on {} (z = {:.1}, bound {z_threshold:.1}){}",
            o.run,
            o.temperature_c,
            o.parameter,
            o.z,
            if outliers.len() > 1 {
                format!(", and {} more", outliers.len() - 1)
            } else {
                String::new()
            }
        )
    } else {
        format!(
            "inadequate: the runs scatter beyond their σ about a smooth model (χ² {chi2:.0} over {dof}, bound {threshold:.0})"
        )
    };
    ThermalCheck {
        adequate,
        chi2,
        dof,
        threshold,
        z_threshold,
        outliers,
        summary,
    }
}

impl ThermalModel {
    /// A parameter at `temperature_c`, with σ. Outside the fitted range
    /// only when `extrapolate` says so, and then marked.
    pub fn predict(
        &self,
        name: &str,
        temperature_c: f64,
        extrapolate: bool,
    ) -> Result<Prediction, ThermalError> {
        let p = self
            .parameters
            .get(name)
            .ok_or_else(|| ThermalError::Input(format!("the model has no parameter {name:?}")))?;
        let outside = !(self.range_c[0]..=self.range_c[1]).contains(&temperature_c);
        if outside && !extrapolate {
            return Err(ThermalError::OutOfRange {
                temperature_c,
                range_c: self.range_c,
            });
        }
        let (value, sigma) = p.fit().at(temperature_c - REFERENCE_C);
        Ok(Prediction {
            value,
            sigma,
            extrapolated: outside,
        })
    }
}
