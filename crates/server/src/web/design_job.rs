//! A design job's page: its progress while it runs (the block asks for
//! itself every two seconds, as a run's jobs do, and the page reloads once
//! the job has settled), then the scheme as a table with its duration, the
//! predicted accuracies against the target, the built-in schemes on the
//! same target, and the scheme's JSON to download.

use axum::extract::{Path, State};
use axum::http::{header, HeaderValue};
use axum::response::{Html, IntoResponse, Response};
use maud::{html, Markup};

use super::access::PageCaller;
use super::error::PageError;
use super::format;
use super::layout;
use crate::api::auth::roles;
use crate::api::designs::design_job;
use crate::api::{parse_id, AppState};
use crate::store::{DesignRow, JobId, JobRow, JobState};
use sinscal_core::design::Design;
use sinscal_core::model::PARAMETERS;
use sinscal_core::sim::scheme::Step;

async fn read(st: &AppState, id: String) -> Result<DesignRow, PageError> {
    let id: JobId = parse_id(id, "design")?;
    Ok(design_job(st, id).await?)
}

/// The stored design, parsed; `None` until the job succeeded.
fn parsed(row: &DesignRow) -> Result<Option<Design>, PageError> {
    row.design
        .as_deref()
        .map(serde_json::from_str)
        .transpose()
        .map_err(|e| PageError::from(crate::api::error::ApiError::Internal(e.to_string())))
}

/// Queued or running: the page keeps asking.
fn active(job: &JobRow) -> bool {
    matches!(job.state, JobState::Queued | JobState::Running)
}

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    let row = read(&st, id).await?;
    let design = parsed(&row)?;
    let title = format!("Design {}", format::short_id(row.job.id));
    let body = html! {
        h1 { (title) }
        p.muted { "Asked " (format::time(row.job.created_at)) ". " a href="/design" { "Design another" } }
        (progress_block(&row.job))
        @if let Some(d) = &design { (scheme_section(row.job.id, d)) (accuracy_section(d)) }
        h2 { "Request" }
        pre #request { (row.request) }
    };
    Ok(Html(
        layout::page(&title, Some(&session), body).into_string(),
    ))
}

/// The job's state; while it is queued or running the block asks for
/// itself again every two seconds (htmx). Without JavaScript it is a
/// snapshot with a reload link.
fn progress_block(job: &JobRow) -> Markup {
    let active = active(job);
    let url = format!("/designs/{}/progress", job.id);
    html! {
        section #progress hx-get=[active.then_some(&url)] hx-trigger=[active.then_some("every 2s")] hx-swap="outerHTML" {
            h2 { "Job" }
            table {
                tr {
                    th { "design" }
                    td.job-state data-state=(job.state.as_str()) { (job.state.as_str()) }
                    td {
                        @if !job.state.is_settled() {
                            progress max="1" value=(format!("{:.3}", job.progress)) {}
                            " " (format!("{:.0} %", 100.0 * job.progress))
                            @if let Some(stage) = &job.stage { " · " (stage) }
                        }
                        @if let Some(e) = &job.error { span.problem #design-error { (e) } }
                    }
                }
            }
            @if active { p.muted.noprint { "Updating while the job runs. " a href={ "/designs/" (job.id) } { "Reload" } } }
        }
    }
}

/// The live part of the page (htmx): the job block; once the job has
/// settled, a whole-page reload shows the scheme.
pub async fn progress(
    State(st): State<AppState>,
    _: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Response, PageError> {
    let row = read(&st, id).await?;
    let mut resp = Html(progress_block(&row.job).into_string()).into_response();
    if !active(&row.job) {
        resp.headers_mut()
            .insert("hx-refresh", HeaderValue::from_static("true"));
    }
    Ok(resp)
}

/// One step of the scheme as the table shows it: what, about which axis,
/// the angle, and how long.
fn step_cells(step: &Step) -> (String, String, String, String) {
    match step {
        Step::Dwell { dwell_s } => (
            "dwell".into(),
            String::new(),
            String::new(),
            format!("{dwell_s:.0} s"),
        ),
        Step::Rotate { rotate } => (
            "turn".into(),
            format!("{:?} ({:?})", rotate.axis, rotate.frame()).to_lowercase(),
            format!("{:+.0}°", rotate.angle_deg),
            format!("{} °/s, {} °/s²", rotate.rate_dps, rotate.accel_dps2),
        ),
        Step::Flip { flip } => (
            "turn by hand".into(),
            format!(
                "[{}, {}, {}] (body)",
                flip.axis_b[0], flip.axis_b[1], flip.axis_b[2]
            ),
            format!("{:+.0}°", flip.angle_deg),
            format!("{:.1} s", flip.duration_s),
        ),
    }
}

fn scheme_section(id: JobId, d: &Design) -> Markup {
    let (dwells, turns) = d.scheme.counts();
    html! {
        h2 { "Scheme " code { (d.scheme.name) } }
        p #scheme-summary {
            (dwells) " dwells, " (turns) " turns, " strong { (format!("{:.0} s", d.duration_s)) }
            (format!(" ({:.2} h)", d.duration_s / 3600.0)) "; target " (d.target) " with margin " (d.margin)
            @if d.by_hand { ", turned by hand" }
            ". " a #scheme-download href={ "/designs/" (id) "/scheme.json" } download { "Download the scheme (JSON)" }
        }
        div.scroll { table #scheme {
            tr { th.num { "#" } th { "Step" } th { "Axis" } th.num { "Angle" } th { "Dwell, or turn rate" } }
            @for (i, step) in d.scheme.steps.iter().enumerate() {
                @let (what, axis, angle, how) = step_cells(step);
                tr { td.num { (i + 1) } td { (what) } td { (axis) } td.num { (angle) } td { (how) } }
            }
        } }
    }
}

fn accuracy_section(d: &Design) -> Markup {
    html! {
        h2 { "Predicted accuracy against the target" }
        p.muted { "Predicted 1-σ of each parameter, its target, and σ × margin / target (at most 1: met). Binding: " (d.binding.join(", ")) "." }
        div.scroll { table #predicted {
            tr { th { "Parameter" } th.num { "σ" } th.num { "Target" } th.num { "Ratio" } th { "Unit" } }
            @for p in PARAMETERS.iter() {
                @if let Some(q) = d.parameters.get(p.name) {
                    tr class=[(q.ratio > 1.0).then_some("fail")] {
                        td { (p.name) } td.num { (format::sig(q.sigma, 3)) } td.num { (format::sig(q.target, 3)) }
                        td.num { (format!("{:.2}", q.ratio)) } td { (q.unit) }
                    }
                }
            }
        } }
        @for o in &d.detect { p { (o.describe()) } }
        h3 { "Built-in schemes on the same target" }
        table #comparisons {
            tr { th { "Scheme" } th.num { "Dwell needed" } th.num { "Duration" } th.num { "Worst ratio at 600 s dwells" } }
            @for c in &d.comparisons {
                tr {
                    td { (c.scheme) }
                    td.num { @if let Some(s) = c.dwell_s { (format!("{s:.0} s")) } @else { "not reached" } }
                    td.num { @if let Some(s) = c.duration_s { (format!("{s:.0} s")) } @else { "—" } }
                    td.num { (format!("{:.2}", c.worst_ratio_at_600_s)) }
                }
            }
        }
    }
}

/// `/designs/{id}/scheme.json`: the designed scheme, SPEC §4 JSON, as an
/// attachment (what `sinscal simulate --scheme` and a run's metadata take).
pub async fn download(
    State(st): State<AppState>,
    _: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Response, PageError> {
    let row = read(&st, id).await?;
    let design = parsed(&row)?
        .ok_or_else(|| PageError::not_found(format!("design {} has no scheme yet", row.job.id)))?;
    let body = serde_json::to_string_pretty(&design.scheme)
        .map_err(|e| PageError::from(crate::api::error::ApiError::Internal(e.to_string())))?;
    let mut resp = ([(header::CONTENT_TYPE, "application/json")], body).into_response();
    let attachment = format!(
        "attachment; filename=\"{}-{}.json\"",
        design.scheme.name,
        format::short_id(row.job.id)
    );
    if let Ok(v) = HeaderValue::from_str(&attachment) {
        resp.headers_mut().insert(header::CONTENT_DISPOSITION, v);
    }
    Ok(resp)
}
