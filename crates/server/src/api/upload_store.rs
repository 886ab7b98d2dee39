//! Storing an uploaded run once its bytes are checked: the bytes made
//! whole in the run store, then the run and job rows in one transaction,
//! or the run already stored with the same bytes (for the API's upload and
//! the pages' form alike).

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;

use super::auth::Auth;
use super::error::ApiError;
use super::AppState;
use crate::metrics::UploadOutcome;
use crate::runfiles::{Pending, RunFiles};
use crate::store::{now_ms, InsertOutcome, JobId, NewRun, Role, RunFile, RunId, RunRow, Stored};
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::UnitSerial;

/// Shortest run accepted: the estimator needs at least two dwells of 20 s
/// (one to align on, another attitude to observe anything) and a turn.
pub(super) const MIN_RUN_SECONDS: f64 = 40.0;

/// The answer to an upload (202 for a new run, 200 for one already stored).
#[derive(Debug, Serialize)]
pub struct UploadAnswer {
    pub run_id: RunId,
    pub job_id: JobId,
    /// False when the same bytes were already stored for this unit.
    pub created: bool,
    pub sha256: String,
    pub run_url: String,
    pub job_url: String,
}

/// A body received, hashed and (when the metadata came first) validated.
pub(super) struct Ingested {
    pub file: Pending,
    pub sha256: String,
    pub size: u64,
    /// Records and gzip-ness, once validated.
    pub checked: Option<(u64, bool)>,
}

pub fn queue_full() -> ApiError {
    ApiError::Unavailable {
        detail: "the calibration queue is full; retry later".into(),
        retry_after_s: 30,
    }
}

/// A run an upload stored, or found already stored.
#[derive(Debug)]
pub struct StoredRun {
    /// False when the same bytes were already stored for this unit.
    pub created: bool,
    pub run_id: RunId,
    pub job_id: JobId,
    pub sha256: String,
}

impl StoredRun {
    /// The API's answer: 202 for a new run, 200 for one already stored,
    /// the run in `Location`.
    pub fn answer(self) -> Response {
        let status = if self.created {
            StatusCode::ACCEPTED
        } else {
            StatusCode::OK
        };
        let run_url = format!("/api/v1/runs/{}", self.run_id);
        let body = UploadAnswer {
            job_url: format!("/api/v1/jobs/{}", self.job_id),
            run_url: run_url.clone(),
            run_id: self.run_id,
            job_id: self.job_id,
            created: self.created,
            sha256: self.sha256,
        };
        answer_with_location(status, body, &run_url)
    }
}

fn answer_with_location(status: StatusCode, body: UploadAnswer, run_url: &str) -> Response {
    let mut resp = (status, Json(body)).into_response();
    if let Ok(v) = HeaderValue::from_str(run_url) {
        resp.headers_mut().insert(header::LOCATION, v);
    }
    resp
}

/// The answer to bytes already stored for the unit. A station learns of
/// another uploader's run nothing but that it exists (no ids, no
/// metadata); bytes re-sent with different metadata are refused rather
/// than silently answered with the old run.
fn existing_answer(
    auth: &Auth,
    run: &RunRow,
    metadata: &Stored<RunMetadata>,
) -> Result<StoredRun, ApiError> {
    if auth.role == Role::Station && run.uploaded_by.as_deref() != Some(auth.token_id.as_str()) {
        return Err(ApiError::Conflict(
            "these bytes are already stored for this unit by another uploader".into(),
        ));
    }
    if run.file.metadata.as_json() != metadata.as_json() {
        return Err(ApiError::Conflict(format!(
            "these bytes are already stored for this unit as run {} with different metadata; \
             to store them with the new metadata an admin deletes that run first \
             (DELETE /api/v1/runs/{})",
            run.id, run.id
        )));
    }
    Ok(StoredRun {
        created: false,
        run_id: run.id,
        job_id: run.job_id,
        sha256: run.file.sha256.clone(),
    })
}

/// Refuses a run too short to calibrate, before it is stored: a fault of
/// its data file.
pub(super) fn check_span(
    st: &AppState,
    meta: &RunMetadata,
    data: &Ingested,
) -> Result<(), ApiError> {
    let (records, _) = data.checked.unwrap_or((0, false));
    let span_s = records.saturating_sub(1) as f64 / meta.sample_rate_hz;
    if span_s < MIN_RUN_SECONDS {
        st.metrics.upload(UploadOutcome::Refused);
        return Err(ApiError::Unprocessable(format!(
            "the run spans {span_s:.2} s ({records} records at {} Hz): a calibration needs at \
             least {MIN_RUN_SECONDS} s (two dwells of 20 s and a turn between them)",
            meta.sample_rate_hz
        )));
    }
    Ok(())
}

/// Stores a checked upload (its span checked by [`check_span`]): the file
/// committed, then the run and job rows.
pub(super) async fn store_run(
    st: &AppState,
    auth: &Auth,
    meta: RunMetadata,
    data: Ingested,
) -> Result<StoredRun, ApiError> {
    // `RunMetadata::from_json` validated it: this parse does not fail.
    let serial: UnitSerial = meta
        .unit_serial
        .parse()
        .map_err(ApiError::InvalidMetadata)?;
    let (records, gzip) = data.checked.unwrap_or((0, false));
    let metadata = Stored::of(&meta).map_err(|e| ApiError::Internal(e.to_string()))?;
    if let Some(existing) = st.store.find_run_by_hash(&serial, &data.sha256).await? {
        st.metrics.upload(UploadOutcome::Duplicate);
        return existing_answer(auth, &existing, &metadata);
    }
    let run_id = RunId::new();
    let job_id = JobId::new();
    let ext = match (meta.format, gzip) {
        (DataFormat::Csv, false) => "csv",
        (DataFormat::Csv, true) => "csv.gz",
        (DataFormat::F64le, _) => "bin",
    };
    let blob_path = RunFiles::blob_path(&run_id.to_string(), ext);
    // Until the rows commit, the bytes are `stored`'s, deleted on any early
    // return; the sweep covers a crash.
    let stored = st.run_store.commit(data.file, &blob_path).await?;
    // Checked when the metadata was parsed.
    let recorded_at = meta.recorded_at_ms().map_err(ApiError::InvalidMetadata)?;
    let new = NewRun {
        run_id,
        job_id,
        unit_serial: serial.clone(),
        file: RunFile {
            sha256: data.sha256.clone(),
            size_bytes: data.size as i64,
            records: records as i64,
            format: meta.format,
            gzip,
            blob_path,
            metadata: metadata.clone(),
        },
        recorded_at,
        uploaded_at: now_ms(),
        max_attempts: st.config.max_attempts,
        uploaded_by: Some(auth.token_id.clone()),
        product: meta.product.clone(),
    };
    match st
        .store
        .insert_run_and_job(&new, st.config.max_queue)
        .await?
    {
        InsertOutcome::Created => {
            stored.keep();
            st.wake.notify_one();
            st.metrics.upload(UploadOutcome::Accepted);
            tracing::info!(run = %run_id, job = %job_id, unit = %serial, bytes = data.size, "run stored");
            Ok(StoredRun {
                created: true,
                run_id,
                job_id,
                sha256: data.sha256,
            })
        }
        InsertOutcome::Existing { run_id, .. } => {
            // Stored by a concurrent upload of the same bytes since the
            // check above.
            stored.discard().await;
            st.metrics.upload(UploadOutcome::Duplicate);
            let existing = st
                .store
                .get_run(run_id)
                .await?
                .ok_or_else(|| ApiError::Internal(format!("run {run_id} vanished")))?;
            existing_answer(auth, &existing, &metadata)
        }
        InsertOutcome::QueueFull => {
            stored.discard().await;
            st.metrics.upload(UploadOutcome::Refused);
            Err(queue_full())
        }
    }
}
