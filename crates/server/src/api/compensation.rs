//! A run's compensation file over HTTP: `GET /runs/{id}/compensation`
//! answers what `sinscal export` writes from the run's result, as JSON or,
//! with `?format=csv`, as CSV (CONTRACT §5a). The file of a result the
//! acceptance did not accept is released only on an engineer's stated
//! reason (`?override=…`), which the file's provenance records with the
//! verdict.

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
use sinscal_core::accept::VerdictStatus;
use sinscal_core::calib::CalibrationResult;
use sinscal_core::compensation::{CompensationFile, Provenance, VerdictOverride};

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
    /// Why the file of a result that is not accepted is wanted anyway.
    #[serde(default, rename = "override")]
    override_reason: Option<String>,
}

/// The longest override reason kept: a sentence, not a document.
const MAX_OVERRIDE_CHARS: usize = 300;

/// An engineer's reason to release the file of a result that is not
/// accepted: one line of printable text (it becomes a CSV comment line),
/// checked before anything is read. Only an engineer (or admin) gives one.
pub(crate) fn override_of(
    caller: &Caller<roles::Engineer>,
    reason: Option<&str>,
) -> Result<Option<VerdictOverride>, ApiError> {
    let Some(reason) = reason.map(str::trim) else {
        return Ok(None);
    };
    if reason.is_empty() || reason.chars().count() > MAX_OVERRIDE_CHARS {
        return Err(ApiError::BadRequest(format!(
            "override: give the reason in 1 to {MAX_OVERRIDE_CHARS} characters"
        )));
    }
    if reason.chars().any(char::is_control) {
        return Err(ApiError::BadRequest(
            "override: the reason is one line of text, without control characters".into(),
        ));
    }
    Ok(Some(VerdictOverride {
        by: caller.token_id.clone(),
        reason: reason.to_string(),
    }))
}

async fn get_compensation(
    State(st): State<AppState>,
    caller: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<CompensationQuery>, QueryRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let Query(q) = query?;
    let overridden = override_of(&caller, q.override_reason.as_deref())?;
    let file = compensation_of(&st, id, overridden).await?;
    Ok(file_response(&file, q.format))
}

/// Why the file of a result that is not accepted is held back.
fn not_released(id: RunId, status: Option<VerdictStatus>) -> ApiError {
    let judged = status.map_or("has not been judged".to_string(), |s| {
        format!("is {}", s.as_str().replace('_', " "))
    });
    ApiError::Conflict(format!(
        "run {id} {judged}: its compensation file is released only with an engineer's reason \
         (override=<reason>), which the file records"
    ))
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
/// download); 404 while the run has no result, 409 when the result is not
/// accepted and no override was given.
pub(crate) async fn compensation_of(
    st: &AppState,
    id: RunId,
    overridden: Option<VerdictOverride>,
) -> Result<CompensationFile, ApiError> {
    let run = super::runs::stored_run(st, id).await?;
    let status = run.verdict()?.map(|v| v.verdict.status());
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
        verdict: Some(status.map_or("unjudged", VerdictStatus::as_str).to_string()),
        verdict_override: if status == Some(VerdictStatus::Accepted) {
            None
        } else {
            Some(overridden.ok_or_else(|| not_released(id, status))?)
        },
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
