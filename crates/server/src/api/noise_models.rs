//! The noise model held for a unit (engineers read and write it): its
//! characterisation, stated once, which each later calibration or
//! diagnosis job of the unit's runs carries, as the run's noise model
//! (`given`: σ as a covariance analysis of that noise gives them) or as the
//! reference its own fitted model is tested against (`reference`). A change
//! reaches the next job; results already stored keep the model they state.

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::routing::get;
use axum::{Json, Router};
use serde::{Deserialize, Serialize};

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::json_object::JsonObject;
use super::units::serial_of;
use super::{rfc3339, AppState};
use crate::store::HeldNoiseRow;
use sinscal_core::calib::{parse_noise_terms, HeldNoise, HeldNoiseUse, NoiseDensity};
use sinscal_core::io::UnitSerial;

pub fn router() -> Router<AppState> {
    Router::new().route(
        "/units/{serial}/noise-model",
        get(get_held).put(put_held).delete(delete_held),
    )
}

/// A held model as a body states it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeldNoiseBody {
    /// The terms, by the truth file's `noise` names (checked by
    /// `parse_noise_terms`, which names the term at fault).
    noise: serde_json::Value,
    used_as: HeldNoiseUse,
}

#[derive(Debug, Serialize)]
pub struct HeldNoiseView {
    pub unit_serial: String,
    /// Terms absent here are zero.
    pub noise: NoiseDensity,
    pub used_as: HeldNoiseUse,
    /// The token that set it.
    pub set_by: String,
    pub set_at: String,
}

impl TryFrom<HeldNoiseRow> for HeldNoiseView {
    type Error = ApiError;

    fn try_from(row: HeldNoiseRow) -> Result<Self, ApiError> {
        let held = row.parsed()?;
        Ok(HeldNoiseView {
            unit_serial: row.unit_serial,
            noise: held.noise,
            used_as: held.used_as,
            set_by: row.set_by,
            set_at: rfc3339(row.set_at),
        })
    }
}

/// Holds `noise` (a body's or a form's terms, checked here; a refusal is
/// a 422 naming `noise.<term>`) for the unit as `used_as`, set by the
/// token `by`: the API's PUT and the unit page's form.
pub(crate) async fn hold_for_unit(
    st: &AppState,
    serial: &UnitSerial,
    (noise, used_as): (&serde_json::Value, HeldNoiseUse),
    by: &str,
) -> Result<HeldNoiseRow, ApiError> {
    let noise = parse_noise_terms(noise).map_err(|e| ApiError::InvalidField {
        field: e
            .term()
            .map_or_else(|| "noise".to_string(), |t| format!("noise.{t}")),
        message: e.to_string(),
    })?;
    let held = HeldNoise { noise, used_as };
    Ok(st.store.hold_noise_model(serial, &held, by).await?)
}

async fn get_held(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<HeldNoiseView>, ApiError> {
    let serial = serial_of(path)?;
    let row =
        st.store.held_noise_model(&serial).await?.ok_or_else(|| {
            ApiError::NotFound(format!("no noise model is held for unit {serial}"))
        })?;
    Ok(Json(row.try_into()?))
}

/// Holds the body's model for the unit (creating the unit if it has no
/// run yet), replacing any held before.
async fn put_held(
    State(st): State<AppState>,
    caller: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    JsonObject(body): JsonObject<HeldNoiseBody>,
) -> Result<Json<HeldNoiseView>, ApiError> {
    let serial = serial_of(path)?;
    let row = hold_for_unit(&st, &serial, (&body.noise, body.used_as), &caller.token_id).await?;
    Ok(Json(row.try_into()?))
}

/// Lets the unit's model go: its next calibrations measure and fit their
/// own. 404 when none was held.
async fn delete_held(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<StatusCode, ApiError> {
    let serial = serial_of(path)?;
    if st.store.release_noise_model(&serial).await? {
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(ApiError::NotFound(format!(
            "no noise model is held for unit {serial}"
        )))
    }
}
