//! A run's noise analysis over HTTP: `GET /runs/{id}/noise` answers what
//! `sinscal noise RUN --out NOISE.json` writes, over the run's dwells.
//!
//! It is computed from the stored run file on every request (two streaming
//! reads; about a second for a 3.2 h 100 Hz run), on the blocking pool and
//! a bounded number at a time: a request while the limit is taken is
//! answered 503 with Retry-After rather than queued, so analyses never take
//! more than their share of the cores from the calibration workers. A
//! client that hangs up stops its analysis at the next cancel check.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::routing::get;
use axum::{Json, Router};

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::{parse_id, AppState};
use crate::store::RunId;
use sinscal_core::noise::{NoiseOptions, NoiseReport};
use sinscal_core::pipeline::noise_file;

/// What a refused request is told to wait, s.
const BUSY_RETRY_AFTER_S: u64 = 5;

pub fn router() -> Router<AppState> {
    Router::new().route("/runs/{id}/noise", get(get_noise))
}

/// Sets the flag when dropped: the handler's future is dropped when its
/// client goes away, and the analysis then stops early.
struct CancelOnDrop(Arc<AtomicBool>);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

async fn get_noise(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<NoiseReport>, ApiError> {
    let id: RunId = parse_id(path?.0, "run")?;
    Ok(Json(analyse_noise(&st, id).await?))
}

/// The noise analysis of a stored run (the API's answer and the noise
/// page's), at most `noise_analyses` at once: 503 when all are busy.
pub(crate) async fn analyse_noise(st: &AppState, id: RunId) -> Result<NoiseReport, ApiError> {
    let run = super::runs::stored_run(st, id).await?;
    let meta = run
        .file
        .metadata
        .parse()
        .map_err(|e| ApiError::Internal(format!("stored metadata of run {id}: {e}")))?;
    let permit =
        st.noise_analyses
            .clone()
            .try_acquire_owned()
            .map_err(|_| ApiError::Unavailable {
                detail: "noise analyses are running; retry when one has finished".into(),
                retry_after_s: BUSY_RETRY_AFTER_S,
            })?;
    // After the permit, so a refused request fetches nothing; the copy
    // (an object store's download) goes with the computation too.
    let data = st.run_store.local_copy(&run.file.blob_path).await?;
    let cancel = Arc::new(AtomicBool::new(false));
    let _stop_if_gone = CancelOnDrop(cancel.clone());
    // The permit goes with the computation: a client that hangs up does
    // not free the slot before its analysis has stopped.
    let report = tokio::task::spawn_blocking(move || {
        let _permit = permit;
        noise_file(data.path(), &meta, &NoiseOptions::default(), &cancel)
    })
    .await
    .map_err(|e| ApiError::Internal(format!("noise task: {e}")))??;
    Ok(report)
}
