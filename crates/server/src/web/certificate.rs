//! The calibration certificate of a run's current result: one A4 page
//! (print styles in the style sheet) saying which unit, which data (its
//! sha256), where and how it was recorded, what sinscal version estimated
//! what within which limits, how repeatable the unit is, the verdict, and
//! who approved it. A draft until approved, with the approve button for an
//! engineer or admin; the same text as a PDF the server makes. The text
//! is the API's (`certificate_sheet`), so page and PDF cannot differ.

use axum::extract::{Path, State};
use axum::response::{Html, Response};
use axum::Form;
use maud::{html, Markup};

use super::access::{FormCaller, PageCaller};
use super::error::PageError;
use super::layout;
use super::run::readable_run;
use super::session::{see_other, CsrfForm};
use crate::api::auth::roles;
use crate::api::certificate::{approve_certificate, certificate_of, pdf_response, Certificate};
use crate::api::certificate_sheet::{Sheet, DRAFT, HEADS};
use crate::api::AppState;

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let c = certificate_of(&st, run).await?;
    let sheet = c.sheet();
    let title = match &sheet.number {
        Some(n) => format!("Certificate {n}"),
        None => format!("Certificate {} (draft)", c.run.unit_serial),
    };
    Ok(Html(
        layout::page(&title, Some(&session), body(&c, &sheet, &session)).into_string(),
    ))
}

fn body(c: &Certificate, sheet: &Sheet, session: &PageCaller<roles::Engineer>) -> Markup {
    let id = c.run.id;
    html! {
        article.certificate.draft[sheet.number.is_none()] {
            header.certificate-head {
                h1 { "Calibration certificate" }
                p #certificate-number {
                    @match &sheet.number {
                        Some(n) => { "No. " strong { (n) } }
                        None => strong.fail { (DRAFT) },
                    }
                    br;
                    "Issued " span #certificate-issued { (sheet.issued.as_deref().unwrap_or("not issued")) }
                }
            }
            dl.facts #certificate-facts {
                @for (label, value) in &sheet.facts {
                    dt { (label) } dd { @if label.ends_with("sha256") || *label == "Run" { code { (value) } } @else { (value) } }
                }
            }
            section #approval .approval {
                @match &sheet.approval {
                    Some((who, role, when)) => p { strong { "Approved" } " by " strong #approved-by { (who) } " (" (role) "), " (when) },
                    None => {
                        p { strong.fail { "DRAFT" } " — not approved: not a valid certificate." }
                        @if c.approvable() {
                            form.inline.noprint #approve method="post" action={ "/runs/" (id) "/certificate/approve" } {
                                input type="hidden" name="csrf" value=(session.csrf());
                                button.primary type="submit" { "Approve and issue" }
                            }
                        } @else {
                            p.muted.noprint { "Only a result whose verdict is accepted can be approved." }
                        }
                    }
                }
            }
            h2 { "Parameters (1σ from the estimator)" }
            table #certificate-parameters {
                thead { tr { @for h in HEADS { th { (h) } } } }
                tbody {
                    @for row in &sheet.rows {
                        tr class=[(row.check == "fail" || row.repeat_check == "fail").then_some("fail")] {
                            @for (i, cell) in row.cells().iter().enumerate() {
                                @if (1..=2).contains(&i) || (4..=5).contains(&i) || (7..=8).contains(&i) { td.num { (cell) } } @else { td { (cell) } }
                            }
                        }
                    }
                }
            }
            p.muted { "Repeat.: the sample standard deviation over the unit's " (sheet.repeatability_runs) " calibrated run(s) up to this one, against the product type's max_repeatability. Sign convention, units and the error model: sinscal's contract, SPEC §2." }
            @if !sheet.superseded.is_empty() {
                p.muted #superseded-certificates { "Earlier results of this run were certified as: " (sheet.superseded.join("; ")) }
            }
            p.noprint {
                a #certificate-pdf href={ "/runs/" (id) "/certificate.pdf" } { "PDF" }
                " · "
                a href={ "/runs/" (id) } { "Back to the run" }
            }
        }
    }
}

/// `GET /runs/{id}/certificate.pdf`: the API's PDF, for the session.
pub async fn pdf(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Response, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let c = certificate_of(&st, run).await?;
    Ok(pdf_response(&c))
}

/// `POST /runs/{id}/certificate/approve`: the approve button, through the
/// API's own action (CSRF token checked, then the role), then back to the
/// certificate.
pub async fn approve(
    State(st): State<AppState>,
    sender: FormCaller<roles::Engineer>,
    Path(id): Path<String>,
    Form(form): Form<CsrfForm>,
) -> Result<Response, PageError> {
    let session = sender.check_csrf(&form.csrf)?;
    let run = readable_run(&st, &session, id).await?;
    approve_certificate(&st, run.id, &session.auth).await?;
    Ok(see_other(&format!("/runs/{}/certificate", run.id)))
}
