//! `GET /units/{serial}/thermal`: the unit's thermal model (SPEC §3a) from
//! its calibrated runs that state a temperature, chosen by a filter. It is
//! fitted on each request from the stored results (24 small fits), so it
//! always includes the latest run to land. `…/thermal/compensation` is
//! the model as a compensation file (CONTRACT §5a): its 25 °C values and
//! its coefficients as the file's thermal terms.

use std::collections::BTreeMap;

use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::response::Response;
use axum::routing::get;
use axum::{Json, Router};
use serde::Deserialize;

use super::auth::{roles, Caller};
use super::compensation::{file_response, FileForm};
use super::error::ApiError;
use super::{parse_time, AppState};
use sinscal_core::accept::VerdictStatus;
use sinscal_core::calib::ParameterEstimate;
use sinscal_core::compensation::{CompensationFile, Provenance};
use sinscal_core::io::UnitSerial;
use sinscal_core::thermal::{fit_thermal_model, SoakedRun, ThermalModel};

/// Runs spanning more than this are ramps, not soaks, unless asked for.
pub const DEFAULT_MAX_SPAN_C: f64 = 2.0;

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/units/{serial}/thermal", get(get_thermal))
        .route(
            "/units/{serial}/thermal/compensation",
            get(get_thermal_compensation),
        )
}

/// Which of the unit's runs the model is fitted from.
#[derive(Debug, Default, Deserialize)]
pub struct ThermalQuery {
    pub from: Option<String>,
    pub to: Option<String>,
    /// Only results with this verdict.
    pub verdict: Option<VerdictStatus>,
    /// Largest temperature span of a run used, °C.
    pub max_span_c: Option<f64>,
}

async fn get_thermal(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<ThermalQuery>, QueryRejection>,
) -> Result<Json<ThermalModel>, ApiError> {
    let serial: UnitSerial = path?.0.parse().map_err(ApiError::BadRequest)?;
    let Query(q) = query?;
    Ok(Json(unit_thermal_model(&st, &serial, &q).await?.0))
}

/// The runs' filter of [`ThermalQuery`] and the file's form.
#[derive(Debug, Default, Deserialize)]
struct ThermalCompensationQuery {
    from: Option<String>,
    to: Option<String>,
    verdict: Option<VerdictStatus>,
    max_span_c: Option<f64>,
    #[serde(default)]
    format: FileForm,
}

async fn get_thermal_compensation(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<ThermalCompensationQuery>, QueryRejection>,
) -> Result<Response, ApiError> {
    let serial: UnitSerial = path?.0.parse().map_err(ApiError::BadRequest)?;
    let Query(q) = query?;
    let filter = ThermalQuery {
        from: q.from,
        to: q.to,
        verdict: q.verdict,
        max_span_c: q.max_span_c,
    };
    let (model, runs) = unit_thermal_model(&st, &serial, &filter).await?;
    let provenance = Provenance {
        unit_serial: Some(serial.to_string()),
        source: Some(format!(
            "/api/v1/units/{serial}/thermal: {} runs at {}–{} °C",
            runs.len(),
            model.range_c[0],
            model.range_c[1]
        )),
        model: "base-24".into(),
        model_check_adequate: Some(model.check.adequate),
        ..Provenance::default()
    };
    let file = CompensationFile::from_thermal_model(&model, provenance)
        .map_err(|e| ApiError::Internal(format!("unit {serial}'s thermal model: {e}")))?;
    Ok(file_response(&file, q.format))
}

/// The unit's thermal model and the runs it was fitted from (the API's
/// answer and the unit page's): 404 for an unknown unit, 409 while its
/// runs do not span two temperatures.
pub(crate) async fn unit_thermal_model(
    st: &AppState,
    serial: &UnitSerial,
    q: &ThermalQuery,
) -> Result<(ThermalModel, Vec<SoakedRun>), ApiError> {
    let from = q
        .from
        .as_deref()
        .map(|t| parse_time(t, "from"))
        .transpose()?;
    let to = q.to.as_deref().map(|t| parse_time(t, "to")).transpose()?;
    let max_span_c = q.max_span_c.unwrap_or(DEFAULT_MAX_SPAN_C);
    if !(0.0..=1000.0).contains(&max_span_c) {
        return Err(ApiError::BadRequest(format!(
            "max_span_c must be 0 to 1000 °C, got {max_span_c}"
        )));
    }
    if st.store.get_unit(serial).await?.is_none() {
        return Err(ApiError::NotFound(format!("no unit {serial}")));
    }
    let rows = st
        .store
        .thermal_rows(
            serial,
            (from.unwrap_or(i64::MIN), to.unwrap_or(i64::MAX)),
            q.verdict,
            max_span_c,
        )
        .await?;
    let runs = rows
        .into_iter()
        .map(|r| {
            let parameters: BTreeMap<String, ParameterEstimate> =
                serde_json::from_str(&r.parameters)
                    .map_err(|e| ApiError::Internal(format!("stored result {}: {e}", r.run_id)))?;
            Ok(SoakedRun {
                label: r.run_id.to_string(),
                temperature_c: r.temperature_c,
                parameters,
            })
        })
        .collect::<Result<Vec<_>, ApiError>>()?;
    let model = fit_thermal_model(&runs).map_err(|e| {
        ApiError::Conflict(format!(
            "unit {serial} has no thermal model from {} runs with a temperature: {e}",
            runs.len()
        ))
    })?;
    Ok((model, runs))
}
