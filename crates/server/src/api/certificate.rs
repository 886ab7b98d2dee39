//! A run's calibration certificate: what it certifies (the run's current
//! result), whether it is issued (approved by an engineer or admin: then
//! it has a number and an issue date that never change) or a draft, and
//! the routes that read it as JSON or PDF and approve it.
//!
//! Only a result whose verdict is `accepted` is approved. A compensation
//! file released on an override is not a verdict, and no certificate says
//! a unit passed that the acceptance rules did not pass.

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Serialize;

use super::auth::{roles, Auth, Caller};
use super::certificate_pdf;
pub(crate) use super::certificate_sheet::Certificate;
use super::error::ApiError;
use super::units::unit_repeatability;
use super::{parse_id, rfc3339, AppState};
use crate::store::{
    now_ms, Approval, Approver, CertificateRow, JobId, ResultVersion, Role, RunId, RunRow,
};
use sinscal_core::calib::CalibrationResult;

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/runs/{id}/certificate", get(get_certificate))
        .route("/runs/{id}/certificate.pdf", get(get_pdf))
        .route("/runs/{id}/certificate/approve", post(approve))
}

/// The certificate of `run`'s current result; 404 while it has none.
pub(crate) async fn certificate_of(st: &AppState, run: RunRow) -> Result<Certificate, ApiError> {
    let id = run.id;
    let no_result = || ApiError::NotFound(format!("run {id} has no result: no certificate yet"));
    let result_version = st
        .store
        .result_versions(id)
        .await?
        .into_iter()
        .find(ResultVersion::is_current)
        .ok_or_else(no_result)?;
    let stored = st.store.get_result(id).await?.ok_or_else(no_result)?;
    // A few hundred kB of JSON (mostly convergence history): off the
    // async workers.
    let result: CalibrationResult = tokio::task::spawn_blocking(move || stored.parse())
        .await
        .map_err(|e| ApiError::Internal(format!("result task: {e}")))?
        .map_err(|e| ApiError::Internal(format!("stored result of run {id}: {e}")))?;
    let verdict = run.verdict()?;
    let limits = match verdict.as_ref().and_then(|v| v.product.as_deref()) {
        Some(name) => match st.store.get_product_type(name).await? {
            Some(row) => Some(row.parsed_limits()?),
            None => None,
        },
        None => None,
    };
    let spread = st
        .store
        .repeatability_through(&run.unit_serial, run.run_time, id)
        .await?;
    let repeatability = unit_repeatability(st, run.unit_serial.clone(), spread, limits.as_ref());
    let (issued, earlier): (Vec<CertificateRow>, Vec<CertificateRow>) = st
        .store
        .run_certificates(id)
        .await?
        .into_iter()
        .partition(|c| c.result_seq == result_version.seq);
    Ok(Certificate {
        meta: run.file.metadata.parse().ok(),
        run,
        result,
        result_version,
        verdict,
        limits,
        repeatability,
        issued: issued.into_iter().next(),
        earlier,
    })
}

/// Approves the run's current result (the API's action and the
/// certificate page's button): its certificate and whether it was issued
/// now. 409 while the run has no result or its verdict is not accepted.
pub(crate) async fn approve_certificate(
    st: &AppState,
    id: RunId,
    by: &Auth,
) -> Result<(bool, CertificateRow), ApiError> {
    let approver = Approver {
        token_id: &by.token_id,
        role: by.role,
    };
    match st.store.approve_certificate(id, approver, now_ms()).await? {
        Approval::Issued(c) => {
            tracing::info!(run = %id, number = %c.number, "certificate issued");
            Ok((true, c))
        }
        Approval::AlreadyIssued(c) => Ok((false, c)),
        Approval::NoResult => Err(ApiError::Conflict(format!(
            "run {id} has no result to approve yet"
        ))),
        Approval::NotAccepted(verdict) => Err(ApiError::Conflict(format!(
            "run {id}'s result is {}: only an accepted result gets a certificate",
            verdict.as_deref().unwrap_or("not judged")
        ))),
    }
}

/// The certificate as JSON.
#[derive(Serialize)]
struct CertificateView {
    run_id: RunId,
    unit_serial: String,
    /// `approved` (issued, valid) or `draft` (not valid).
    status: &'static str,
    /// The result certified: its number among the run's results (1 the
    /// first), and its calibration job.
    result_seq: i64,
    result_job_id: JobId,
    verdict: Option<&'static str>,
    number: Option<String>,
    issued_at: Option<String>,
    approved_by: Option<String>,
    approver_role: Option<Role>,
    approved_at: Option<String>,
    /// Whether an engineer or admin may approve it now.
    approvable: bool,
    /// Certificates of the run's earlier results, still on file.
    superseded: Vec<SupersededView>,
}

#[derive(Serialize)]
struct SupersededView {
    number: String,
    result_seq: i64,
    result_job_id: JobId,
    issued_at: String,
    approved_by: String,
}

impl From<&Certificate> for CertificateView {
    fn from(c: &Certificate) -> Self {
        let issued = c.issued.as_ref();
        CertificateView {
            run_id: c.run.id,
            unit_serial: c.run.unit_serial.to_string(),
            status: if issued.is_some() {
                "approved"
            } else {
                "draft"
            },
            result_job_id: c.result_version.job_id,
            result_seq: c.result_version.seq,
            verdict: c.verdict.as_ref().map(|v| v.status().as_str()),
            number: issued.map(|i| i.number.clone()),
            issued_at: issued.map(|i| rfc3339(i.issued_at)),
            approved_by: issued.map(|i| i.approved_by.clone()),
            approver_role: issued.map(|i| i.approver_role),
            approved_at: issued.map(|i| rfc3339(i.approved_at)),
            approvable: c.approvable(),
            superseded: c
                .earlier
                .iter()
                .map(|e| SupersededView {
                    number: e.number.clone(),
                    result_seq: e.result_seq,
                    result_job_id: e.job_id,
                    issued_at: rfc3339(e.issued_at),
                    approved_by: e.approved_by.clone(),
                })
                .collect(),
        }
    }
}

async fn read(
    st: &AppState,
    caller: &Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Certificate, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let run = super::runs::readable_run(st, caller, id).await?;
    certificate_of(st, run).await
}

async fn get_certificate(
    State(st): State<AppState>,
    caller: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<CertificateView>, ApiError> {
    let c = read(&st, &caller, path).await?;
    Ok(Json(CertificateView::from(&c)))
}

async fn get_pdf(
    State(st): State<AppState>,
    caller: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    let c = read(&st, &caller, path).await?;
    Ok(pdf_response(&c))
}

/// The certificate's PDF as an inline download named for the unit and the
/// number (`draft` until approved).
pub(crate) fn pdf_response(c: &Certificate) -> Response {
    let name = c.issued.as_ref().map_or("draft", |i| i.number.as_str());
    let mut resp = (
        [(header::CONTENT_TYPE, "application/pdf")],
        certificate_pdf::render(&c.sheet()),
    )
        .into_response();
    let disposition = format!("inline; filename=\"{}-{name}.pdf\"", c.run.unit_serial);
    if let Ok(v) = HeaderValue::from_str(&disposition) {
        resp.headers_mut().insert(header::CONTENT_DISPOSITION, v);
    }
    resp
}

/// 201 with the certificate when issued now, 200 when the result was
/// already approved (its certificate unchanged).
async fn approve(
    State(st): State<AppState>,
    caller: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Response, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    let run = super::runs::readable_run(&st, &caller, id).await?;
    let (issued_now, _) = approve_certificate(&st, run.id, &caller).await?;
    let c = certificate_of(&st, run).await?;
    let status = if issued_now {
        StatusCode::CREATED
    } else {
        StatusCode::OK
    };
    Ok((status, Json(CertificateView::from(&c))).into_response())
}
