//! Units: list, one unit, its calibration history and the repeatability of
//! its parameters across runs (the seed paper's Table 2, for any number of
//! runs).

use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::routing::get;
use axum::{Json, Router};
use serde::{Deserialize, Serialize};

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::runs::{ModelCheckBrief, VerdictView};
use super::{parse_time, rfc3339, AppState};
use crate::store::{
    JobCounts, JobId, Review, RunId, SpreadRun, UnitFilter, UnitSpread, UnitSummary,
};
use sinscal_core::accept::{LimitKind, ProductLimits, VerdictStatus};
use sinscal_core::calib::ErrorModel;
use sinscal_core::io::meta::validate_product;
use sinscal_core::io::UnitSerial;
use sinscal_core::model::PARAMETERS;

const MAX_PAGE: i64 = 1000;
const DEFAULT_PAGE: i64 = 100;
const MAX_OFFSET: i64 = 1_000_000_000;

#[derive(Debug, Deserialize)]
pub struct UnitsQuery {
    limit: Option<i64>,
    offset: Option<i64>,
    /// Units whose latest calibrated run has this verdict.
    verdict: Option<VerdictStatus>,
    /// Units whose latest run names this product.
    product: Option<String>,
}

fn page(limit: Option<i64>, offset: Option<i64>) -> Result<(i64, i64), ApiError> {
    let limit = limit.unwrap_or(DEFAULT_PAGE);
    let offset = offset.unwrap_or(0);
    if !(1..=MAX_PAGE).contains(&limit) {
        return Err(ApiError::BadRequest(format!(
            "limit must be 1 to {MAX_PAGE}, got {limit}"
        )));
    }
    if !(0..=MAX_OFFSET).contains(&offset) {
        return Err(ApiError::BadRequest(format!(
            "offset must be 0 to {MAX_OFFSET}, got {offset}"
        )));
    }
    Ok((limit, offset))
}

#[derive(Serialize)]
pub struct UnitView {
    pub serial: UnitSerial,
    pub created_at: String,
    pub runs: i64,
    pub calibrated: i64,
    pub last_run_time: Option<String>,
    /// The product its latest run names.
    pub product: Option<String>,
    /// The verdict of its latest calibrated run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verdict: Option<VerdictView>,
}

impl TryFrom<UnitSummary> for UnitView {
    type Error = ApiError;
    fn try_from(u: UnitSummary) -> Result<Self, ApiError> {
        let verdict = u.verdict()?.map(VerdictView::from);
        Ok(UnitView {
            serial: u.serial,
            created_at: rfc3339(u.created_at),
            runs: u.runs,
            calibrated: u.calibrated,
            last_run_time: u.last_run_time.map(rfc3339),
            product: u.product,
            verdict,
        })
    }
}

#[derive(Serialize)]
pub struct UnitList {
    pub total: i64,
    pub limit: i64,
    pub offset: i64,
    pub items: Vec<UnitView>,
}

#[derive(Serialize)]
pub struct UnitDetail {
    #[serde(flatten)]
    pub unit: UnitView,
    /// The unit's jobs by state.
    pub jobs: JobCounts,
}

#[derive(Debug, Deserialize)]
pub struct HistoryQuery {
    limit: Option<i64>,
    offset: Option<i64>,
    from: Option<String>,
    to: Option<String>,
    /// Only results with this verdict.
    verdict: Option<VerdictStatus>,
}

#[derive(Serialize)]
pub struct HistoryItem {
    pub run_id: RunId,
    pub job_id: JobId,
    pub run_time: String,
    pub completed_at: String,
    /// The stored JSON, passed through: a page of 100 runs is 2400
    /// estimates, not worth parsing only to print again.
    pub parameters: Box<serde_json::value::RawValue>,
    /// The error model the result was made with (null: not known).
    pub model: Option<ErrorModel>,
    /// `clear`, or `needs_review` when the model check failed.
    pub review: Review,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_check: Option<ModelCheckBrief>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verdict: Option<VerdictView>,
}

#[derive(Serialize)]
pub struct History {
    pub unit_serial: UnitSerial,
    pub total: i64,
    pub limit: i64,
    pub offset: i64,
    pub items: Vec<HistoryItem>,
}

#[derive(Debug, Deserialize)]
pub struct RepeatabilityQuery {
    last: Option<i64>,
    since: Option<String>,
}

#[derive(Serialize)]
pub struct ParameterRepeatability {
    pub name: String,
    pub unit: String,
    pub n: i64,
    pub mean: f64,
    /// Sample standard deviation (n − 1); null below two runs.
    pub std_dev: Option<f64>,
    pub min: f64,
    pub max: f64,
    pub range: f64,
    /// Largest |change| between consecutive runs in time order; null below
    /// two runs.
    pub max_change: Option<f64>,
    /// The unit's product type's `max_repeatability` for the parameter
    /// when it sets one (as the verdict and the unit's page judge), else
    /// the server's configured tolerance.
    pub tolerance: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance_source: Option<ToleranceSource>,
    /// Over a product's limit: the standard deviation exceeds it (the
    /// verdict's rule). Over the server's tolerance: the standard deviation
    /// or the largest change exceeds it.
    pub flagged: bool,
}

/// Where a repeatability tolerance comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ToleranceSource {
    Product,
    Server,
}

/// The limits of the product type a unit's latest run names, when it
/// exists.
pub(crate) async fn unit_limits(
    st: &AppState,
    product: Option<&str>,
) -> Result<Option<ProductLimits>, ApiError> {
    let Some(name) = product else {
        return Ok(None);
    };
    match st.store.get_product_type(name).await? {
        Some(row) => Ok(Some(row.parsed_limits()?)),
        None => Ok(None),
    }
}

#[derive(Serialize)]
pub struct Repeatability {
    pub unit_serial: UnitSerial,
    /// Calibrated runs the statistics cover.
    pub runs: i64,
    /// Those runs in time order, each with the model its result was made
    /// with: statistics over runs of different models compare estimates
    /// of different things.
    pub run_models: Vec<RunModel>,
    pub parameters: Vec<ParameterRepeatability>,
    pub flagged: Vec<String>,
}

/// A run a repeatability covers and the model its result was made with.
#[derive(Serialize)]
pub struct RunModel {
    pub run_id: RunId,
    pub run_time: String,
    /// Null: not known.
    pub model: Option<ErrorModel>,
}

impl From<SpreadRun> for RunModel {
    fn from(r: SpreadRun) -> Self {
        RunModel {
            run_id: r.run_id,
            run_time: rfc3339(r.run_time),
            model: r.model,
        }
    }
}

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/units", get(list_units))
        .route("/units/{serial}", get(get_unit))
        .route("/units/{serial}/history", get(history))
        .route("/units/{serial}/repeatability", get(repeatability))
}

/// The unit serial of a path; a malformed one is a 400 naming the rule.
pub(crate) fn serial_of(path: Result<Path<String>, PathRejection>) -> Result<UnitSerial, ApiError> {
    path?.0.parse().map_err(ApiError::BadRequest)
}

async fn list_units(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    query: Result<Query<UnitsQuery>, QueryRejection>,
) -> Result<Json<UnitList>, ApiError> {
    let Query(q) = query?;
    let (limit, offset) = page(q.limit, q.offset)?;
    if let Some(p) = &q.product {
        validate_product(p).map_err(ApiError::BadRequest)?;
    }
    let filter = UnitFilter {
        verdict: q.verdict,
        product: q.product,
        serial_contains: None,
    };
    let (total, rows) = st.store.list_units(&filter, limit, offset).await?;
    Ok(Json(UnitList {
        total,
        limit,
        offset,
        items: rows
            .into_iter()
            .map(TryInto::try_into)
            .collect::<Result<_, _>>()?,
    }))
}

async fn get_unit(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<UnitDetail>, ApiError> {
    let serial = serial_of(path)?;
    let unit = st
        .store
        .get_unit(&serial)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no unit {serial}")))?;
    let jobs = st.store.unit_job_counts(&serial).await?;
    Ok(Json(UnitDetail {
        unit: unit.try_into()?,
        jobs,
    }))
}

async fn history(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<HistoryQuery>, QueryRejection>,
) -> Result<Json<History>, ApiError> {
    let serial = serial_of(path)?;
    let Query(q) = query?;
    let (limit, offset) = page(q.limit, q.offset)?;
    let from = q
        .from
        .as_deref()
        .map(|t| parse_time(t, "from"))
        .transpose()?
        .unwrap_or(i64::MIN);
    let to =
        q.to.as_deref()
            .map(|t| parse_time(t, "to"))
            .transpose()?
            .unwrap_or(i64::MAX);
    if st.store.get_unit(&serial).await?.is_none() {
        return Err(ApiError::NotFound(format!("no unit {serial}")));
    }
    let (total, rows) = st
        .store
        .history(&serial, (from, to), q.verdict, limit, offset)
        .await?;
    let items = rows
        .into_iter()
        .map(|r| {
            Ok(HistoryItem {
                verdict: r.verdict()?.map(VerdictView::from),
                model: r.model()?,
                parameters: serde_json::value::RawValue::from_string(r.parameters)
                    .map_err(|e| ApiError::Internal(e.to_string()))?,
                run_id: r.run_id,
                job_id: r.job_id,
                run_time: rfc3339(r.run_time),
                completed_at: rfc3339(r.completed_at),
                review: Review::of(true, r.model_adequate),
                model_check: ModelCheckBrief::from_columns(r.model_adequate, r.model_summary),
            })
        })
        .collect::<Result<_, ApiError>>()?;
    Ok(Json(History {
        unit_serial: serial,
        total,
        limit,
        offset,
        items,
    }))
}

async fn repeatability(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<RepeatabilityQuery>, QueryRejection>,
) -> Result<Json<Repeatability>, ApiError> {
    let serial = serial_of(path)?;
    let Query(q) = query?;
    if let Some(last) = q.last {
        if last < 1 {
            return Err(ApiError::BadRequest(format!(
                "last must be ≥ 1, got {last}"
            )));
        }
    }
    let since = q
        .since
        .as_deref()
        .map(|t| parse_time(t, "since"))
        .transpose()?
        .unwrap_or(i64::MIN);
    let Some(unit) = st.store.get_unit(&serial).await? else {
        return Err(ApiError::NotFound(format!("no unit {serial}")));
    };
    let limits = unit_limits(&st, unit.product.as_deref()).await?;
    let spread = st.store.repeatability(&serial, since, q.last).await?;
    Ok(Json(unit_repeatability(
        &st,
        serial,
        spread,
        limits.as_ref(),
    )))
}

/// The spread of a unit's runs (as the store read it), each parameter
/// against `limits`' `max_repeatability` when it sets one, else the
/// server's tolerance: the API's answer, and what a calibration
/// certificate states.
pub(crate) fn unit_repeatability(
    st: &AppState,
    serial: UnitSerial,
    spread: UnitSpread,
    limits: Option<&ProductLimits>,
) -> Repeatability {
    let mut rows = spread.parameters;
    // Canonical order (SPEC §2), not alphabetical.
    let order = |name: &str| {
        PARAMETERS
            .iter()
            .position(|p| p.name == name)
            .unwrap_or(usize::MAX)
    };
    rows.sort_by_key(|r| (order(&r.name), r.name.clone()));
    let runs = rows.iter().map(|r| r.n).max().unwrap_or(0);
    let parameters: Vec<ParameterRepeatability> = rows
        .into_iter()
        .map(|r| {
            let std_dev = (r.n >= 2).then(|| (r.sum_sq.max(0.0) / (r.n - 1) as f64).sqrt());
            let product_limit = limits.and_then(|l| {
                let i = order(&r.name);
                (i < PARAMETERS.len())
                    .then(|| l.of(i).get(LimitKind::MaxRepeatability))
                    .flatten()
            });
            let (tolerance, tolerance_source, flagged) = match product_limit {
                Some(limit) => (
                    Some(limit),
                    Some(ToleranceSource::Product),
                    std_dev.is_some_and(|s| s > limit),
                ),
                None => {
                    let tol = st.config.tolerances.get(&r.name).copied();
                    let over = tol.is_some_and(|tol| {
                        std_dev.is_some_and(|s| s > tol) || r.max_change.is_some_and(|c| c > tol)
                    });
                    (tol, tol.map(|_| ToleranceSource::Server), over)
                }
            };
            ParameterRepeatability {
                range: r.max - r.min,
                unit: PARAMETERS
                    .iter()
                    .find(|p| p.name == r.name)
                    .map_or("", |p| p.unit)
                    .to_string(),
                name: r.name,
                n: r.n,
                mean: r.mean,
                std_dev,
                min: r.min,
                max: r.max,
                max_change: r.max_change,
                tolerance,
                tolerance_source,
                flagged,
            }
        })
        .collect();
    let flagged = parameters
        .iter()
        .filter(|p| p.flagged)
        .map(|p| p.name.clone())
        .collect();
    Repeatability {
        unit_serial: serial,
        runs,
        run_models: spread.runs.into_iter().map(RunModel::from).collect(),
        parameters,
        flagged,
    }
}
