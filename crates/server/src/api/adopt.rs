//! Closing the discrepancy loop: a run's diagnosis adopted as its model
//! (the named effects become states of its next calibration), and the
//! results a run has had, each with the model it was made with.

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Serialize;

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::runs::{calibration_queued, job_answer, latest_report};
use super::{parse_id, refuse_while_stopping, rfc3339, AppState};
use crate::store::{Adoption, JobId, JobState, ResultVersion, RunId};
use sinscal_core::calib::ErrorModel;
use sinscal_core::diagnose::DiagnoseReport;

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/runs/{id}/diagnosis/adopt", post(adopt_diagnosis))
        .route("/runs/{id}/results", get(list_results))
        .route("/runs/{id}/results/{seq}", get(get_result_version))
}

/// Adopts the run's latest diagnosis (202 with the calibration job queued
/// with the adopted model); 409 when it names nothing new, is not
/// settled, or the run's calibration is busy.
async fn adopt_diagnosis(
    State(st): State<AppState>,
    caller: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let job = adopt_latest_diagnosis(&st, id, &caller.token_id).await?;
    Ok(job_answer(StatusCode::ACCEPTED, job))
}

/// The model the run's latest diagnosis adds to its current result's,
/// adopted and its calibration queued (the API's action and the diagnosis
/// page's button).
pub(crate) async fn adopt_latest_diagnosis(
    st: &AppState,
    id: RunId,
    by: &str,
) -> Result<crate::store::JobRow, ApiError> {
    refuse_while_stopping(st)?;
    let (diagnosis, model) = model_to_adopt(st, id).await?;
    let adoption = Adoption {
        model: &model,
        diagnosis,
        by,
    };
    let requeued = st
        .store
        .adopt_model(id, adoption, st.config.max_attempts, st.config.max_queue)
        .await?;
    let job = calibration_queued(st, id, requeued)?;
    tracing::info!(run = %id, %model, diagnosis = %diagnosis, "model adopted; calibration queued");
    Ok(job)
}

/// The latest diagnosis (its job, settled and succeeded) and the model it
/// makes of the current result's.
async fn model_to_adopt(st: &AppState, id: RunId) -> Result<(JobId, ErrorModel), ApiError> {
    let stored = latest_report(st, id).await?;
    let job = st
        .store
        .latest_diagnose_job(id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("run {id} has no diagnosis")))?;
    if job.state != JobState::Succeeded {
        return Err(ApiError::Conflict(format!(
            "run {id}'s latest diagnose job {} is {}: adopt once it has succeeded",
            job.id, job.state
        )));
    }
    let current = current_model(st, id).await?;
    let report: DiagnoseReport = tokio::task::spawn_blocking(move || stored.parse())
        .await
        .map_err(|e| ApiError::Internal(format!("report task: {e}")))?
        .map_err(|e| ApiError::Internal(format!("stored diagnosis of run {id}: {e}")))?;
    let model = report
        .adopted_model(&current)
        .map_err(|e| ApiError::Conflict(format!("run {id}: {e}")))?;
    Ok((job.id, model))
}

/// The model of the run's current result; 409 while it has none.
async fn current_model(st: &AppState, id: RunId) -> Result<ErrorModel, ApiError> {
    let versions = st.store.result_versions(id).await?;
    let current = versions
        .into_iter()
        .find(ResultVersion::is_current)
        .ok_or_else(|| {
            ApiError::Conflict(format!(
                "run {id} has no current result to compare the diagnosis with"
            ))
        })?;
    match current.model {
        Some(m) => m
            .parse()
            .map_err(|e| ApiError::Internal(format!("run {id}'s result: {e}"))),
        None => Ok(ErrorModel::base()),
    }
}

/// One of a run's results, as listed.
#[derive(Serialize)]
struct ResultVersionView {
    seq: i64,
    current: bool,
    job_id: JobId,
    model: Option<String>,
    completed_at: String,
    superseded_at: Option<String>,
    verdict: Option<String>,
    model_check_adequate: Option<bool>,
}

impl From<ResultVersion> for ResultVersionView {
    fn from(v: ResultVersion) -> Self {
        ResultVersionView {
            seq: v.seq,
            current: v.is_current(),
            job_id: v.job_id,
            model: v.model,
            completed_at: rfc3339(v.completed_at),
            superseded_at: v.superseded_at.map(rfc3339),
            verdict: v.verdict,
            model_check_adequate: v.model_adequate,
        }
    }
}

async fn list_results(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<Vec<ResultVersionView>>, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    super::runs::stored_run(&st, id).await?;
    let versions = st.store.result_versions(id).await?;
    Ok(Json(versions.into_iter().map(Into::into).collect()))
}

async fn get_result_version(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<(String, String)>, PathRejection>,
) -> Result<Response, ApiError> {
    let (id, seq) = path?.0;
    let id: RunId = parse_id(id, "run")?;
    // Any segment that is not a result's number names nothing: a 404, as
    // an unknown id is.
    let seq: i64 = seq.parse().map_err(|_| {
        ApiError::NotFound(format!(
            "no result {seq:?} of run {id} (results are numbered from 1)"
        ))
    })?;
    let json = st
        .store
        .result_version(id, seq)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("run {id} has no result number {seq}")))?;
    Ok((
        [(header::CONTENT_TYPE, "application/json")],
        json.into_json(),
    )
        .into_response())
}
