//! Design jobs: `POST /designs` queues a scheme design as a durable job
//! (202, the same body as `POST /schemes/design`) and `GET /designs/{id}`
//! reads it back: the job's state, progress and error, the request, and
//! the design once it succeeded. A job has the server's design-job time
//! limit, far longer than a synchronous request's; running out fails the
//! job, saying so.

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Serialize;

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::jobs::JobView;
use super::json_object::JsonObject;
use super::upload_store::queue_full;
use super::{parse_id, refuse_while_stopping, AppState};
use crate::store::{DesignQueued, DesignRow, JobId};
use sinscal_core::design::{check, DesignError, DesignSpec};

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/designs", post(queue))
        .route("/designs/{id}", get(read))
}

/// A design job as the API answers it.
#[derive(Debug, Serialize)]
pub struct DesignJobView {
    #[serde(flatten)]
    pub job: JobView,
    /// The request as it was posted.
    pub request: serde_json::Value,
    /// The id of the token that asked.
    pub requested_by: String,
    /// The design (as `POST /schemes/design` answers it), once the job
    /// succeeded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub design: Option<serde_json::Value>,
}

impl DesignJobView {
    pub(crate) fn of(row: DesignRow) -> Result<DesignJobView, ApiError> {
        let json = |text: &str| {
            serde_json::from_str(text)
                .map_err(|e| ApiError::Internal(format!("a stored design is not JSON: {e}")))
        };
        Ok(DesignJobView {
            request: json(&row.request)?,
            design: row.design.as_deref().map(json).transpose()?,
            requested_by: row.requested_by,
            job: row.job.into(),
        })
    }
}

/// A design error as the API answers it: what the client can change is
/// 422; nothing else can arise before the search runs.
pub(crate) fn refused(e: DesignError) -> ApiError {
    match e {
        DesignError::Invalid(msg) => ApiError::Unprocessable(msg),
        e => ApiError::Unprocessable(e.to_string()),
    }
}

/// Queues a design job for `spec`, asked by `caller`, once its request is
/// checked (so that a bad request is a 422 now, not a failed job later).
pub(crate) async fn queue_design(
    st: &AppState,
    caller: &Caller<roles::Engineer>,
    spec: &DesignSpec,
) -> Result<DesignRow, ApiError> {
    refuse_while_stopping(st)?;
    check(&spec.request(None).map_err(refused)?).map_err(refused)?;
    let request = serde_json::to_string(spec).map_err(|e| ApiError::Internal(e.to_string()))?;
    let limits = (st.config.max_attempts, st.config.max_queue);
    match st
        .store
        .queue_design_job(&request, &caller.token_id, limits)
        .await?
    {
        DesignQueued::Created(row) => {
            st.wake.notify_one();
            Ok(*row)
        }
        DesignQueued::QueueFull => Err(queue_full()),
    }
}

/// A design job by id, or 404.
pub(crate) async fn design_job(st: &AppState, id: JobId) -> Result<DesignRow, ApiError> {
    st.store
        .get_design(id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no design {id}")))
}

async fn queue(
    State(st): State<AppState>,
    caller: Caller<roles::Engineer>,
    JsonObject(spec): JsonObject<DesignSpec>,
) -> Result<Response, ApiError> {
    let row = queue_design(&st, &caller, &spec).await?;
    let url = format!("/api/v1/designs/{}", row.job.id);
    let mut resp = (StatusCode::ACCEPTED, Json(DesignJobView::of(row)?)).into_response();
    if let Ok(v) = HeaderValue::from_str(&url) {
        resp.headers_mut().insert(header::LOCATION, v);
    }
    Ok(resp)
}

async fn read(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<DesignJobView>, ApiError> {
    let id: JobId = parse_id(path?.0, "design")?;
    Ok(Json(DesignJobView::of(design_job(&st, id).await?)?))
}
