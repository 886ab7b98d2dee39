//! The calibration certificate of a run: one printable page saying which
//! unit, which data (its sha256), who recorded it where, what sinscal
//! version estimated what, within which limits, and the verdict.

use axum::extract::{Path, State};
use axum::response::Html;
use maud::html;

use super::access::PageCaller;
use super::error::PageError;
use super::format;
use super::layout;
use super::run::{parameter_table, parsed_result, product_limits, readable_run};
use crate::api::auth::roles;
use crate::api::AppState;
use sinscal_core::io::meta::RunMetadata;

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let result = parsed_result(&st, run.id).await?.ok_or_else(|| {
        PageError::not_found(format!("run {} has no result: no certificate yet", run.id))
    })?;
    let meta = RunMetadata::from_json(run.file.metadata.as_bytes()).ok();
    let verdict = run.verdict()?;
    let limits = product_limits(&st, verdict.as_ref()).await?;
    let completed = st
        .store
        .get_job(run.job_id)
        .await?
        .and_then(|j| j.finished_at);
    let (word, class) = format::verdict(verdict.as_ref().map(|v| v.status()));
    let body = html! {
        article.certificate {
            h1 { "Calibration certificate" }
            dl.facts #certificate-facts {
                dt { "Unit" } dd { strong { (run.unit_serial) } }
                dt { "Product" } dd { (meta.as_ref().and_then(|m| m.product.as_deref()).unwrap_or("—")) }
                dt { "Run" } dd { code { (run.id) } }
                dt { "Recorded" } dd { (format::time(run.run_time)) }
                dt { "Calibrated" } dd { (completed.map(format::time).unwrap_or_else(|| "—".into())) }
                dt { "Station" } dd { (meta.as_ref().and_then(|m| m.station.as_deref()).unwrap_or("—")) }
                dt { "Operator" } dd { (meta.as_ref().and_then(|m| m.operator.as_deref()).unwrap_or("—")) }
                dt { "Raw data sha256" } dd { code { (run.file.sha256) } }
                dt { "Estimator" } dd { (result.estimator) ", model " (result.model) ", " (result.passes) " passes over " (format::sig(result.duration_s / 3600.0, 3)) " h" }
                dt { "Software" } dd { "sinscal " (env!("CARGO_PKG_VERSION")) }
                dt { "Verdict" } dd { span class={ "badge " (class) } { (word) }
                    @if let Some(v) = &verdict { @if let (Some(p), Some(r)) = (&v.product, v.revision) { " against product type " (p) " revision " (r) } } }
                @if let Some(c) = &result.model_check { dt { "Model check" } dd { @if c.adequate { "adequate" } @else { "inadequate" } } }
            }
            h2 { "Parameters (1σ from the estimator)" }
            (parameter_table(&result, limits.as_ref(), verdict.as_ref().map(|v| &v.verdict)))
            p.muted { "Sign convention, units and the error model: sinscal's contract, SPEC §2. Issued " (format::time(crate::store::now_ms())) "." }
            p.noprint { a href={ "/runs/" (run.id) } { "Back to the run" } }
        }
    };
    Ok(Html(
        layout::page(
            &format!("Certificate {}", run.unit_serial),
            Some(&session),
            body,
        )
        .into_string(),
    ))
}
