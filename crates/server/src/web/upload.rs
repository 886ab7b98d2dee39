//! The upload form: a run's metadata (run.json) and data files, sent as the
//! API's multipart upload is, the unit named by the metadata. The form's
//! CSRF token travels in its action's query string, because the body
//! streams to disk and the token must be checked before a byte of it is
//! read; the page lists the session's own recent uploads with where each
//! stands (its verdict once calibrated). A refused upload answers with
//! the form again under what was refused: the data file or the metadata,
//! and why.

use axum::extract::{Query, Request, State};
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
    let what = match refusal.part {
        Some(UploadPart::Data) => "The data file was refused",
        Some(UploadPart::Metadata) => "The metadata (run.json) was refused",
        None => "The upload was refused",
    };
    let part = refusal.part.map(|p| match p {
        UploadPart::Data => "data",
        UploadPart::Metadata => "metadata",
    });
    let (status, detail) = shown(refusal.error);
    let body = html! {
        h1 { "Upload refused" }
        section #refusal data-part=[part] {
            p { strong { (what) } " (" (status.as_u16()) " " (status.canonical_reason().unwrap_or("")) "):" }
            p.problem #refusal-detail { (detail) }
        }
        h2 { "Send it again" }
        p.muted { "Choose the files again (a browser does not keep them), or go back to " a href="/upload" { "the upload page" } "." }
        (form(session))
    };
    let page = layout::page("Upload refused", Some(session), body).into_string();
    (status, Html(page)).into_response()
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
