//! A run's compensation file over HTTP: `GET /runs/{id}/compensation`
//! answers what `sinscal export` writes from the run's result, as JSON or,
//! with `?format=csv`, as CSV (CONTRACT §5a).

use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde::Deserialize;

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::{parse_id, AppState};
use crate::store::RunId;
use sinscal_core::calib::CalibrationResult;
use sinscal_core::compensation::{CompensationFile, Provenance};

pub fn router() -> Router<AppState> {
    Router::new().route("/runs/{id}/compensation", get(get_compensation))
}

/// The file's two forms.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum FileForm {
    #[default]
    Json,
    Csv,
}

#[derive(Debug, Deserialize)]
struct CompensationQuery {
    #[serde(default)]
    format: FileForm,
}

async fn get_compensation(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<CompensationQuery>, QueryRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let Query(q) = query?;
    let file = compensation_of(&st, id).await?;
    Ok(file_response(&file, q.format))
}

/// A compensation file as the response in the form asked for.
pub(crate) fn file_response(file: &CompensationFile, form: FileForm) -> Response {
    match form {
        FileForm::Json => {
            ([(header::CONTENT_TYPE, "application/json")], file.to_json()).into_response()
        }
        FileForm::Csv => ([(header::CONTENT_TYPE, "text/csv")], file.to_csv()).into_response(),
    }
}

/// The compensation file of a run's result (the API's and the run page's
/// download); 404 while the run has no result.
pub(crate) async fn compensation_of(
    st: &AppState,
    id: RunId,
) -> Result<CompensationFile, ApiError> {
    let run = super::runs::stored_run(st, id).await?;
    let Some(json) = st.store.get_result(id).await? else {
        // No result, no compensation: the file does not exist (yet).
        let state = st
            .store
            .get_job(run.job_id)
            .await?
            .map_or("unknown", |j| j.state.as_str());
        return Err(ApiError::NotFound(format!(
            "run {id} has no compensation: it has no result, its job {} is {state}",
            run.job_id
        )));
    };
    let provenance = Provenance {
        unit_serial: Some(run.unit_serial.into()),
        source: Some(format!("/api/v1/runs/{id}/result")),
        run_id: Some(id.to_string()),
        ..Provenance::default()
    };
    // A stored result is up to half a megabyte of JSON: parsed off the
    // async workers.
    let file = tokio::task::spawn_blocking(move || {
        let result: CalibrationResult = json
            .parse()
            .map_err(|e| ApiError::Internal(format!("stored result of run {id}: {e}")))?;
        CompensationFile::from_result(&result, provenance)
            .map_err(|e| ApiError::Internal(format!("stored result of run {id}: {e}")))
    })
    .await
    .map_err(|e| ApiError::Internal(format!("compensation task: {e}")))??;
    Ok(file)
}
