//! The workbench: HTML pages at the server's root for the people of a
//! calibration line, rendered on the server (maud), same origin and same
//! roles as the API. A browser signs in with a token and then holds a
//! session cookie (`session`); every form carries the session's CSRF token.
//! Pages work without JavaScript; htmx only refreshes a running job's
//! progress.
//!
//! Each page is a file named for what it shows; they read through the
//! store and act through the API's own action functions, so a button does
//! exactly what the matching API call does. Plots are `plot` charts inlined
//! as SVG: a page is one request.

mod access;
mod admin;
mod assets;
mod certificate;
mod design;
mod design_job;
mod diagnosis;
mod error;
mod format;
mod layout;
mod noise;
mod noise_charts;
mod run;
mod run_plots;
mod run_verdict;
mod session;
mod signin;
mod unit;
mod unit_noise;
mod unit_tables;
mod unit_thermal;
mod units;
mod upload;

use axum::extract::DefaultBodyLimit;
use axum::http::{header, HeaderValue, Method, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use tower_http::limit::RequestBodyLimitLayer;

pub use self::error::PageError;
use crate::api::AppState;

/// The pages' routes. `max_body_bytes` bounds the upload form as it bounds
/// the API's upload.
pub fn router(max_body_bytes: u64) -> Router<AppState> {
    let limit = usize::try_from(max_body_bytes).unwrap_or(usize::MAX);
    let upload = Router::new()
        .route("/upload", get(upload::page).post(upload::submit))
        .layer(DefaultBodyLimit::max(limit))
        .layer(RequestBodyLimitLayer::new(limit))
        .layer(axum::middleware::map_response(move |resp| async move {
            upload::oversized_as_page(resp, max_body_bytes)
        }))
        .layer(axum::middleware::from_fn(
            crate::api::close_after_refused_upload,
        ));
    Router::new()
        .route("/", get(units::page))
        .route("/signin", get(signin::signin_page).post(signin::sign_in))
        .route("/signout", post(signin::sign_out))
        .route("/units/{serial}", get(unit::page))
        .route("/units/{serial}/noise-model", post(unit_noise::hold))
        .route(
            "/units/{serial}/noise-model/release",
            post(unit_noise::release),
        )
        .route("/runs/{id}", get(run::page))
        .route("/runs/{id}/progress", get(run::progress))
        .route("/runs/{id}/files/{name}", get(run::download))
        .route("/runs/{id}/{action}", post(run::action))
        .route("/runs/{id}/certificate", get(certificate::page))
        .route("/runs/{id}/certificate.pdf", get(certificate::pdf))
        .route("/runs/{id}/certificate/approve", post(certificate::approve))
        .route("/runs/{id}/diagnosis", get(diagnosis::page))
        .route("/runs/{id}/noise", get(noise::page))
        .route("/design", get(design::page).post(design::submit))
        .route("/designs/{id}", get(design_job::page))
        .route("/designs/{id}/progress", get(design_job::progress))
        .route("/designs/{id}/scheme.json", get(design_job::download))
        .route("/admin", get(admin::page))
        .route("/admin/tokens", post(admin::create_token))
        .route("/admin/tokens/{id}/revoke", post(admin::revoke_token))
        .route("/admin/products", post(admin::save_product))
        .route("/admin/products/{name}/delete", post(admin::delete_product))
        .route("/static/style.css", get(assets::style))
        .route("/static/htmx.min.js", get(assets::htmx))
        .merge(upload)
        .layer(axum::middleware::from_fn(same_origin_writes))
        .layer(axum::middleware::map_response(page_headers))
}

/// What every page answer carries: a Content-Security-Policy that allows
/// only this origin's scripts and styles (no inline script, so an injected
/// tag cannot run), no framing, no sniffing, and no caching of pages that
/// show a line's results.
async fn page_headers(mut resp: Response) -> Response {
    let h = resp.headers_mut();
    let is_page = h
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"text/html"));
    if is_page {
        h.insert(
            header::CONTENT_SECURITY_POLICY,
            HeaderValue::from_static(
                "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; \
                 connect-src 'self'; form-action 'self'; frame-ancestors 'none'; base-uri 'none'",
            ),
        );
        h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
        h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    }
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("same-origin"),
    );
    resp
}

/// Refuses a state-changing request that a browser says came from another
/// site (`Sec-Fetch-Site`, `Origin`), before any handler or CSRF check runs.
/// The CSRF token is the defence; this is the second, and the only one the
/// sign-in form has before a session exists.
async fn same_origin_writes(req: axum::extract::Request, next: axum::middleware::Next) -> Response {
    if req.method() != Method::GET && req.method() != Method::HEAD {
        let h = req.headers();
        let cross_site = h
            .get("sec-fetch-site")
            .is_some_and(|v| v.as_bytes() == b"cross-site" || v.as_bytes() == b"same-site");
        let host = h.get(header::HOST).and_then(|v| v.to_str().ok());
        let foreign_origin = h
            .get(header::ORIGIN)
            .and_then(|v| v.to_str().ok())
            .is_some_and(|origin| {
                let authority = origin.split_once("://").map_or(origin, |(_, a)| a);
                Some(authority) != host
            });
        if cross_site || foreign_origin {
            return PageError::Status(
                StatusCode::FORBIDDEN,
                "this form was sent from another site".into(),
            )
            .into_response();
        }
    }
    next.run(req).await
}
