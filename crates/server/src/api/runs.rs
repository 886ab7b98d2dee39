//! Runs: read one, its result, delete one; queue its diagnosis or its
//! calibration again, and read the latest report. (Uploads are in
//! `upload`.) The actions are functions the pages call too.

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::{Deserialize, Serialize};

use super::auth::{roles, Auth, Caller};
use super::error::ApiError;
use super::jobs::JobView;
use super::json_object::JsonObject;
use super::upload::queue_full;
use super::{parse_id, refuse_while_stopping, rfc3339, AppState};

use crate::store::{
    CalibrationRequeued, DiagnoseQueued, JobId, JobRow, Review, RunDeletion, RunId, RunRow, Stored,
    StoredVerdict,
};
use sinscal_core::accept::Verdict;
use sinscal_core::diagnose::DiagnoseReport;
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::UnitSerial;

#[derive(Serialize)]
pub struct RunView {
    pub id: RunId,
    pub unit_serial: UnitSerial,
    pub job_id: JobId,
    pub sha256: String,
    pub size_bytes: i64,
    pub records: i64,
    pub format: DataFormat,
    pub gzip: bool,
    pub uploaded_at: String,
    pub recorded_at: Option<String>,
    pub run_time: String,
    pub metadata: serde_json::Value,
    /// `pending` until calibrated; `needs_review` when the result's model
    /// check found a misfit the 24 parameters cannot explain.
    pub review: Review,
    /// The result's model check in brief, once there is a result.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_check: Option<ModelCheckBrief>,
    /// The result's verdict, once there is a result.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verdict: Option<VerdictView>,
}

/// A verdict as the run, result, history and unit views show it:
/// `status`, `failed`, `reasons` (CONTRACT §6a), and what it was judged on.
#[derive(Serialize)]
pub struct VerdictView {
    #[serde(flatten)]
    pub verdict: Verdict,
    /// The run judged.
    pub run_id: RunId,
    /// The product its metadata names (null: none, no limits applied).
    pub product: Option<String>,
    /// The product type's revision applied (null: no product type).
    pub product_revision: Option<i64>,
    /// When the stored verdict last changed.
    pub judged_at: String,
}

impl From<StoredVerdict> for VerdictView {
    fn from(v: StoredVerdict) -> Self {
        VerdictView {
            verdict: v.verdict,
            run_id: v.run_id,
            product: v.product,
            product_revision: v.revision,
            judged_at: rfc3339(v.judged_at),
        }
    }
}

/// A model check as run and history views show it; the whole check is in
/// the result.
#[derive(Serialize)]
pub struct ModelCheckBrief {
    pub adequate: bool,
    pub summary: String,
}

impl ModelCheckBrief {
    pub fn from_columns(adequate: Option<bool>, summary: Option<String>) -> Option<Self> {
        Some(ModelCheckBrief {
            adequate: adequate?,
            summary: summary.unwrap_or_default(),
        })
    }
}

impl RunView {
    fn from_row(r: RunRow) -> Result<Self, ApiError> {
        let verdict = r.verdict()?.map(VerdictView::from);
        Ok(RunView {
            verdict,
            metadata: serde_json::from_str(r.file.metadata.as_json())
                .map_err(|e| ApiError::Internal(e.to_string()))?,
            id: r.id,
            unit_serial: r.unit_serial,
            job_id: r.job_id,
            sha256: r.file.sha256,
            size_bytes: r.file.size_bytes,
            records: r.file.records,
            format: r.file.format,
            gzip: r.file.gzip,
            uploaded_at: rfc3339(r.uploaded_at),
            recorded_at: r.recorded_at.map(rfc3339),
            run_time: rfc3339(r.run_time),
            review: Review::of(r.calibrated, r.model_adequate),
            model_check: ModelCheckBrief::from_columns(r.model_adequate, r.model_summary),
        })
    }
}

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/runs/{id}", get(get_run).delete(delete_run))
        .route("/runs/{id}/result", get(get_result))
        .route("/runs/{id}/diagnose", post(diagnose_run))
        .route("/runs/{id}/calibrate", post(recalibrate_run))
        .route("/runs/{id}/diagnosis", get(get_diagnosis))
        .route("/runs/{id}/diagnosis/gap.svg", get(get_diagnosis_gap_svg))
}

/// The run `id`, or a 404 naming it (for the readers of every run).
pub(crate) async fn stored_run(st: &AppState, id: RunId) -> Result<RunRow, ApiError> {
    st.store
        .get_run(id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no run {id}")))
}

async fn get_run(
    State(st): State<AppState>,
    auth: Caller<roles::Follow>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<RunView>, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let run = readable_run(&st, &auth, id).await?;
    Ok(Json(RunView::from_row(run)?))
}

/// The run `id` if `auth` may read it (the API's run view and every page
/// of a run): a station reads only its own uploads, and any other run is
/// 404 to it, as an unknown one is.
pub(crate) async fn readable_run(
    st: &AppState,
    auth: &Auth,
    id: RunId,
) -> Result<RunRow, ApiError> {
    st.store
        .get_run(id)
        .await?
        .filter(|r| auth.may_read_run(r.uploaded_by.as_deref()))
        .ok_or_else(|| ApiError::NotFound(format!("no run {id}")))
}

async fn get_result(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let json = result_document(&st, id).await?;
    Ok(([(header::CONTENT_TYPE, "application/json")], json).into_response())
}

/// A run's result document with its verdict (the API's answer and the run
/// page's download); 409 while the run has none.
pub(crate) async fn result_document(st: &AppState, id: RunId) -> Result<String, ApiError> {
    let run = stored_run(st, id).await?;
    if let Some(json) = st.store.get_result(id).await? {
        // Stored as serialized by the estimator's own types: served as is,
        // with the verdict (which changes with the limits) put in front.
        let verdict = run.verdict()?.map(VerdictView::from);
        return with_verdict(json.into_json(), verdict.as_ref());
    }
    let state = st
        .store
        .get_job(run.job_id)
        .await?
        .map_or("unknown", |j| j.state.as_str());
    Err(ApiError::Conflict(format!(
        "run {id} has no result: its job {} is {state}",
        run.job_id
    )))
}

/// A stored result document (a JSON object) with `"verdict"` as its first
/// member, without parsing the document (most of it is the convergence
/// history).
fn with_verdict(doc: String, verdict: Option<&VerdictView>) -> Result<String, ApiError> {
    let Some(verdict) = verdict else {
        return Ok(doc);
    };
    let body = doc
        .trim_start()
        .strip_prefix('{')
        .ok_or_else(|| ApiError::Internal("a stored result is not a JSON object".into()))?;
    let verdict = serde_json::to_string(verdict).map_err(|e| ApiError::Internal(e.to_string()))?;
    let sep = if body.trim_start().starts_with('}') {
        ""
    } else {
        ","
    };
    Ok(format!("{{\"verdict\":{verdict}{sep}{body}"))
}

async fn delete_run(
    State(st): State<AppState>,
    _: Caller<roles::Admin>,
    path: Result<Path<String>, PathRejection>,
) -> Result<StatusCode, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    remove_run(&st, id).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Deletes a run, its file and everything derived from it (the API's
/// DELETE and the run page's button).
pub(crate) async fn remove_run(st: &AppState, id: RunId) -> Result<(), ApiError> {
    match st.store.delete_run(id).await? {
        RunDeletion::Deleted { blob_path } => {
            // The rows are gone first: a crash before this line, or a
            // failed delete, leaves orphan bytes, which the sweep removes.
            if let Err(e) = st.run_store.remove(&blob_path).await {
                tracing::warn!(run = %id, error = %e, "run file left for the sweep");
            }
            tracing::info!(run = %id, "run deleted");
            Ok(())
        }
        RunDeletion::NoRun => Err(ApiError::NotFound(format!("no run {id}"))),
        RunDeletion::JobBusy(state) => Err(ApiError::Conflict(format!(
            "run {id}'s job is {state}: cancel it and wait for it to stop first"
        ))),
    }
}

/// A job answer: the job, with its URL in `Location`.
pub(crate) fn job_answer(status: StatusCode, job: JobRow) -> Response {
    let url = format!("/api/v1/jobs/{}", job.id);
    let mut resp = (status, Json(JobView::from(job))).into_response();
    if let Ok(v) = HeaderValue::from_str(&url) {
        resp.headers_mut().insert(header::LOCATION, v);
    }
    resp
}

/// Queues the discrepancy workflow for a run (202), or returns the diagnose
/// job already queued or running for it (200) so that repeated requests do
/// not stack up copies of a minutes-long job.
async fn diagnose_run(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let queued = queue_diagnosis(&st, id).await?;
    let status = if queued.created {
        StatusCode::ACCEPTED
    } else {
        StatusCode::OK
    };
    Ok(job_answer(status, queued.job))
}

/// What a request to calibrate a run again may change (the body may be
/// left out).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrateAgain {
    /// Fit a bias wander the run's dwells do not show
    /// (`EstimateOptions::fit_unseen_wander`), kept for the run's later
    /// calibrations; absent: as before.
    #[serde(default)]
    fit_unseen_wander: Option<bool>,
}

/// Queues the run's calibration again (202), replacing its result when it
/// has one; 409 while its calibration is queued or running.
async fn recalibrate_run(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    body: Option<JsonObject<CalibrateAgain>>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let again = body.map(|b| b.0).unwrap_or_default();
    let job = queue_recalibration(&st, id, again.fit_unseen_wander).await?;
    Ok(job_answer(StatusCode::ACCEPTED, job))
}

/// A job a run action queued, or the one it found already waiting.
pub(crate) struct QueuedJob {
    pub job: JobRow,
    pub created: bool,
}

/// Queues a diagnosis of a run unless one is queued or running already.
pub(crate) async fn queue_diagnosis(st: &AppState, id: RunId) -> Result<QueuedJob, ApiError> {
    refuse_while_stopping(st)?;
    match st
        .store
        .queue_diagnose_job(
            id,
            JobId::new(),
            st.config.max_attempts,
            st.config.max_queue,
        )
        .await?
    {
        DiagnoseQueued::Created(job) => {
            st.wake.notify_one();
            tracing::info!(run = %id, job = %job.id, "diagnosis queued");
            Ok(QueuedJob { job, created: true })
        }
        DiagnoseQueued::Existing(job) => Ok(QueuedJob {
            job,
            created: false,
        }),
        DiagnoseQueued::NoRun => Err(ApiError::NotFound(format!("no run {id}"))),
        DiagnoseQueued::QueueFull => Err(queue_full()),
    }
}

/// Queues a run's calibration again, with the fit of unseen wander
/// changed when `fit_unseen_wander` says so.
pub(crate) async fn queue_recalibration(
    st: &AppState,
    id: RunId,
    fit_unseen_wander: Option<bool>,
) -> Result<JobRow, ApiError> {
    refuse_while_stopping(st)?;
    let requeued = st
        .store
        .requeue_calibration(
            id,
            fit_unseen_wander,
            st.config.max_attempts,
            st.config.max_queue,
        )
        .await?;
    let job = calibration_queued(st, id, requeued)?;
    tracing::info!(run = %id, job = %job.id, "calibration queued again");
    Ok(job)
}

/// A run's calibration queued again (the workers woken), or why not: the
/// answer of every action that calibrates a run again.
pub(crate) fn calibration_queued(
    st: &AppState,
    id: RunId,
    requeued: CalibrationRequeued,
) -> Result<JobRow, ApiError> {
    match requeued {
        CalibrationRequeued::Queued(job) => {
            st.wake.notify_one();
            Ok(job)
        }
        CalibrationRequeued::Busy(job) => Err(ApiError::Conflict(format!(
            "run {id}'s calibration job {} is {}: wait for it to settle first",
            job.id, job.state
        ))),
        CalibrationRequeued::NoRun => Err(ApiError::NotFound(format!("no run {id}"))),
        CalibrationRequeued::QueueFull => Err(queue_full()),
    }
}

/// The latest successful diagnosis report of a run, as stored. 409 while
/// its diagnose job has not succeeded, 404 if none was ever asked for.
pub(crate) async fn latest_report(
    st: &AppState,
    id: RunId,
) -> Result<Stored<DiagnoseReport>, ApiError> {
    if let Some(json) = st.store.latest_diagnosis(id).await? {
        return Ok(json);
    }
    if st.store.get_run(id).await?.is_none() {
        return Err(ApiError::NotFound(format!("no run {id}")));
    }
    match st.store.latest_diagnose_job(id).await? {
        Some(job) => Err(ApiError::Conflict(format!(
            "run {id} has no diagnosis yet: its diagnose job {} is {}",
            job.id, job.state
        ))),
        None => Err(ApiError::NotFound(format!(
            "run {id} has no diagnosis: POST /api/v1/runs/{id}/diagnose to queue one"
        ))),
    }
}

async fn get_diagnosis(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let report = latest_report(&st, id).await?;
    // Stored as serialized by the workflow's own types: served as is.
    Ok((
        [(header::CONTENT_TYPE, "application/json")],
        report.into_json(),
    )
        .into_response())
}

async fn get_diagnosis_gap_svg(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let report = latest_report(&st, id)
        .await?
        .parse()
        .map_err(|e| ApiError::Internal(format!("stored diagnosis: {e}")))?;
    let svg = sinscal_core::diagnose::plot::gap_svg(&report);
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}
