//! Runs: read one, its result, delete one. (Uploads are in `upload`.)

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use serde::Serialize;

use super::auth::{roles, Auth};
use super::error::ApiError;
use super::{parse_id, rfc3339, AppState};
use crate::store::RunRow;

#[derive(Serialize)]
pub struct RunView {
    pub id: String,
    pub unit_serial: String,
    pub job_id: String,
    pub sha256: String,
    pub size_bytes: i64,
    pub records: i64,
    pub format: String,
    pub gzip: bool,
    pub uploaded_at: String,
    pub recorded_at: Option<String>,
    pub run_time: String,
    pub metadata: serde_json::Value,
}

impl RunView {
    fn from_row(r: RunRow) -> Result<Self, ApiError> {
        Ok(RunView {
            metadata: serde_json::from_str(&r.metadata)
                .map_err(|e| ApiError::Internal(e.to_string()))?,
            id: r.id,
            unit_serial: r.unit_serial,
            job_id: r.job_id,
            sha256: r.sha256,
            size_bytes: r.size_bytes,
            records: r.records,
            format: r.format,
            gzip: r.gzip,
            uploaded_at: rfc3339(r.uploaded_at),
            recorded_at: r.recorded_at.map(rfc3339),
            run_time: rfc3339(r.run_time),
        })
    }
}

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/runs/{id}", get(get_run).delete(delete_run))
        .route("/runs/{id}/result", get(get_result))
}

async fn get_run(
    State(st): State<AppState>,
    auth: Auth,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<RunView>, ApiError> {
    auth.require(roles::FOLLOW)?;
    let id = parse_id(path?.0, "run")?;
    let run = st
        .store
        .get_run(&id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no run {id}")))?;
    Ok(Json(RunView::from_row(run)?))
}

async fn get_result(
    State(st): State<AppState>,
    auth: Auth,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    auth.require(roles::ENGINEER)?;
    let id = parse_id(path?.0, "run")?;
    if let Some(json) = st.store.get_result(&id).await? {
        // Stored as serialized by the estimator's own types: served as is.
        return Ok(([(header::CONTENT_TYPE, "application/json")], json).into_response());
    }
    let run = st
        .store
        .get_run(&id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no run {id}")))?;
    let state = st
        .store
        .get_job(&run.job_id)
        .await?
        .map(|j| j.state)
        .unwrap_or_else(|| "unknown".into());
    Err(ApiError::Conflict(format!(
        "run {id} has no result: its job {} is {state}",
        run.job_id
    )))
}

async fn delete_run(
    State(st): State<AppState>,
    auth: Auth,
    path: Result<Path<String>, PathRejection>,
) -> Result<StatusCode, ApiError> {
    auth.require(roles::ADMIN)?;
    let id = parse_id(path?.0, "run")?;
    match st.store.delete_run(&id).await? {
        Ok(Some(blob)) => {
            // The rows are gone first: a crash before this line leaves an
            // orphan file, which the startup sweep removes.
            let _ = tokio::fs::remove_file(st.config.data_dir.join(blob)).await;
            Ok(StatusCode::NO_CONTENT)
        }
        Ok(None) => Err(ApiError::NotFound(format!("no run {id}"))),
        Err(state) => Err(ApiError::Conflict(format!(
            "run {id}'s job is {state}: cancel it and wait for it to stop first"
        ))),
    }
}
