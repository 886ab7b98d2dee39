//! The units page (`/`): every unit with its product, latest calibration,
//! verdict and last run; search by serial, filter by verdict and product.
//! Without a session, `/` is the sign-in page.

use axum::extract::rejection::QueryRejection;
use axum::extract::{Query, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use maud::html;
use serde::Deserialize;

use super::access::PageCaller;
use super::error::PageError;
use super::format;
use super::layout;
use super::session::{see_other, MaybeSession};
use super::signin::signin_response;
use crate::api::auth::roles;
use crate::api::AppState;
use crate::store::{Role, UnitFilter};
use sinscal_core::accept::VerdictStatus;
use sinscal_core::io::meta::validate_product;

const PAGE_SIZE: i64 = 100;

#[derive(Debug, Default, Deserialize)]
pub struct UnitsQuery {
    #[serde(default)]
    q: String,
    #[serde(default)]
    verdict: String,
    #[serde(default)]
    product: String,
    #[serde(default)]
    offset: i64,
}

pub async fn page(
    State(st): State<AppState>,
    headers: HeaderMap,
    MaybeSession(session): MaybeSession,
    query: Result<Query<UnitsQuery>, QueryRejection>,
) -> Result<Response, PageError> {
    let Some(session) = session else {
        return Ok(signin_response(&headers, None, StatusCode::OK));
    };
    // A station's work starts at the upload form.
    if session.role() == Role::Station {
        return Ok(see_other("/upload"));
    }
    let session = PageCaller::<roles::Engineer>::new(session)?;
    let Query(q) = query.map_err(|e| PageError::bad_request(e.body_text()))?;
    let verdict = match q.verdict.as_str() {
        "" => None,
        v => Some(
            serde_json::from_value::<VerdictStatus>(serde_json::Value::String(v.into())).map_err(
                |_| {
                    PageError::bad_request(format!(
                        "verdict {v:?}: one of accepted, needs_review, rejected"
                    ))
                },
            )?,
        ),
    };
    let product = match q.product.trim() {
        "" => None,
        p => {
            validate_product(p).map_err(PageError::bad_request)?;
            Some(p.to_string())
        }
    };
    let search = q.q.trim();
    if search.len() > 64 {
        return Err(PageError::bad_request(
            "the search text is longer than 64 bytes".into(),
        ));
    }
    let offset = q.offset.clamp(0, 1_000_000_000);
    let filter = UnitFilter {
        verdict,
        product: product.clone(),
        serial_contains: (!search.is_empty()).then(|| search.to_string()),
    };
    let (total, units) = st.store.list_units(&filter, PAGE_SIZE, offset).await?;
    let products = st.store.list_product_types().await?;
    let mut rows = Vec::with_capacity(units.len());
    for u in units {
        let verdict = u.verdict()?;
        rows.push((u, verdict));
    }
    let next = offset + PAGE_SIZE;
    let body = html! {
        h1 { "Units" }
        form.filters method="get" action="/" {
            label for="q" { "Serial" }
            input #q type="search" name="q" value=(search) placeholder="contains…";
            label for="verdict" { "Verdict" }
            select #verdict name="verdict" {
                option value="" { "any" }
                @for (value, text) in [("accepted", "accepted"), ("needs_review", "needs review"), ("rejected", "rejected")] {
                    option value=(value) selected[q.verdict == value] { (text) }
                }
            }
            label for="product" { "Product" }
            select #product name="product" {
                option value="" { "any" }
                @for p in &products {
                    option value=(p.name) selected[product.as_deref() == Some(p.name.as_str())] { (p.name) }
                }
            }
            button type="submit" { "Filter" }
        }
        p.muted { (total) " units" @if total > PAGE_SIZE { ", " (offset + 1) "–" ((offset + PAGE_SIZE).min(total)) " shown" } }
        table #units {
            thead { tr {
                th { "Unit" } th { "Product" } th.num { "Runs" } th.num { "Calibrated" }
                th { "Latest calibration" } th { "Verdict" } th { "Last run" }
            } }
            tbody {
                @for (u, v) in &rows {
                    @let (word, class) = format::verdict(v.as_ref().map(|v| v.status()));
                    tr {
                        td { a href={ "/units/" (u.serial) } { (u.serial) } }
                        td { (u.product.as_deref().unwrap_or("—")) }
                        td.num { (u.runs) }
                        td.num { (u.calibrated) }
                        td {
                            @if let (Some(v), Some(at)) = (v, u.calibrated_at) {
                                a href={ "/runs/" (v.run_id) } { (format::time(at)) }
                            } @else { "—" }
                        }
                        td { span class={ "badge " (class) } { (word) } }
                        td { (u.last_run_time.map(format::time).unwrap_or_else(|| "—".into())) }
                    }
                }
            }
        }
        @if next < total {
            p { a href={ "/?q=" (urlencode(search)) "&verdict=" (q.verdict) "&product=" (urlencode(&q.product)) "&offset=" (next) } { "Next " (PAGE_SIZE) } }
        }
    };
    Ok(Html(layout::page("Units", Some(&session), body).into_string()).into_response())
}

/// Percent-encodes a query value (serials and product names are short
/// ASCII; anything else is encoded byte by byte).
pub fn urlencode(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}
