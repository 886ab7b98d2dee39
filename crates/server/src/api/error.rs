//! The one place where errors become HTTP responses: RFC 7807
//! `application/problem+json`, every status from a variant of [`ApiError`].

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::Serialize;

use crate::runstore::RunStoreError;
use crate::store::{is_storage_full_io, StoreError};
use sinscal_core::accept::LimitError;
use sinscal_core::io::data::{DataError, Position};
use sinscal_core::noise::NoiseError;

/// How long a client is asked to wait after a full disk (507) before
/// retrying: long enough for an operator or a cleanup job to free space.
pub const STORAGE_FULL_RETRY_AFTER_S: u64 = 60;

pub const PROBLEM_JSON: &str = "application/problem+json";

/// Where a problem was found: in an uploaded data file, or in a request
/// body's field.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ProblemPosition {
    Line(u64),
    Record(u64),
    Field(String),
}

/// Everything a handler can answer besides success.
#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    /// 400: the request is malformed (a missing part, a bad parameter).
    #[error("{0}")]
    BadRequest(String),
    /// 401: no bearer token, or one that is unknown or revoked.
    #[error("a valid bearer token is required")]
    Unauthenticated,
    /// 403: the token's role may not do this.
    #[error("this needs the role {0}")]
    Forbidden(&'static str),
    /// 404: no such resource.
    #[error("{0}")]
    NotFound(String),
    /// 405: the path exists, the method does not.
    #[error("method not allowed")]
    MethodNotAllowed,
    /// 408: the upload body stalled (no data for the idle timeout, or
    /// slower than the minimum rate).
    #[error("{0}")]
    RequestTimeout(String),
    /// 409: the resource's state forbids this now.
    #[error("{0}")]
    Conflict(String),
    /// 413: the body exceeds the configured limit.
    #[error("{0}")]
    PayloadTooLarge(String),
    /// 414: the request target is longer than the server reads.
    #[error("{0}")]
    UriTooLong(String),
    /// 422: the request body is well-formed JSON with invalid content.
    #[error("{0}")]
    Unprocessable(String),
    /// 431: the request's header fields are too large or too many.
    #[error("{0}")]
    HeadersTooLarge(String),
    /// 422: a field of the request body is invalid; `field` names it (a
    /// dotted path such as `limits.gyro_bias_x.max_sigma`).
    #[error("{field}: {message}")]
    InvalidField { field: String, message: String },
    /// 422: the metadata is invalid.
    #[error("{0}")]
    InvalidMetadata(String),
    /// 422: the run data is invalid; names the line or record.
    #[error("{0}")]
    InvalidData(#[from] DataError),
    /// 503: the queue is full or the server is stopping; retry later.
    #[error("{detail}")]
    Unavailable { detail: String, retry_after_s: u64 },
    /// 507: the disk holding the data is full; retry later.
    #[error("{detail}")]
    InsufficientStorage { detail: String, retry_after_s: u64 },
    /// 500: logged with its cause chain, answered opaquely.
    #[error("internal error: {0}")]
    Internal(String),
}

impl ApiError {
    /// The HTTP status this error answers with (the pages answer with it
    /// too).
    pub fn status(&self) -> StatusCode {
        match self {
            ApiError::BadRequest(_) => StatusCode::BAD_REQUEST,
            ApiError::Unauthenticated => StatusCode::UNAUTHORIZED,
            ApiError::Forbidden(_) => StatusCode::FORBIDDEN,
            ApiError::NotFound(_) => StatusCode::NOT_FOUND,
            ApiError::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
            ApiError::RequestTimeout(_) => StatusCode::REQUEST_TIMEOUT,
            ApiError::Conflict(_) => StatusCode::CONFLICT,
            ApiError::PayloadTooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::UriTooLong(_) => StatusCode::URI_TOO_LONG,
            ApiError::HeadersTooLarge(_) => StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
            ApiError::Unprocessable(_)
            | ApiError::InvalidField { .. }
            | ApiError::InvalidMetadata(_) => StatusCode::UNPROCESSABLE_ENTITY,
            ApiError::InvalidData(
                DataError::TooLarge { .. } | DataError::ExpansionRatio { .. },
            ) => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::InvalidData(_) => StatusCode::UNPROCESSABLE_ENTITY,
            ApiError::Unavailable { .. } => StatusCode::SERVICE_UNAVAILABLE,
            ApiError::InsufficientStorage { .. } => StatusCode::INSUFFICIENT_STORAGE,
            ApiError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// The answer to a full disk.
    pub fn storage_full() -> ApiError {
        ApiError::InsufficientStorage {
            detail: "the server's storage is full; retry later".into(),
            retry_after_s: STORAGE_FULL_RETRY_AFTER_S,
        }
    }
}

impl From<StoreError> for ApiError {
    fn from(e: StoreError) -> Self {
        if e.is_storage_full() {
            tracing::warn!(error = %e, "write refused: storage full");
            return ApiError::storage_full();
        }
        ApiError::Internal(e.to_string())
    }
}

impl From<std::io::Error> for ApiError {
    fn from(e: std::io::Error) -> Self {
        if is_storage_full_io(&e) {
            tracing::warn!(error = %e, "write refused: storage full");
            return ApiError::storage_full();
        }
        ApiError::Internal(format!("I/O: {e}"))
    }
}

impl From<RunStoreError> for ApiError {
    fn from(e: RunStoreError) -> Self {
        match e {
            // Local I/O keeps its meaning (a full disk is 507).
            RunStoreError::Io { source, .. } => ApiError::from(source),
            // The object store may answer again shortly.
            e @ RunStoreError::Remote { .. } => {
                tracing::warn!(error = %e, "run store unavailable");
                ApiError::Unavailable {
                    detail: format!("the run store is unavailable: {e}"),
                    retry_after_s: 30,
                }
            }
        }
    }
}

impl From<NoiseError> for ApiError {
    fn from(e: NoiseError) -> Self {
        match e {
            // The stored run cannot be analysed as recorded.
            NoiseError::TooShort { .. } | NoiseError::Unusable(_) => {
                ApiError::Unprocessable(e.to_string())
            }
            // The server's own file or options: nothing the client can fix.
            NoiseError::Source(_) | NoiseError::Options(_) | NoiseError::Cancelled => {
                ApiError::Internal(format!("noise analysis: {e}"))
            }
        }
    }
}

impl From<LimitError> for ApiError {
    fn from(e: LimitError) -> Self {
        ApiError::InvalidField {
            field: e.field,
            message: e.message,
        }
    }
}

impl From<axum::extract::rejection::PathRejection> for ApiError {
    fn from(e: axum::extract::rejection::PathRejection) -> Self {
        ApiError::BadRequest(e.body_text())
    }
}

impl From<axum::extract::rejection::QueryRejection> for ApiError {
    fn from(e: axum::extract::rejection::QueryRejection) -> Self {
        ApiError::BadRequest(e.body_text())
    }
}

impl From<axum::extract::rejection::JsonRejection> for ApiError {
    fn from(e: axum::extract::rejection::JsonRejection) -> Self {
        match e.status() {
            StatusCode::PAYLOAD_TOO_LARGE => ApiError::PayloadTooLarge(e.body_text()),
            // Valid JSON that does not fit the request's schema (an unknown
            // role, a missing field).
            StatusCode::UNPROCESSABLE_ENTITY => ApiError::Unprocessable(e.body_text()),
            _ => ApiError::BadRequest(e.body_text()),
        }
    }
}

#[derive(Serialize)]
struct Problem<'a> {
    #[serde(rename = "type")]
    kind: &'a str,
    title: &'a str,
    status: u16,
    detail: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    line: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    record: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    field: Option<String>,
}

/// A problem+json response for a status with no more to say than its
/// reason phrase (used for responses produced outside the handlers).
pub fn problem_response(status: StatusCode, detail: String) -> Response {
    let title = status.canonical_reason().unwrap_or("Error");
    render(status, "about:blank", title, detail, None)
}

fn render(
    status: StatusCode,
    kind: &str,
    title: &str,
    detail: String,
    at: Option<ProblemPosition>,
) -> Response {
    let (mut line, mut record, mut field) = (None, None, None);
    match at {
        Some(ProblemPosition::Line(l)) => line = Some(l),
        Some(ProblemPosition::Record(r)) => record = Some(r),
        Some(ProblemPosition::Field(f)) => field = Some(f),
        None => {}
    }
    let body = Problem {
        kind,
        title,
        status: status.as_u16(),
        detail,
        line,
        record,
        field,
    };
    let json = serde_json::to_vec(&body).unwrap_or_else(|_| b"{}".to_vec());
    let mut resp = (status, json).into_response();
    resp.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static(PROBLEM_JSON));
    resp
}

impl ApiError {
    /// The problem's type URI and title: a sinscal type where a client can
    /// act on the kind of problem, otherwise `about:blank` with the status's
    /// reason phrase (422's in RFC 9110's wording).
    fn problem_type(&self) -> (&'static str, &'static str) {
        match self {
            ApiError::InvalidField { .. } => ("urn:sinscal:problem:invalid-field", "Invalid field"),
            ApiError::InvalidMetadata(_) => (
                "urn:sinscal:problem:invalid-metadata",
                "Invalid run metadata",
            ),
            ApiError::InvalidData(
                DataError::TooLarge { .. } | DataError::ExpansionRatio { .. },
            ) => ("urn:sinscal:problem:invalid-data", "Run data too large"),
            ApiError::InvalidData(_) => ("urn:sinscal:problem:invalid-data", "Invalid run data"),
            ApiError::InsufficientStorage { .. } => {
                ("urn:sinscal:problem:storage-full", "Insufficient Storage")
            }
            ApiError::Unprocessable(_) => ("about:blank", "Unprocessable Content"),
            _ => (
                "about:blank",
                self.status().canonical_reason().unwrap_or("Error"),
            ),
        }
    }

    /// Where the problem is: the data's line or record, or the field.
    fn position(&self) -> Option<ProblemPosition> {
        match self {
            ApiError::InvalidField { field, .. } => Some(ProblemPosition::Field(field.clone())),
            ApiError::InvalidData(e) => e.position().map(|p| match p {
                Position::Line(l) => ProblemPosition::Line(l),
                Position::Record { number, .. } => ProblemPosition::Record(number),
            }),
            _ => None,
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let (kind, title) = self.problem_type();
        let detail = match &self {
            ApiError::Internal(cause) => {
                tracing::error!(cause, "internal error");
                "internal error; the server log has the cause".to_string()
            }
            _ => self.to_string(),
        };
        let mut response = render(self.status(), kind, title, detail, self.position());
        let headers = response.headers_mut();
        match self {
            ApiError::Unauthenticated => {
                headers.insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
            }
            ApiError::Unavailable { retry_after_s, .. }
            | ApiError::InsufficientStorage { retry_after_s, .. } => {
                headers.insert(header::RETRY_AFTER, HeaderValue::from(retry_after_s));
            }
            _ => {}
        }
        response
    }
}
