//! The upload form: a run's metadata (run.json) and data files, sent as the
//! API's multipart upload is, the unit named by the metadata. The form's
//! CSRF token travels in its action's query string, because the body
//! streams to disk and the token must be checked before a byte of it is
//! read; the page lists the session's own recent uploads with where each
//! stands (its verdict once calibrated). A refused upload answers with
//! the form again under what was refused: the data file or the metadata,
//! and why.

use axum::extract::{Query, Request, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use maud::{html, Markup};
use serde::Deserialize;

use super::access::{FormCaller, PageCaller};
use super::error::{shown, PageError};
use super::format;
use super::layout;
use super::session::see_other;
use crate::api::auth::roles;
use crate::api::upload::{upload_form, RefusedUpload, UploadPart};
use crate::api::AppState;

const RECENT_UPLOADS: i64 = 20;

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Upload>,
) -> Result<Html<String>, PageError> {
    let recent = st
        .store
        .runs_uploaded_by(&session.auth.token_id, RECENT_UPLOADS)
        .await?;
    let body = html! {
        h1 { "Upload a run" }
        p { "The metadata file (SPEC §5, " code { "run.json" } ") names the unit, the sample rate and the data format; the data file is the run as recorded (CSV, gzip CSV or f64le). Both are checked as they arrive; a refused file names the line or field at fault." }
        (form(&session))
        h2 { "Your recent uploads" }
        @if recent.is_empty() { p.muted { "None yet." } }
        @else {
            table #uploads {
                tr { th { "Uploaded" } th { "Unit" } th { "Run" } th { "Records" } th { "Verdict" } }
                @for r in &recent {
                    @let (word, class) = format::run_outcome(r.calibrated, r.job_state, r.verdict()?.map(|v| v.status()));
                    tr { td { (format::time(r.uploaded_at)) } td { (r.unit_serial) }
                         td { a href={ "/runs/" (r.id) } { code { (format::short_id(r.id)) } } }
                         td.num { (r.file.records) } td { span class={ "badge " (class) } { (word) } } }
                }
            }
        }
    };
    Ok(Html(
        layout::page("Upload", Some(&session), body).into_string(),
    ))
}

/// The upload form itself, its CSRF token in its action.
fn form(session: &PageCaller<roles::Upload>) -> Markup {
    html! {
        form.stack #upload method="post" action={ "/upload?csrf=" (session.csrf()) } enctype="multipart/form-data" {
            label for="metadata" { "Metadata (run.json)" }
            input #metadata type="file" name="metadata" accept=".json,application/json" required;
            label for="data" { "Run data" }
            input #data type="file" name="data" required;
            button.primary type="submit" { "Upload" }
        }
    }
}

/// The answer to a refused upload: with the API's status, what was
/// refused (the data file, the metadata, or the upload as a whole) and
/// the problem's detail, then the form to send it again.
fn refused(session: &PageCaller<roles::Upload>, refusal: RefusedUpload) -> Response {
    let (status, detail) = shown(refusal.error);
    refusal_page(Some(session), refusal.part, status, &detail)
}

/// A refusal page; without a session (a body refused before the handler
/// read one) it links back to the form instead of repeating it.
fn refusal_page(
    session: Option<&PageCaller<roles::Upload>>,
    part: Option<UploadPart>,
    status: StatusCode,
    detail: &str,
) -> Response {
    let what = match part {
        Some(UploadPart::Data) => "The data file was refused",
        Some(UploadPart::Metadata) => "The metadata (run.json) was refused",
        None => "The upload was refused",
    };
    let part = part.map(|p| match p {
        UploadPart::Data => "data",
        UploadPart::Metadata => "metadata",
    });
    let body = html! {
        h1 { "Upload refused" }
        section #refusal data-part=[part] {
            p { strong { (what) } " (" (status.as_u16()) " " (status.canonical_reason().unwrap_or("")) "):" }
            p.problem #refusal-detail { (detail) }
        }
        h2 { "Send it again" }
        p.muted { "Choose the files again (a browser does not keep them), or go back to " a href="/upload" { "the upload page" } "." }
        @if let Some(session) = session { (form(session)) }
    };
    let nav = session.map(|s| &**s);
    let page = layout::page("Upload refused", nav, body).into_string();
    (status, Html(page)).into_response()
}

/// The body limit's own 413, answered before the handler runs when a
/// browser declares a body over `max_body_bytes`: as the refusal page (the
/// data file is what makes a body that large; the metadata part is
/// capped far below). Any other answer passes unchanged.
pub fn oversized_as_page(resp: Response, max_body_bytes: u64) -> Response {
    let is_page = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"text/html"));
    if resp.status() != StatusCode::PAYLOAD_TOO_LARGE || is_page {
        return resp;
    }
    let detail = format!("the upload exceeds the limit of {max_body_bytes} bytes");
    let mut page = refusal_page(None, Some(UploadPart::Data), resp.status(), &detail);
    for (name, value) in resp.headers() {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH {
            page.headers_mut().insert(name.clone(), value.clone());
        }
    }
    page
}

#[derive(Deserialize)]
pub struct UploadTarget {
    #[serde(default)]
    csrf: String,
}

pub async fn submit(
    State(st): State<AppState>,
    sender: FormCaller<roles::Upload>,
    Query(target): Query<UploadTarget>,
    req: Request,
) -> Result<Response, PageError> {
    let session = sender.check_csrf(&target.csrf)?;
    match upload_form(&st, session.caller(), req).await {
        Ok(stored) => Ok(see_other(&format!("/runs/{}", stored.run_id))),
        Err(refusal) => Ok(refused(&session, refusal)),
    }
}
