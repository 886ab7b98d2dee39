//! Jobs: state and progress, cancel.

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Serialize;

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::{parse_id, rfc3339, AppState};
use crate::store::{JobId, JobKind, JobRow, JobState, Role, RunId};

#[derive(Clone, Debug, Serialize)]
pub struct JobView {
    pub id: JobId,
    /// The job's run; absent for a design job, which has none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub run_id: Option<RunId>,
    /// calibrate, diagnose or design.
    pub kind: JobKind,
    /// queued, running, succeeded, failed, dead_letter or cancelled.
    pub state: JobState,
    /// 0 … 100.
    pub progress_percent: f64,
    pub stage: Option<String>,
    pub attempts: i64,
    pub max_attempts: i64,
    pub cancel_requested: bool,
    /// The error of the last failed attempt, kept after retries.
    pub error: Option<String>,
    pub created_at: String,
    pub started_at: Option<String>,
    pub finished_at: Option<String>,
    pub heartbeat_at: Option<String>,
    pub lease_expires_at: Option<String>,
}

impl From<JobRow> for JobView {
    fn from(j: JobRow) -> Self {
        JobView {
            id: j.id,
            run_id: j.run_id,
            kind: j.kind,
            state: j.state,
            progress_percent: (j.progress * 1000.0).round() / 10.0,
            stage: j.stage,
            attempts: j.attempts,
            max_attempts: j.max_attempts,
            cancel_requested: j.cancel_requested,
            error: j.error,
            created_at: rfc3339(j.created_at),
            started_at: j.started_at.map(rfc3339),
            finished_at: j.finished_at.map(rfc3339),
            heartbeat_at: j.heartbeat_at.map(rfc3339),
            lease_expires_at: j.lease_expires_at.map(rfc3339),
        }
    }
}

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/jobs/{id}", get(get_job))
        .route("/jobs/{id}/cancel", post(cancel_job))
}

async fn get_job(
    State(st): State<AppState>,
    auth: Caller<roles::Follow>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<JobView>, ApiError> {
    let id: JobId = parse_id(path?.0, "job")?;
    let not_found = || ApiError::NotFound(format!("no job {id}"));
    let job = st.store.get_job(id).await?.ok_or_else(not_found)?;
    if auth.role == Role::Station {
        // A station reads only its own runs' jobs: never a design's.
        let run_id = job.run_id.ok_or_else(not_found)?;
        let uploader = st.store.get_run(run_id).await?.and_then(|r| r.uploaded_by);
        if !auth.may_read_run(uploader.as_deref()) {
            return Err(not_found());
        }
    }
    Ok(Json(job.into()))
}

/// Cancels a queued job at once; a running job stops at the estimator's
/// next check (its state shows `cancel_requested` until then). A finished
/// job cannot be cancelled (409); cancelling a cancelled job is a no-op.
async fn cancel_job(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<JobView>, ApiError> {
    let id: JobId = parse_id(path?.0, "job")?;
    let job = st
        .store
        .cancel_job(id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no job {id}")))?;
    if job.state.is_settled() {
        return Err(ApiError::Conflict(format!(
            "job {id} has already {}",
            job.state
        )));
    }
    Ok(Json(job.into()))
}
