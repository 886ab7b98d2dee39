//! How a page answers what went wrong: as a page, with the same status and
//! the same words the API would use (its `ApiError`), so that an engineer
//! reads the cause, not a blank screen.

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use maud::html;

use crate::api::error::ApiError;
use crate::store::StoreError;

#[derive(Debug)]
pub enum PageError {
    /// No session: the browser is sent to the sign-in page.
    SignIn,
    /// A status and what to tell the reader.
    Status(StatusCode, String),
}

impl From<ApiError> for PageError {
    fn from(e: ApiError) -> Self {
        let (status, detail) = shown(e);
        PageError::Status(status, detail)
    }
}

/// The status of an API error and its words for a page: the API's detail,
/// but an internal cause only in the log.
pub fn shown(e: ApiError) -> (StatusCode, String) {
    let status = e.status();
    let detail = match e {
        // Logged where it happened; not for the page.
        ApiError::Internal(cause) => {
            tracing::error!(%cause, "page failed");
            "the server failed to answer; the cause is in its log".to_string()
        }
        other => other.to_string(),
    };
    (status, detail)
}

impl From<StoreError> for PageError {
    fn from(e: StoreError) -> Self {
        ApiError::from(e).into()
    }
}

impl PageError {
    pub fn not_found(what: String) -> PageError {
        PageError::Status(StatusCode::NOT_FOUND, what)
    }

    pub fn bad_request(what: String) -> PageError {
        PageError::Status(StatusCode::BAD_REQUEST, what)
    }
}

impl IntoResponse for PageError {
    fn into_response(self) -> Response {
        match self {
            PageError::SignIn => {
                let mut resp = StatusCode::SEE_OTHER.into_response();
                resp.headers_mut()
                    .insert(header::LOCATION, HeaderValue::from_static("/signin"));
                // An htmx request follows this header instead.
                resp.headers_mut()
                    .insert("hx-redirect", HeaderValue::from_static("/signin"));
                resp
            }
            PageError::Status(status, detail) => {
                let title = status.canonical_reason().unwrap_or("Error");
                let body = html! {
                    (maud::DOCTYPE)
                    html lang="en" {
                        head {
                            meta charset="utf-8";
                            title { (title) " · sinscal" }
                            link rel="stylesheet" href="/static/style.css";
                            link rel="icon" href="data:,";
                        }
                        body {
                            main {
                                h1 { (status.as_u16()) " " (title) }
                                p.problem { (detail) }
                                p { a href="/" { "Units" } " · " a href="/signin" { "Sign in" } }
                            }
                        }
                    }
                };
                (status, Html(body.into_string())).into_response()
            }
        }
    }
}
