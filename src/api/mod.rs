//! The HTTP API under `/api/v1`: one router per resource, merged here with
//! one state struct. Only this module knows HTTP; every error becomes
//! problem+json in [`error`].

pub mod auth;
pub mod error;
mod jobs;
mod runs;
mod tokens;
mod units;
pub mod upload;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use axum::extract::{DefaultBodyLimit, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use tokio::sync::{Notify, Semaphore};
use tower_http::limit::RequestBodyLimitLayer;
use tower_http::trace::TraceLayer;

use self::auth::{roles, Auth};
use self::error::{problem_response, ApiError, PROBLEM_JSON};
use crate::server::metrics::Metrics;
use crate::server::Config;
use crate::store::Store;

/// The OpenAPI document at the repository root: what the server serves is
/// what CI checks the server against.
pub const OPENAPI_YAML: &str = include_str!("../../openapi.yaml");

/// Shared by every handler.
#[derive(Clone)]
pub struct AppState {
    pub store: Store,
    pub config: Arc<Config>,
    pub metrics: Arc<Metrics>,
    /// Wakes a worker when a job is queued.
    pub wake: Arc<Notify>,
    /// Bounds concurrent uploads (each holds a blocking thread and a file).
    pub uploads: Arc<Semaphore>,
    /// Set at shutdown: uploads are refused, readiness fails.
    pub stopping: Arc<AtomicBool>,
}

/// The whole application's router.
pub fn router(state: AppState) -> Router {
    let limit = usize::try_from(state.config.max_body_bytes).unwrap_or(usize::MAX);
    // Two separate limits, both needed: axum's DefaultBodyLimit (2 MB unless
    // changed) applies to its extractors, Multipart included; tower-http's
    // RequestBodyLimitLayer applies to the raw body stream.
    let upload = Router::new()
        .route("/units/{serial}/runs", post(upload::upload))
        .layer(DefaultBodyLimit::max(limit))
        .layer(RequestBodyLimitLayer::new(limit));
    let api = Router::new()
        .route("/healthz", get(healthz))
        .route("/readyz", get(readyz))
        .route("/metrics", get(metrics))
        .route("/openapi.yaml", get(openapi))
        .merge(runs::router())
        .merge(jobs::router())
        .merge(units::router())
        .merge(tokens::router())
        .merge(upload)
        .method_not_allowed_fallback(|| async { ApiError::MethodNotAllowed });
    Router::new()
        .nest("/api/v1", api)
        .fallback(|| async { ApiError::NotFound("no such endpoint".into()) })
        .layer(axum::middleware::map_response(ensure_problem))
        .layer(tower::limit::GlobalConcurrencyLimitLayer::new(
            state.config.max_concurrent_requests,
        ))
        .layer(TraceLayer::new_for_http())
        .with_state(state)
}

/// Turns any error response made outside the handlers (a layer's 413, an
/// extractor's rejection) into problem+json, keeping its headers.
async fn ensure_problem(resp: Response) -> Response {
    let status = resp.status();
    let is_problem = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes() == PROBLEM_JSON.as_bytes());
    if !(status.is_client_error() || status.is_server_error()) || is_problem {
        return resp;
    }
    let (parts, _) = resp.into_parts();
    let mut fixed = problem_response(
        status,
        status.canonical_reason().unwrap_or("error").to_string(),
    );
    for (name, value) in parts.headers.iter() {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH {
            fixed.headers_mut().insert(name.clone(), value.clone());
        }
    }
    fixed
}

/// Ids are UUIDs made by the server; anything else names nothing.
pub(crate) fn parse_id(raw: String, what: &str) -> Result<String, ApiError> {
    uuid::Uuid::parse_str(&raw)
        .map(|u| u.hyphenated().to_string())
        .map_err(|_| ApiError::NotFound(format!("no {what} {raw:?} (ids are UUIDs)")))
}

pub(crate) fn rfc3339(ms: i64) -> String {
    chrono::DateTime::from_timestamp_millis(ms)
        .unwrap_or_default()
        .to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

/// An RFC 3339 time or a date (midnight UTC), as Unix ms.
pub(crate) fn parse_time(text: &str, what: &str) -> Result<i64, ApiError> {
    if let Ok(t) = chrono::DateTime::parse_from_rfc3339(text) {
        return Ok(t.timestamp_millis());
    }
    if let Ok(d) = chrono::NaiveDate::parse_from_str(text, "%Y-%m-%d") {
        if let Some(t) = d.and_hms_opt(0, 0, 0) {
            return Ok(t.and_utc().timestamp_millis());
        }
    }
    Err(ApiError::BadRequest(format!(
        "{what} must be an RFC 3339 time or a YYYY-MM-DD date, got {text:?}"
    )))
}

async fn healthz() -> Json<serde_json::Value> {
    Json(serde_json::json!({"status": "ok"}))
}

async fn readyz(State(st): State<AppState>) -> Response {
    if st.stopping.load(Ordering::Relaxed) {
        return problem_response(StatusCode::SERVICE_UNAVAILABLE, "shutting down".into());
    }
    match st.store.ping().await {
        Ok(()) => Json(serde_json::json!({"status": "ready"})).into_response(),
        Err(e) => {
            tracing::error!(error = %e, "readiness: database");
            problem_response(
                StatusCode::SERVICE_UNAVAILABLE,
                "database unavailable".into(),
            )
        }
    }
}

async fn metrics(State(st): State<AppState>, auth: Auth) -> Result<Response, ApiError> {
    auth.require(roles::ENGINEER)?;
    let counts = st.store.job_counts().await?;
    Ok((
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        st.metrics.render(&counts),
    )
        .into_response())
}

async fn openapi(auth: Auth) -> Result<Response, ApiError> {
    auth.require(roles::FOLLOW)?;
    Ok(([(header::CONTENT_TYPE, "application/yaml")], OPENAPI_YAML).into_response())
}

impl AppState {
    /// Refuse new uploads and fail readiness from now on.
    pub fn set_stopping(&self) {
        self.stopping.store(true, Ordering::Relaxed);
    }
}
