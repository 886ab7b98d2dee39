//! Scheme design over HTTP: `POST /schemes/design` answers what
//! `sinscal design` prints, as JSON.
//!
//! A design scores a few thousand schemes (tens of CPU seconds), so it runs
//! on the blocking pool, one at a time: a second request while one runs is
//! answered 503 with Retry-After rather than queued behind it, so that
//! designs never take the calibration workers' cores two at a time. Each
//! has the server's time limit (`--design-time-limit-secs`); the command
//! line has none.

use std::collections::BTreeMap;

use axum::extract::rejection::JsonRejection;
use axum::extract::State;
use axum::routing::post;
use axum::{Json, Router};
use serde::Deserialize;

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::AppState;
use sinscal_core::calib::NoiseDensity;
use sinscal_core::design::{design, Axes, Design, DesignError, DesignRequest, DetectGoal, Target};
use sinscal_core::nav::Site;

/// What a refused request is told to wait, s.
const BUSY_RETRY_AFTER_S: u64 = 30;

pub fn router() -> Router<AppState> {
    Router::new().route("/schemes/design", post(design_scheme))
}

/// The target: `"table1"` or accuracies by parameter name.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum TargetSpec {
    Named(String),
    Accuracies(BTreeMap<String, f64>),
}

/// The request body; every field is optional and defaults as the command
/// line does.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DesignBody {
    target: Option<TargetSpec>,
    tighten: Option<f64>,
    margin: Option<f64>,
    arw_deg_rt_h: Option<f64>,
    vrw_ug_rt_hz: Option<f64>,
    axes: Option<Axes>,
    rate_dps: Option<f64>,
    accel_dps2: Option<f64>,
    min_dwell_s: Option<f64>,
    max_dwell_s: Option<f64>,
    max_turns: Option<usize>,
    max_duration_s: Option<f64>,
    by_hand: Option<bool>,
    seed: Option<u64>,
    latitude_deg: Option<f64>,
    attitude_error_deg: Option<[f64; 3]>,
    /// `["accel_lever_arm=2cm", "accel_delay=0.5ms"]`.
    detect: Option<Vec<String>>,
}

impl DesignBody {
    fn request(self, time_limit_s: f64) -> Result<DesignRequest, ApiError> {
        let defaults = DesignRequest::default();
        let target = match self.target {
            None => Target::table1(),
            Some(TargetSpec::Named(n)) if n == "table1" => Target::table1(),
            Some(TargetSpec::Named(n)) => {
                return Err(ApiError::Unprocessable(format!(
                    "target: {n:?} is not a named target (use \"table1\" or an object of \
                     accuracies by parameter name)"
                )))
            }
            Some(TargetSpec::Accuracies(map)) => Target::from_accuracies("request", map)
                .map_err(|e| ApiError::Unprocessable(e.to_string()))?,
        };
        let target = match self.tighten {
            None => target,
            Some(f) if f.is_finite() && f > 0.0 => target.tightened(f),
            Some(f) => {
                return Err(ApiError::Unprocessable(format!(
                    "tighten must be a positive number, got {f}"
                )))
            }
        };
        let detect = self
            .detect
            .unwrap_or_default()
            .iter()
            .map(|g| g.parse::<DetectGoal>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ApiError::Unprocessable(format!("detect: {e}")))?;
        let latitude = self.latitude_deg.unwrap_or(Site::REFERENCE.latitude_deg);
        Ok(DesignRequest {
            target: Some(target),
            noise: NoiseDensity::white(
                self.arw_deg_rt_h
                    .unwrap_or(defaults.noise.gyro_arw_deg_rt_h),
                self.vrw_ug_rt_hz
                    .unwrap_or(defaults.noise.accel_vrw_ug_rt_hz),
            ),
            axes: self.axes.unwrap_or(defaults.axes),
            rate_dps: self.rate_dps.unwrap_or(defaults.rate_dps),
            accel_dps2: self.accel_dps2.unwrap_or(defaults.accel_dps2),
            min_dwell_s: self.min_dwell_s.unwrap_or(defaults.min_dwell_s),
            max_dwell_s: self.max_dwell_s.unwrap_or(defaults.max_dwell_s),
            max_turns: self.max_turns.unwrap_or(defaults.max_turns),
            max_duration_s: self.max_duration_s,
            margin: self.margin.unwrap_or(defaults.margin),
            by_hand: self.by_hand.unwrap_or(defaults.by_hand),
            seed: self.seed.unwrap_or(defaults.seed),
            site: Site {
                latitude_deg: latitude,
                ..Site::REFERENCE
            },
            initial_attitude_deg: self
                .attitude_error_deg
                .unwrap_or(defaults.initial_attitude_deg),
            time_limit_s: Some(time_limit_s),
            detect,
        })
    }
}

async fn design_scheme(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    body: Result<Json<DesignBody>, JsonRejection>,
) -> Result<Json<Design>, ApiError> {
    let Json(body) = body?;
    let req = body.request(st.config.design_time_limit.as_secs_f64())?;
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
        Err(DesignError::Invalid(msg)) => Err(ApiError::Unprocessable(msg)),
        Err(e @ (DesignError::TimeLimit(_) | DesignError::Calib(_) | DesignError::Diagnose(_))) => {
            Err(ApiError::Unprocessable(e.to_string()))
        }
    }
}
