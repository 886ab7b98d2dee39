//! The HTTP API under `/api/v1`: one router per resource, merged here with
//! one state struct. Only this module knows HTTP; every error becomes
//! problem+json in [`error`].

pub(crate) mod adopt;
pub mod auth;
pub(crate) mod certificate;
mod certificate_pdf;
pub(crate) mod certificate_sheet;
pub(crate) mod compensation;
pub(crate) mod designs;
pub mod error;
mod jobs;
mod json_object;
pub(crate) mod noise;
pub(crate) mod noise_models;
pub(crate) mod products;
pub(crate) mod runs;
mod schemes;
pub(crate) mod thermal;
pub(crate) mod tokens;
pub(crate) mod units;
pub mod upload;
pub mod upload_guard;
mod upload_store;

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

use self::auth::{roles, Caller};
use self::error::{problem_response, ApiError, PROBLEM_JSON};
use crate::config::Config;
use crate::metrics::Metrics;
use crate::runstore::RunStore;
use crate::store::{JobState, Store};

/// The OpenAPI document at the repository root: what the server serves is
/// what CI checks the server against.
pub const OPENAPI_YAML: &str = include_str!("../../../../openapi.yaml");

/// Shared by every handler.
#[derive(Clone)]
pub struct AppState {
    pub store: Store,
    /// Where the runs' files are kept.
    pub run_store: RunStore,
    pub config: Arc<Config>,
    pub metrics: Arc<Metrics>,
    /// Wakes a worker when a job is queued.
    pub wake: Arc<Notify>,
    /// Bounds concurrent uploads (each holds a blocking thread and a file).
    pub uploads: Arc<Semaphore>,
    /// One scheme design at a time (each takes tens of CPU seconds).
    pub designs: Arc<Semaphore>,
    /// Noise analyses computed at once (each reads a whole run twice).
    pub noise_analyses: Arc<Semaphore>,
    /// Set at shutdown: uploads are refused, readiness fails.
    pub stopping: Arc<AtomicBool>,
}

/// The whole application's router: the API under `/api/v1`, the
/// operations endpoints, and `pages` (the workbench's HTML, built by
/// `web`, which uses this module: it is passed in rather than named here).
pub fn router(state: AppState, pages: Router<AppState>) -> Router {
    let limit = usize::try_from(state.config.max_body_bytes).unwrap_or(usize::MAX);
    // Two separate limits, both needed: axum's DefaultBodyLimit (2 MB unless
    // changed) applies to its extractors, Multipart included; tower-http's
    // RequestBodyLimitLayer applies to the raw body stream.
    let upload = Router::new()
        .route("/units/{serial}/runs", post(upload::upload))
        .layer(DefaultBodyLimit::max(limit))
        .layer(RequestBodyLimitLayer::new(limit))
        .layer(axum::middleware::from_fn(close_after_refused_upload));
    // The operations endpoints, under the API and at the root too, where
    // orchestrators' probes and Prometheus look for them by default.
    let operations = operations();
    let api = Router::new()
        .merge(operations.clone())
        .route("/openapi.yaml", get(openapi))
        .merge(runs::router())
        .merge(adopt::router())
        .merge(certificate::router())
        .merge(compensation::router())
        .merge(noise::router())
        .merge(noise_models::router())
        .merge(jobs::router())
        .merge(units::router())
        .merge(thermal::router())
        .merge(schemes::router())
        .merge(designs::router())
        .merge(tokens::router())
        .merge(products::router())
        .merge(upload)
        .method_not_allowed_fallback(|| async { ApiError::MethodNotAllowed });
    Router::new()
        .nest("/api/v1", api)
        .merge(operations)
        .merge(pages)
        .fallback(|| async { ApiError::NotFound("no such endpoint".into()) })
        .layer(axum::middleware::from_fn(bound_request_head))
        .layer(axum::middleware::map_response(ensure_problem))
        .layer(tower::limit::GlobalConcurrencyLimitLayer::new(
            state.config.max_concurrent_requests,
        ))
        .layer(TraceLayer::new_for_http())
        .with_state(state)
}

fn operations() -> Router<AppState> {
    Router::new()
        .route("/healthz", get(healthz))
        .route("/readyz", get(readyz))
        .route("/metrics", get(metrics))
}

/// A worker process's router: the operations endpoints alone, at the root
/// and under `/api/v1`, with the same limits as the whole router.
pub fn operations_router(state: AppState) -> Router {
    Router::new()
        .nest("/api/v1", operations())
        .merge(operations())
        .fallback(|| async {
            ApiError::NotFound("a worker serves only /healthz, /readyz and /metrics".into())
        })
        .layer(axum::middleware::map_response(ensure_problem))
        .layer(tower::limit::GlobalConcurrencyLimitLayer::new(
            state.config.max_concurrent_requests,
        ))
        .layer(TraceLayer::new_for_http())
        .with_state(state)
}

/// An upload refused before its body was read (role, queue, disk, size)
/// leaves the rest of the body in flight, so its HTTP/1 connection cannot
/// carry another request: say so, or a client that pools it meets a broken
/// pipe on its next request. (HTTP/2 streams need no such header.)
pub(crate) async fn close_after_refused_upload(
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    let http1 = req.version() < axum::http::Version::HTTP_2;
    let mut resp = next.run(req).await;
    if http1 && !resp.status().is_success() {
        resp.headers_mut().insert(
            header::CONNECTION,
            axum::http::HeaderValue::from_static("close"),
        );
    }
    resp
}

/// Turns any error response made outside the handlers (a layer's 413, an
/// extractor's rejection) into problem+json, keeping its headers.
async fn ensure_problem(resp: Response) -> Response {
    let status = resp.status();
    // Pages answer their errors as pages.
    let is_problem_or_page = resp.headers().get(header::CONTENT_TYPE).is_some_and(|v| {
        v.as_bytes() == PROBLEM_JSON.as_bytes() || v.as_bytes().starts_with(b"text/html")
    });
    if !(status.is_client_error() || status.is_server_error()) || is_problem_or_page {
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

/// Longest request target (path and query) served.
const MAX_URI_BYTES: usize = 16 * 1024;
/// Most header fields, and most bytes of names and values, served.
const MAX_HEADER_FIELDS: usize = 64;
const MAX_HEADER_BYTES: usize = 64 * 1024;

/// Refuses an oversized request head with problem+json (414, 431). These
/// limits sit well inside the HTTP parser's own (URI 64 KiB, 100 fields,
/// ~400 KiB of head), which answer without a body; a request between the
/// two is answered here, as documented.
async fn bound_request_head(req: axum::extract::Request, next: axum::middleware::Next) -> Response {
    let uri_len = req.uri().path_and_query().map_or(0, |p| p.as_str().len());
    if uri_len > MAX_URI_BYTES {
        return ApiError::UriTooLong(format!(
            "the request target is {uri_len} bytes; at most {MAX_URI_BYTES} are served"
        ))
        .into_response();
    }
    let fields = req.headers().len();
    let bytes: usize = req
        .headers()
        .iter()
        .map(|(n, v)| n.as_str().len() + v.len())
        .sum();
    if fields > MAX_HEADER_FIELDS || bytes > MAX_HEADER_BYTES {
        return ApiError::HeadersTooLarge(format!(
            "{fields} header fields, {bytes} bytes; at most {MAX_HEADER_FIELDS} fields and \
             {MAX_HEADER_BYTES} bytes are served"
        ))
        .into_response();
    }
    next.run(req).await
}

/// Refuses new work (an upload, a queued job) once shutdown has begun.
pub(crate) fn refuse_while_stopping(st: &AppState) -> Result<(), ApiError> {
    if st.stopping.load(Ordering::Relaxed) {
        return Err(ApiError::Unavailable {
            detail: "the server is shutting down".into(),
            retry_after_s: 10,
        });
    }
    Ok(())
}

/// A run's or a job's id from a path segment. Ids are UUIDs made by the
/// server; anything else names nothing, so it is a 404 as an unknown id
/// is (not a 400). Parsed in the handler, after the role check, rather
/// than by axum's `Path` extractor, whose refusal of a malformed segment
/// would be a 400 with serde's message.
pub(crate) fn parse_id<T: std::str::FromStr>(raw: String, what: &str) -> Result<T, ApiError> {
    raw.parse()
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

/// Ready when the server can take an upload to its end: not stopping, the
/// data folder above its free-space floor and writable, an object store
/// (when runs are kept in one) taking a write, read and delete, the
/// database readable and writable. Each check runs on every call, so
/// readiness returns by itself once space is freed.
async fn readyz(State(st): State<AppState>) -> Response {
    match not_ready(&st).await {
        None => Json(serde_json::json!({"status": "ready"})).into_response(),
        Some(why) => {
            tracing::warn!(why, "not ready");
            let mut r = problem_response(StatusCode::SERVICE_UNAVAILABLE, why);
            r.headers_mut()
                .insert(header::RETRY_AFTER, header::HeaderValue::from(10u64));
            r
        }
    }
}

/// Why the server is not ready, if it is not.
async fn not_ready(st: &AppState) -> Option<String> {
    if st.stopping.load(Ordering::Relaxed) {
        return Some("shutting down".into());
    }
    if let Some(why) = st.run_store.not_ready(st.config.min_free_bytes).await {
        return Some(why);
    }
    if let Err(e) = st.store.ping().await {
        return Some(format!("database unavailable: {e}"));
    }
    if let Err(e) = st.store.write_probe().await {
        return Some(format!("database not writable: {e}"));
    }
    None
}

async fn metrics(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
) -> Result<Response, ApiError> {
    let counts = st.store.job_counts().await?;
    Ok((
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        st.metrics.render(
            counts.of(JobState::Queued),
            counts.iter().map(|(state, n)| (state.as_str(), n)),
        ),
    )
        .into_response())
}

async fn openapi(_: Caller<roles::Follow>) -> Result<Response, ApiError> {
    Ok(([(header::CONTENT_TYPE, "application/yaml")], OPENAPI_YAML).into_response())
}

impl AppState {
    /// Refuse new uploads and fail readiness from now on.
    pub fn set_stopping(&self) {
        self.stopping.store(true, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::{JobId, RunId};

    /// A path's id parses in any UUID spelling to the one the store keeps;
    /// anything else is the 404 of an id that names nothing.
    #[test]
    fn a_path_id_is_a_uuid_or_names_nothing() {
        let id: RunId = parse_id("6F9619FF8B86D011B42D00C04FC964FF".into(), "run").unwrap();
        assert_eq!(id.to_string(), "6f9619ff-8b86-d011-b42d-00c04fc964ff");
        match parse_id::<JobId>("not-a-uuid".into(), "job") {
            Err(ApiError::NotFound(detail)) => {
                assert_eq!(detail, r#"no job "not-a-uuid" (ids are UUIDs)"#)
            }
            other => panic!("{:?}", other.map(|id| id.to_string())),
        }
    }
}
