//! The pages' two static files, compiled into the binary: the style sheet
//! and htmx (2.x, BSD Zero Clause licence), served from this origin so that
//! the Content-Security-Policy can forbid every other.

use axum::http::header;
use axum::response::IntoResponse;

const STYLE_CSS: &str = include_str!("style.css");
const HTMX_JS: &str = include_str!("htmx.min.js");

pub async fn style() -> impl IntoResponse {
    (
        [
            (header::CONTENT_TYPE, "text/css; charset=utf-8"),
            (header::CACHE_CONTROL, "public, max-age=3600"),
        ],
        STYLE_CSS,
    )
}

pub async fn htmx() -> impl IntoResponse {
    (
        [
            (header::CONTENT_TYPE, "text/javascript; charset=utf-8"),
            (header::CACHE_CONTROL, "public, max-age=86400"),
        ],
        HTMX_JS,
    )
}
