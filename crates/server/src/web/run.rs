//! A run's page: what was uploaded, its job's progress (live while it
//! runs), the verdict (or what it waits for) to every role that reads the
//! run, and to engineers once calibrated the 24 parameters (and effect
//! parameters) against the product's limits, the model check, the
//! cross-check, the convergence plots (the seed paper's Fig. 3), the
//! per-dwell residuals, downloads, and the actions the session's role may
//! take.

use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderValue};
use axum::response::{Html, IntoResponse, Response};
use axum::Form;
use maud::{html, Markup};

use super::access::{FormCaller, PageCaller};
use super::error::PageError;
use super::format;
use super::layout::{self, action_button};
use super::run_plots::{convergence_charts, residual_chart};
use super::run_verdict::{pending_verdict, verdict_block};
use super::session::{see_other, CsrfForm};
use crate::api::adopt::adopt_latest_diagnosis;
use crate::api::auth::roles::{self, Implies};
use crate::api::compensation::{compensation_of, override_of};
use crate::api::runs::{queue_diagnosis, queue_recalibration, remove_run};
use crate::api::{parse_id, AppState};
use crate::store::{JobRow, ResultVersion, RunId, RunRow, StoredVerdict};
use sinscal_core::accept::{LimitKind, ParameterCheck, ProductLimits, Verdict, VerdictStatus};
use sinscal_core::calib::result::UnseenWanderReport;
use sinscal_core::calib::CalibrationResult;
use sinscal_core::model::PARAMETERS;

/// The run of a path's `id` if the session may read it (a station: its
/// own uploads only, as in the API; others read as 404). The role was
/// checked by the caller's type (any set within [`roles::FOLLOW`]); the
/// id is parsed here, after it, as the API parses it: a malformed one is
/// the 404 of an unknown one.
pub(super) async fn readable_run<P: Implies<roles::Follow>>(
    st: &AppState,
    session: &PageCaller<P>,
    id: String,
) -> Result<RunRow, PageError> {
    let id: RunId = parse_id(id, "run")?;
    Ok(crate::api::runs::readable_run(st, &session.auth, id).await?)
}

/// The run's result, parsed (a few hundred kB of JSON, mostly the
/// convergence history: off the async workers).
pub(super) async fn parsed_result(
    st: &AppState,
    id: RunId,
) -> Result<Option<CalibrationResult>, PageError> {
    let Some(json) = st.store.get_result(id).await? else {
        return Ok(None);
    };
    tokio::task::spawn_blocking(move || {
        json.parse().map(Some).map_err(|e| {
            PageError::from(crate::api::error::ApiError::Internal(format!(
                "stored result of run {id}: {e}"
            )))
        })
    })
    .await
    .map_err(|e| {
        PageError::from(crate::api::error::ApiError::Internal(format!(
            "result task: {e}"
        )))
    })?
}

/// The limits of the product a run names, when its type exists.
pub(super) async fn product_limits(
    st: &AppState,
    verdict: Option<&StoredVerdict>,
) -> Result<Option<ProductLimits>, PageError> {
    let Some(name) = verdict.and_then(|v| v.product.as_deref()) else {
        return Ok(None);
    };
    match st.store.get_product_type(name).await? {
        Some(row) => Ok(Some(row.parsed_limits()?)),
        None => Ok(None),
    }
}

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Follow>,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let meta = run.file.metadata.parse().ok();
    let jobs = run_jobs(&st, &run).await?;
    let engineer = roles::ENGINEER.contains(&session.role());
    let result = if engineer {
        parsed_result(&st, run.id).await?
    } else {
        None
    };
    let verdict = run.verdict()?;
    let limits = product_limits(&st, verdict.as_ref()).await?;
    let versions = st.store.result_versions(run.id).await?;
    let body = html! {
        h1 { "Run " code { (format::short_id(run.id)) } " of unit "
            @if engineer { a href={ "/units/" (run.unit_serial) } { (run.unit_serial) } } @else { (run.unit_serial) } }
        dl.facts {
            dt { "Run id" } dd { code { (run.id) } }
            dt { "Recorded" } dd { (format::time(run.run_time)) }
            dt { "Uploaded" } dd { (format::time(run.uploaded_at)) }
            @if let Some(m) = &meta {
                dt { "Station" } dd { (m.station.as_deref().unwrap_or("—")) }
                dt { "Operator" } dd { (m.operator.as_deref().unwrap_or("—")) }
                dt { "Product" } dd { (m.product.as_deref().unwrap_or("—")) }
                dt { "Data" } dd { (run.file.records) " records at " (m.sample_rate_hz) " Hz, " (run.file.format) @if run.file.gzip { " (gzip)" } ", " (run.file.size_bytes) " bytes" }
            }
            dt { "sha256" } dd { code { (run.file.sha256) } }
            @if let Some(r) = &result {
                dt { "Model" } dd #run-model { (r.model)
                    @if let (Some(_), Some(at)) = (&run.model, run.model_adopted_at) { " (adopted from its diagnosis " (format::time(at)) ")" } }
            }
        }
        @if engineer { (earlier_results(run.id, &versions)) }
        (progress_block(&run, &jobs))
        @if engineer {
            div.actions {
                @if let Some(d) = &jobs.diagnose { a href={ "/runs/" (run.id) "/diagnosis" } { "Diagnosis (" (d.state.as_str()) ")" } }
                a href={ "/runs/" (run.id) "/noise" } { "Noise analysis" }
                (action_button(&session, &format!("/runs/{}/diagnose", run.id), "Diagnose", ""))
                (action_button(&session, &format!("/runs/{}/calibrate", run.id), "Calibrate again", ""))
                @if let Some(w) = result.as_ref().and_then(proposed_wander) {
                    span.proposal #unseen-wander { "The run asks for " (w.term) " its dwells do not show (ln L +" (format!("{:.0}", w.gain_ln_l)) "); if the diagnosis names no effect:" }
                    (action_button(&session, &format!("/runs/{}/fit-wander", run.id), "Calibrate again, fitting the wander", ""))
                }
                @if roles::ADMIN.contains(&session.role()) {
                    (action_button(&session, &format!("/runs/{}/delete", run.id), "Delete run", "danger"))
                }
            }
        }
        @if run.calibrated { (verdict_block(verdict.as_ref())) }
        @else { (pending_verdict(&run)) }
        @if let Some(r) = &result {
            div.actions {
                "Download: "
                a href={ "/runs/" (run.id) "/files/result.json" } download { "result JSON" }
                a href={ "/runs/" (run.id) "/files/result.csv" } download { "result CSV" }
                @if accepted(verdict.as_ref()) {
                    a href={ "/runs/" (run.id) "/files/compensation.json" } download { "compensation JSON" }
                    a href={ "/runs/" (run.id) "/files/compensation.csv" } download { "compensation CSV" }
                }
                a href={ "/runs/" (run.id) "/certificate" } { "certificate" }
            }
            @if !accepted(verdict.as_ref()) { (override_form(run.id)) }
            h2 { "Parameters" }
            (parameter_table(r, limits.as_ref(), verdict.as_ref().map(|v| &v.verdict)))
            (checks(r))
            h2 { "Convergence" }
            p.muted { "Each parameter's estimate ± 1σ over the run (the filter's last pass), by family." }
            (convergence_charts(r))
            h2 { "Residual per dwell" }
            (residual_chart(r))
        }
    };
    Ok(Html(
        layout::page(
            &format!("Run {}", format::short_id(run.id)),
            Some(&session),
            body,
        )
        .into_string(),
    ))
}

/// The run's calibration job and its latest diagnose job.
pub(super) struct RunJobs {
    calibrate: Option<JobRow>,
    diagnose: Option<JobRow>,
}

impl RunJobs {
    fn active(&self) -> bool {
        [&self.calibrate, &self.diagnose]
            .into_iter()
            .flatten()
            .any(|j| !j.state.is_settled() && j.state != crate::store::JobState::Cancelled)
    }
}

async fn run_jobs(st: &AppState, run: &RunRow) -> Result<RunJobs, PageError> {
    Ok(RunJobs {
        calibrate: st.store.get_job(run.job_id).await?,
        diagnose: st.store.latest_diagnose_job(run.id).await?,
    })
}

/// The jobs' states; while one is queued or running the block asks for
/// itself again every two seconds (htmx), and the page reloads once all
/// have settled. Without JavaScript it is a snapshot with a reload link.
fn progress_block(run: &RunRow, jobs: &RunJobs) -> Markup {
    let active = jobs.active();
    let url = format!("/runs/{}/progress", run.id);
    html! {
        section #progress hx-get=[active.then_some(&url)] hx-trigger=[active.then_some("every 2s")] hx-swap="outerHTML" {
            h2 { "Jobs" }
            table {
                @for (what, job) in [("calibration", &jobs.calibrate), ("diagnosis", &jobs.diagnose)] {
                    @if let Some(j) = job {
                        tr {
                            th { (what) }
                            td.job-state data-state=(j.state.as_str()) { (j.state.as_str()) }
                            td {
                                @if !j.state.is_settled() {
                                    progress max="1" value=(format!("{:.3}", j.progress)) {}
                                    " " (format!("{:.0} %", 100.0 * j.progress))
                                    @if let Some(stage) = &j.stage { " · " (stage) }
                                }
                                @if let Some(e) = &j.error { span.problem { (e) } }
                            }
                        }
                    }
                }
            }
            @if active { p.muted.noprint { "Updating while the job runs. " a href={ "/runs/" (run.id) } { "Reload" } } }
        }
    }
}

/// The live part of the run page (htmx): the jobs block; once nothing is
/// running, a whole-page reload shows the result.
pub async fn progress(
    State(st): State<AppState>,
    session: PageCaller<roles::Follow>,
    Path(id): Path<String>,
) -> Result<Response, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let jobs = run_jobs(&st, &run).await?;
    let mut resp = Html(progress_block(&run, &jobs).into_string()).into_response();
    if !jobs.active() {
        resp.headers_mut()
            .insert("hx-refresh", HeaderValue::from_static("true"));
    }
    Ok(resp)
}

fn accepted(verdict: Option<&StoredVerdict>) -> bool {
    verdict.is_some_and(|v| v.verdict.status() == VerdictStatus::Accepted)
}

/// The compensation file of a run that is not accepted: released on a
/// stated reason, which the file records with the verdict.
fn override_form(id: RunId) -> Markup {
    let file = |form: &str| format!("/runs/{id}/files/compensation.{form}");
    html! {
        form #compensation-override method="get" action=(file("json")) {
            label for="override" { "Compensation file of a run that is not accepted — reason (recorded in the file): " }
            input #override type="text" name="override" required maxlength="300";
            button type="submit" { "JSON" }
            button type="submit" formaction=(file("csv")) { "CSV" }
        }
    }
}

/// The style of a parameter's check: an unverified value is marked as
/// doubtful, not as passed.
fn check_class(c: ParameterCheck) -> &'static str {
    match c {
        ParameterCheck::Pass => "pass",
        ParameterCheck::Fail => "fail",
        ParameterCheck::Unverified => "unverified",
        ParameterCheck::NoLimit => "muted",
    }
}

fn limit_text(limits: Option<&ProductLimits>, i: usize, kind: LimitKind) -> String {
    limits
        .and_then(|l| l.of(i).get(kind))
        .map_or_else(|| "—".into(), |v| format::sig(v, 3))
}

/// The 24 parameters with σ, the product's limits and pass/fail as the
/// verdict judged them, then any effect parameters.
pub(super) fn parameter_table(
    r: &CalibrationResult,
    limits: Option<&ProductLimits>,
    verdict: Option<&Verdict>,
) -> Markup {
    let check = |name: &str, limited: bool| {
        verdict.map_or(ParameterCheck::NoLimit, |v| {
            v.parameter_check(name, limited)
        })
    };
    html! {
        table #parameters {
            thead { tr {
                th { "Parameter" } th.num { "Value" } th.num { "1σ" } th { "Unit" }
                th.num { "Limit |value|" } th.num { "Limit σ" } th { "Check" }
            } }
            tbody {
                @for (i, p) in PARAMETERS.iter().enumerate() {
                    @if let Some(e) = r.parameters.get(p.name) {
                        @let c = check(p.name, limits.is_some_and(|l| !l.of(i).is_empty()));
                        tr class=[(c == ParameterCheck::Fail).then_some("fail")] {
                            td { (p.name) }
                            td.num { (format::sig(e.value, 6)) }
                            td.num { (format::sig(e.sigma, 3)) }
                            td { (e.unit) }
                            td.num { (limit_text(limits, i, LimitKind::MaxAbsValue)) }
                            td.num { (limit_text(limits, i, LimitKind::MaxSigma)) }
                            td { span class=(check_class(c)) { (c.as_str()) } }
                        }
                    }
                }
            }
        }
        @if !r.effects.is_empty() {
            h3 { "Effect parameters (" (r.model) ")" }
            table #effects {
                tr { th { "Parameter" } th.num { "Value" } th.num { "1σ" } th { "Unit" } }
                @for (name, e) in &r.effects {
                    tr { td { (name) } td.num { (format::sig(e.value, 5)) } td.num { (format::sig(e.sigma, 3)) } td { (e.unit) } }
                }
            }
        }
        @if let Some(t) = &r.thermal {
            h3 { "Temperature coefficients (in-run, " (format::sig(t.range_c[0], 3)) "–" (format::sig(t.range_c[1], 3)) " °C)" }
            p.muted { "The parameters above are at 25 °C; each moves by its coefficient per °C, and the gyro biases by k times the rate of change of temperature." }
            table #thermal-coefficients {
                tr { th { "Parameter" } th.num { "Per °C" } th.num { "1σ" } th { "Unit" } }
                @for p in PARAMETERS.iter() {
                    @if let Some(l) = t.parameters.get(p.name).and_then(|e| e.linear) {
                        tr { td { (p.name) } td.num { (format::sig(l.value, 4)) } td.num { (format::sig(l.sigma, 3)) } td { (p.unit) "/°C" } }
                    }
                }
                @for (axis, k) in &t.gyro_bias_rate {
                    tr { td { "gyro_bias_rate_" (axis) } td.num { (format::sig(k.value, 4)) } td.num { (format::sig(k.sigma, 3)) } td { "deg/h per °C/min" } }
                }
            }
        }
    }
}

/// The model check, warnings, and the least-squares cross-check.
fn checks(r: &CalibrationResult) -> Markup {
    html! {
        h2 { "Model check" }
        @match &r.model_check {
            Some(c) => {
                p #model-check { @if c.adequate { span.pass { "adequate" } } @else { span.fail { "inadequate" } } " — " (c.summary) }
                p.muted { "χ² = " (format::sig(c.statistic, 4)) " against " (format::sig(c.threshold, 4)) " (" (c.dof) " scores); largest |z| " (format::sig(c.largest_z, 3)) " against " (format::sig(c.largest_z_threshold, 3)) "." }
                @if !c.findings.is_empty() {
                    table #findings {
                        tr { th { "Where" } th { "Axis" } th.num { "z" } th.num { "From (s)" } th.num { "To (s)" } }
                        @for f in c.findings.iter().take(10) {
                            tr { td { (serde_json::to_string(&f.shape).unwrap_or_default().trim_matches('"')) @if let Some(d) = f.dwell { " dwell " (d) } }
                                 td { (serde_json::to_string(&f.axis).unwrap_or_default().trim_matches('"')) }
                                 td.num { (format::sig(f.z, 3)) } td.num { (format::sig(f.t_start, 5)) } td.num { (format::sig(f.t_end, 5)) } }
                        }
                    }
                }
            }
            None => p.muted { "This result predates the model check." },
        }
        @if !r.warnings.is_empty() {
            h3 { "Warnings" }
            ul #warnings { @for w in &r.warnings { li { (w) } } }
        }
        @if let Some(c) = &r.cross_check {
            h2 { "Cross-check (" (c.method) ")" }
            @if c.flagged.is_empty() { p { "The filter and the least squares agree on every parameter within 3 combined σ." } }
            @else { p.fail { "They differ on: " (c.flagged.join(", ")) } }
            details {
                summary { "Every parameter" }
                table #cross-check {
                    tr { th { "Parameter" } th.num { "Filter" } th.num { "Least squares" } th.num { "σ (LSQ)" } th.num { "Difference in σ" } }
                    @for e in &c.entries {
                        tr class=[e.flagged.then_some("flag")] { td { (e.name) } td.num { (format::sig(e.kf, 5)) } td.num { (format::sig(e.lsq, 5)) } td.num { (format::sig(e.lsq_sigma, 3)) } td.num { (format::sig(e.normalized_difference, 2)) } }
                    }
                }
            }
        }
    }
}

/// The results the run had before its current one (a model adopted, a
/// calibration asked for again): each kept, with the model it was made
/// with, and readable through the API.
fn earlier_results(run_id: RunId, versions: &[ResultVersion]) -> Markup {
    let earlier: Vec<&ResultVersion> = versions.iter().filter(|v| !v.is_current()).collect();
    html! {
        @if !earlier.is_empty() {
            section #earlier-results {
                h2 { "Earlier results" }
                table {
                    tr { th { "No." } th { "Model" } th { "Completed" } th { "Replaced" } th { "Verdict then" } th { "API" } }
                    @for v in &earlier {
                        tr { td.num { (v.seq) } td { (v.model.as_deref().unwrap_or("—")) } td { (format::time(v.completed_at)) }
                             td { (v.superseded_at.map(format::time).unwrap_or_default()) } td { (v.verdict.as_deref().unwrap_or("—")) }
                             td { code { "/api/v1/runs/" (run_id) "/results/" (v.seq) } } }
                    }
                }
            }
        }
    }
}

/// The wander the current result proposes to fit (its white model
/// stands, its run asked for wander), if any.
fn proposed_wander(r: &CalibrationResult) -> Option<&UnseenWanderReport> {
    let w = r.noise_model.as_ref()?.unseen_wander.as_ref()?;
    (!w.fitted).then_some(w)
}

/// What the run page's buttons do, and who may.
#[derive(Clone, Copy, Debug)]
enum RunAction {
    Diagnose,
    /// Adopt the latest diagnosis: calibrate again with its named effects.
    Adopt,
    Calibrate,
    /// Calibrate again fitting the wander the result proposed
    /// (`fit_unseen_wander`, kept on the run).
    FitWander,
    Delete,
}

impl RunAction {
    fn named(name: &str) -> Option<RunAction> {
        match name {
            "diagnose" => Some(RunAction::Diagnose),
            "adopt" => Some(RunAction::Adopt),
            "calibrate" => Some(RunAction::Calibrate),
            "fit-wander" => Some(RunAction::FitWander),
            "delete" => Some(RunAction::Delete),
            _ => None,
        }
    }

    /// Whether `session` may take this action: the roles depend on the
    /// action, so they are checked here, once it is known, by narrowing
    /// the caller (the same check the extractors make).
    fn allowed(self, session: &PageCaller<roles::Follow>) -> Result<(), PageError> {
        match self {
            RunAction::Diagnose
            | RunAction::Adopt
            | RunAction::Calibrate
            | RunAction::FitWander => {
                session.narrow::<roles::Engineer>()?;
            }
            RunAction::Delete => {
                session.narrow::<roles::Admin>()?;
            }
        }
        Ok(())
    }
}

/// `POST /runs/{id}/{diagnose|adopt|calibrate|fit-wander|delete}`: the button's action,
/// through the API's own function, then back to the run (or, once
/// deleted, to its unit). The action is named first (404 for any other
/// name), then the form's CSRF token is checked, then the action's role.
pub async fn action(
    State(st): State<AppState>,
    sender: FormCaller<roles::Follow>,
    Path((id, name)): Path<(String, String)>,
    Form(form): Form<CsrfForm>,
) -> Result<Response, PageError> {
    let action = RunAction::named(&name)
        .ok_or_else(|| PageError::not_found(format!("no run action {name:?}")))?;
    let session = sender.check_csrf(&form.csrf)?;
    action.allowed(&session)?;
    let run = readable_run(&st, &session, id).await?;
    match action {
        RunAction::Diagnose => {
            queue_diagnosis(&st, run.id).await?;
        }
        RunAction::Adopt => {
            adopt_latest_diagnosis(&st, run.id, &session.auth.token_id).await?;
        }
        RunAction::Calibrate => {
            queue_recalibration(&st, run.id, None).await?;
        }
        RunAction::FitWander => {
            queue_recalibration(&st, run.id, Some(true)).await?;
        }
        RunAction::Delete => {
            remove_run(&st, run.id).await?;
            return Ok(see_other(&format!("/units/{}", run.unit_serial)));
        }
    }
    Ok(see_other(&format!("/runs/{}", run.id)))
}

/// The run's files the page offers for download.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RunFile {
    ResultJson,
    ResultCsv,
    CompensationJson,
    CompensationCsv,
}

impl RunFile {
    const ALL: [(&'static str, RunFile); 4] = [
        ("result.json", RunFile::ResultJson),
        ("result.csv", RunFile::ResultCsv),
        ("compensation.json", RunFile::CompensationJson),
        ("compensation.csv", RunFile::CompensationCsv),
    ];

    fn named(name: &str) -> Option<(&'static str, RunFile)> {
        RunFile::ALL.into_iter().find(|(n, _)| *n == name)
    }
}

/// A download's query: the reason that releases the compensation file of
/// a run that is not accepted.
#[derive(Debug, serde::Deserialize)]
pub struct DownloadQuery {
    #[serde(default, rename = "override")]
    override_reason: Option<String>,
}

/// `/runs/{id}/files/{name}`: the result (JSON as the API answers it, or
/// CSV: one row per parameter, the 24 then effects) or the compensation
/// file (JSON or CSV), as an attachment named for the unit and run.
/// Engineers and admins only, checked once the file is named: an unknown
/// file is 404 to every caller.
pub async fn download(
    State(st): State<AppState>,
    session: PageCaller<roles::Follow>,
    Path((id, name)): Path<(String, String)>,
    Query(q): Query<DownloadQuery>,
) -> Result<Response, PageError> {
    let (name, file) = RunFile::named(&name)
        .ok_or_else(|| PageError::not_found(format!("no run file {name:?}")))?;
    let session = session.narrow::<roles::Engineer>()?;
    let run = readable_run(&st, &session, id).await?;
    let (content_type, body) = match file {
        RunFile::ResultJson => (
            "application/json",
            crate::api::runs::result_document(&st, run.id).await?,
        ),
        RunFile::ResultCsv => {
            let r = parsed_result(&st, run.id)
                .await?
                .ok_or_else(|| PageError::not_found(format!("run {} has no result yet", run.id)))?;
            ("text/csv", result_csv(&r))
        }
        RunFile::CompensationJson | RunFile::CompensationCsv => {
            let overridden = override_of(session.caller(), q.override_reason.as_deref())?;
            let c = compensation_of(&st, run.id, overridden).await?;
            if file == RunFile::CompensationJson {
                ("application/json", c.to_json())
            } else {
                ("text/csv", c.to_csv())
            }
        }
    };
    let mut resp = ([(header::CONTENT_TYPE, content_type)], body).into_response();
    let attachment = format!(
        "attachment; filename=\"{}-{}-{name}\"",
        run.unit_serial,
        format::short_id(run.id)
    );
    if let Ok(v) = HeaderValue::from_str(&attachment) {
        resp.headers_mut().insert(header::CONTENT_DISPOSITION, v);
    }
    Ok(resp)
}

fn result_csv(r: &CalibrationResult) -> String {
    let mut csv = String::from("parameter,value,sigma,unit\n");
    for p in PARAMETERS.iter() {
        if let Some(e) = r.parameters.get(p.name) {
            csv.push_str(&format!("{},{},{},{}\n", p.name, e.value, e.sigma, e.unit));
        }
    }
    for (name, e) in &r.effects {
        csv.push_str(&format!("{name},{},{},{}\n", e.value, e.sigma, e.unit));
    }
    csv
}
