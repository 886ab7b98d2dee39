//! The result's tables and warnings, read off the last pass: each
//! parameter and effect state with its σ (those the run left near their
//! prior named poorly observable), the warnings a run earns, and the
//! in-run thermal result.

use std::collections::BTreeMap;

use super::effect_model::Effect;
use super::error::CalibError;
use super::kf_pass::Pass;
use super::result::{CrossCheck, ParameterEstimate};
use super::temperature::THERMAL_SPAN_C;
use super::thermal_states::RunThermal;
use super::thermal_states::{is_thermal, run_thermal};
use super::walk::PassContext;
use crate::estimation::effect_columns::EffectParameter;
use crate::estimation::priors::{prior_sigma, Priors};
use crate::model::{ErrorParameters, Grade, N_PARAMS, PARAMETERS};

/// A parameter is reported poorly observable when its σ after the run is
/// above this fraction of its prior: the run has not halved the prior's
/// uncertainty, so much of the estimate is the prior's.
const POORLY_OBSERVABLE: f64 = 0.5;

/// Fewer dwells than this are warned about: the seed paper's scheme, for
/// which the 24-parameter model was set up, has ten positions.
const MULTI_POSITION_DWELLS: usize = 10;

/// The warnings of a result, and the names of what the run hardly
/// observed, in the order they are found.
#[derive(Default)]
pub(super) struct Findings {
    pub warnings: Vec<String>,
    pub poorly_observable: Vec<String>,
}

impl Findings {
    /// Names `name` poorly observable when its σ is above
    /// `POORLY_OBSERVABLE` of its prior (both SI).
    fn observability(&mut self, name: &str, sigma_si: f64, prior_si: f64) {
        if sigma_si > POORLY_OBSERVABLE * prior_si {
            self.poorly_observable.push(name.to_string());
            self.warnings.push(format!(
                "{name} is poorly observable on this run's scheme: its σ is {:.0}% of the prior",
                100.0 * sigma_si / prior_si
            ));
        }
    }
}

/// The 24 parameters in canonical units with their σ.
pub(super) fn parameter_table(
    params: &ErrorParameters,
    last: &Pass,
    priors: Priors,
    findings: &mut Findings,
) -> BTreeMap<String, ParameterEstimate> {
    let prior = prior_sigma(priors);
    let mut table = BTreeMap::new();
    for (i, info) in PARAMETERS.iter().enumerate() {
        let sigma = last.sigma[i];
        findings.observability(info.name, sigma, prior[i]);
        table.insert(
            info.name.to_string(),
            ParameterEstimate {
                value: params.canonical(i),
                sigma: sigma / info.si_per_unit,
                unit: info.unit.to_string(),
            },
        );
    }
    table
}

/// The effect states in their own units with their σ; the thermal
/// states are checked for observability but reported in the result's
/// `thermal` instead.
pub(super) fn effect_table(
    states: &[EffectParameter],
    effects: &[f64],
    last: &Pass,
    grade: Grade,
    findings: &mut Findings,
) -> BTreeMap<String, ParameterEstimate> {
    let mut table = BTreeMap::new();
    for (j, state) in states.iter().enumerate() {
        let sigma = last.sigma[N_PARAMS + j];
        let prior_si = state.prior_sigma(grade) * state.si_per_unit();
        findings.observability(&state.name(), sigma, prior_si);
        if is_thermal(*state) {
            continue;
        }
        table.insert(
            state.name(),
            ParameterEstimate {
                value: effects[j] / state.si_per_unit(),
                sigma: sigma / state.si_per_unit(),
                unit: state.unit().to_string(),
            },
        );
    }
    table
}

/// A run whose temperature spans enough to move its parameters, calibrated
/// without thermal states.
pub(super) fn thermal_span_warning(ctx: &PassContext) -> Option<String> {
    let span = ctx.temperature.as_ref()?.span_c();
    (span >= THERMAL_SPAN_C && !ctx.opts.model.has(Effect::Thermal)).then(|| {
        format!(
            "the unit's temperature spanned {span:.1} °C during the run, and its parameters \
             move with it: calibrate with thermal states (`--thermal`, model {}) to estimate \
             their coefficients",
            ctx.opts.model.and(Effect::Thermal)
        )
    })
}

/// What the run itself earns: parameters the two estimators disagree on,
/// the gaps bridged, too few dwells.
pub(super) fn run_warnings(ctx: &PassContext, cross_check: Option<&CrossCheck>) -> Vec<String> {
    let scan = ctx.scan;
    // A single warning names every flagged parameter: on a unit with an
    // effect the model lacks they run to twenty (imu_tk's Xsens recording
    // under the base model), and twenty lines of one sentence would hide
    // the other warnings.
    let mut warnings: Vec<String> = cross_check
        .filter(|c| !c.flagged.is_empty())
        .map(|c| {
            format!(
                "the filter and the least-squares cross-check differ by more than 3 combined σ \
                 on {}: an effect the model lacks, or a motion the filter did not follow \
                 (`sinscal diagnose` names what is missing)",
                c.flagged.join(", ")
            )
        })
        .into_iter()
        .collect();
    warnings.extend(scan.gaps.iter().map(|g| g.warning(&scan.segments)));
    let n_dwells = scan.dwells().count();
    if n_dwells < MULTI_POSITION_DWELLS {
        warnings.push(format!(
            "only {n_dwells} dwells found; the base model needs a multi-position scheme"
        ));
    }
    warnings
}

/// The in-run thermal result, when the model carries thermal states and
/// the run has a temperature column.
pub(super) fn thermal_result(
    ctx: &PassContext,
    params: &ErrorParameters,
    states: &[EffectParameter],
    effects: &[f64],
    last: &Pass,
) -> Result<Option<RunThermal>, CalibError> {
    let curve = match (
        ctx.opts.model.has(Effect::Thermal),
        ctx.temperature.as_ref(),
    ) {
        (true, Some(curve)) => curve,
        _ => return Ok(None),
    };
    let covariance = last.covariance.as_ref().ok_or_else(|| {
        CalibError::Numerical("the thermal states' pass kept no covariance".into())
    })?;
    let t = curve.summary();
    Ok(Some(run_thermal(
        params,
        states,
        effects,
        covariance,
        [t.min_c, t.max_c],
    )))
}
