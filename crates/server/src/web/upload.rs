//! The upload form: a run's metadata (run.json) and data files, sent as the
//! API's multipart upload is, the unit named by the metadata. The form's
//! CSRF token travels in its action's query string, because the body
//! streams to disk and the token must be checked before a byte of it is
//! read; the page lists the session's own recent uploads.

use axum::extract::{Query, Request, State};
use axum::response::{Html, Response};
use maud::html;
use serde::Deserialize;

use super::access::{FormCaller, PageCaller};
use super::error::PageError;
use super::format;
use super::layout;
use super::session::see_other;
use crate::api::auth::roles;
use crate::api::upload::upload_form;
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
        form.stack #upload method="post" action={ "/upload?csrf=" (session.csrf()) } enctype="multipart/form-data" {
            label for="metadata" { "Metadata (run.json)" }
            input #metadata type="file" name="metadata" accept=".json,application/json" required;
            label for="data" { "Run data" }
            input #data type="file" name="data" required;
            button.primary type="submit" { "Upload" }
        }
        h2 { "Your recent uploads" }
        @if recent.is_empty() { p.muted { "None yet." } }
        @else {
            table #uploads {
                tr { th { "Uploaded" } th { "Unit" } th { "Run" } th { "Records" } th { "Calibrated" } }
                @for r in &recent {
                    tr { td { (format::time(r.uploaded_at)) } td { (r.unit_serial) }
                         td { a href={ "/runs/" (r.id) } { code { (format::short_id(r.id)) } } }
                         td.num { (r.file.records) } td { @if r.calibrated { "yes" } @else { "not yet" } } }
                }
            }
        }
    };
    Ok(Html(
        layout::page("Upload", Some(&session), body).into_string(),
    ))
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
    let stored = upload_form(&st, session.caller(), req).await?;
    Ok(see_other(&format!("/runs/{}", stored.run_id)))
}
