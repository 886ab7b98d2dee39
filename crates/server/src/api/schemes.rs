//! Scheme design over HTTP: `POST /schemes/design` answers what
//! `sinscal design` prints, as JSON, while the client waits.
//!
//! A design scores a few thousand schemes (tens of CPU seconds), so it runs
//! on the blocking pool, one at a time: a second request while one runs is
//! answered 503 with Retry-After rather than queued behind it, so that
//! designs never take the calibration workers' cores two at a time. Each
//! has the server's time limit (`--design-time-limit-secs`); the command
//! line has none. Running out of it is the server's limit, not the
//! request's fault: 503, pointing to `POST /designs` (`designs`), which
//! runs the same design as a job with a far longer limit.

use axum::extract::State;
use axum::routing::post;
use axum::{Json, Router};

use super::auth::{roles, Caller};
use super::designs::refused;
use super::error::ApiError;
use super::json_object::JsonObject;
use super::AppState;
use sinscal_core::design::{design, Design, DesignError, DesignSpec};

/// What a refused request is told to wait, s.
const BUSY_RETRY_AFTER_S: u64 = 30;

pub fn router() -> Router<AppState> {
    Router::new().route("/schemes/design", post(design_scheme))
}

async fn design_scheme(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    JsonObject(spec): JsonObject<DesignSpec>,
) -> Result<Json<Design>, ApiError> {
    let limit = st.config.design_time_limit.as_secs_f64();
    let req = spec.request(Some(limit)).map_err(refused)?;
    let permit = st
        .designs
        .clone()
        .try_acquire_owned()
        .map_err(|_| ApiError::Unavailable {
            detail: "a scheme design is running; retry when it has finished".into(),
            retry_after_s: BUSY_RETRY_AFTER_S,
        })?;
    // The permit goes with the computation: a client that hangs up does
    // not free the slot while its design still runs.
    let designed = tokio::task::spawn_blocking(move || {
        let _permit = permit;
        design(&req)
    })
    .await
    .map_err(|e| ApiError::Internal(format!("design task: {e}")))?;
    match designed {
        Ok(d) => Ok(Json(d)),
        Err(DesignError::TimeLimit(s)) => Err(ApiError::Unavailable {
            detail: format!(
                "the design did not finish within this server's time limit for a request \
                 answered at once ({s:.0} s); POST the same body to /api/v1/designs to run it \
                 as a job with a limit of {:.0} s, and follow it at /api/v1/designs/{{id}}",
                st.config.design_job_time_limit.as_secs_f64()
            ),
            retry_after_s: BUSY_RETRY_AFTER_S,
        }),
        Err(e) => Err(refused(e)),
    }
}
