//! Verdicts as stored: every result's verdict (`accept::judge`) is kept in
//! its row, so that history and the units list filter by index, and is
//! judged again whenever what it depends on changes — a result stored or
//! deleted before it in the unit's history (repeatability), or its product
//! type created, changed or deleted. A stored verdict is rewritten only
//! when it changes, with the time and the product-type revision it was
//! judged against (CONTRACT §6a).
//!
//! Works on any connection (the caller's write transaction, or the writer
//! at startup), so it depends on no sibling but the leaves.

use std::collections::{BTreeMap, HashMap};

use sqlx::{AnyConnection, FromRow};

use super::dialect::{lock_key, unit_key, Backend};
use super::error::StoreError;
use super::ids::RunId;
use super::kinds::OptionalFlag;
use super::spread::SpreadAccumulator;
use sinscal_core::accept::{judge, Evidence, Product, ProductLimits, Verdict, VerdictStatus};
use sinscal_core::calib::ParameterEstimate;
use sinscal_core::model::{N_PARAMS, PARAMETERS};

/// A result's row as a verdict reads it.
#[derive(FromRow)]
struct Judged {
    run_id: RunId,
    parameters: String,
    param_values: Option<Vec<u8>>,
    #[sqlx(try_from = "OptionalFlag")]
    model_adequate: Option<bool>,
    poorly_observable: Option<String>,
    cross_check_flagged: Option<String>,
    product: Option<String>,
    verdict_detail: Option<String>,
    verdict_product: Option<String>,
    verdict_revision: Option<i64>,
    scheme_dwells_found: Option<i64>,
    scheme_positions_declared: Option<i64>,
}

/// A product type as a verdict reads it.
struct Limits {
    limits: ProductLimits,
    revision: i64,
}

/// Judges again the verdicts of a unit's results from `from` on (its run
/// time and run id; `None`: all of them), in history order, and brings the
/// unit's own product and verdict up to date. Earlier results only feed the
/// repeatability.
pub(super) async fn refresh_unit(
    conn: &mut AnyConnection,
    serial: &str,
    from: Option<(i64, RunId)>,
    now: i64,
) -> Result<(), StoreError> {
    // Compared as the TEXT the column holds: "" sorts before every id.
    let (from_time, from_id) =
        from.map_or((i64::MIN, String::new()), |(t, id)| (t, id.to_string()));
    let mut acc = SpreadAccumulator::default();
    let earlier: Vec<Vec<u8>> = sqlx::query_scalar(
        "SELECT param_values FROM results
         WHERE unit_serial = $1 AND param_values IS NOT NULL AND (run_time, run_id) < ($2, $3)
         ORDER BY run_time, run_id",
    )
    .bind(serial)
    .bind(from_time)
    .bind(&from_id)
    .fetch_all(&mut *conn)
    .await?;
    for blob in &earlier {
        acc.push(blob);
    }
    let rows: Vec<Judged> = sqlx::query_as(
        "SELECT s.run_id, s.parameters, s.param_values, s.model_adequate, s.poorly_observable,
                s.cross_check_flagged, r.product, s.verdict_detail, s.verdict_product,
                s.verdict_revision, s.scheme_dwells_found, s.scheme_positions_declared
         FROM results s JOIN runs r ON r.id = s.run_id
         WHERE s.unit_serial = $1 AND (s.run_time, s.run_id) >= ($2, $3)
         ORDER BY s.run_time, s.run_id",
    )
    .bind(serial)
    .bind(from_time)
    .bind(&from_id)
    .fetch_all(&mut *conn)
    .await?;
    let mut types: HashMap<String, Option<Limits>> = HashMap::new();
    for row in rows {
        if let Some(blob) = &row.param_values {
            acc.push(blob);
        }
        let (repeatability, runs) = acc.std_devs();
        let (values, sigmas) = values_and_sigmas(&row.parameters)?;
        let poorly = names(row.poorly_observable.as_deref())?;
        let flagged = names(row.cross_check_flagged.as_deref())?;
        let limits = match &row.product {
            Some(name) if !types.contains_key(name) => {
                let found = product_limits(&mut *conn, name).await?;
                types.entry(name.clone()).or_insert(found)
            }
            Some(name) => types.entry(name.clone()).or_insert(None),
            None => &None,
        };
        let product = match (&row.product, limits) {
            (None, _) => Product::None,
            (Some(_), Some(l)) => Product::Known(&l.limits),
            (Some(name), None) => Product::Unknown(name),
        };
        let evidence = Evidence {
            values: &values,
            sigmas: &sigmas,
            model_adequate: row.model_adequate,
            poorly_observable: &poorly,
            cross_check_flagged: &flagged,
            repeatability: &repeatability,
            runs,
            scheme_dwells: row.scheme_dwells_found.zip(row.scheme_positions_declared),
        };
        let verdict = judge(&evidence, product);
        let revision = limits.as_ref().map(|l| l.revision);
        let detail = serde_json::to_string(&verdict)?;
        let unchanged = row.verdict_detail.as_deref() == Some(detail.as_str())
            && row.verdict_product == row.product
            && row.verdict_revision == revision;
        if unchanged {
            continue;
        }
        sqlx::query(
            "UPDATE results SET verdict = $1, verdict_detail = $2, verdict_product = $3,
                    verdict_revision = $4, verdict_at = $5
             WHERE run_id = $6",
        )
        .bind(verdict.status().as_str())
        .bind(&detail)
        .bind(&row.product)
        .bind(revision)
        .bind(now)
        .bind(row.run_id)
        .execute(&mut *conn)
        .await?;
    }
    refresh_unit_row(conn, serial).await
}

/// The unit's product (its latest run's) and verdict (its latest calibrated
/// run's), from the rows they derive from.
pub(super) async fn refresh_unit_row(
    conn: &mut AnyConnection,
    serial: &str,
) -> Result<(), StoreError> {
    sqlx::query(
        "UPDATE units SET
             product = (SELECT r.product FROM runs r WHERE r.unit_serial = $1
                        ORDER BY r.run_time DESC, r.id DESC LIMIT 1),
             verdict = (SELECT s.verdict FROM results s WHERE s.unit_serial = $1
                        ORDER BY s.run_time DESC, s.run_id DESC LIMIT 1)
         WHERE serial = $1",
    )
    .bind(serial)
    .execute(&mut *conn)
    .await?;
    Ok(())
}

/// Judges again every unit with a run naming `product` (its product type
/// was created, changed or deleted).
pub(super) async fn refresh_product(
    backend: Backend,
    conn: &mut AnyConnection,
    product: &str,
    now: i64,
) -> Result<(), StoreError> {
    let units: Vec<String> =
        sqlx::query_scalar("SELECT DISTINCT unit_serial FROM runs WHERE product = $1")
            .bind(product)
            .fetch_all(&mut *conn)
            .await?;
    for serial in units {
        lock_key(backend, conn, &unit_key(&serial)).await?;
        refresh_unit(conn, &serial, None, now).await?;
    }
    Ok(())
}

/// Judges every result that has no verdict yet (stored before verdicts
/// existed): their units, whole. A no-op afterwards.
pub(super) async fn backfill(conn: &mut AnyConnection, now: i64) -> Result<(), StoreError> {
    let units: Vec<String> =
        sqlx::query_scalar("SELECT DISTINCT unit_serial FROM results WHERE verdict IS NULL")
            .fetch_all(&mut *conn)
            .await?;
    for serial in units {
        refresh_unit(conn, &serial, None, now).await?;
    }
    Ok(())
}

async fn product_limits(
    conn: &mut AnyConnection,
    name: &str,
) -> Result<Option<Limits>, StoreError> {
    let row: Option<(String, i64)> =
        sqlx::query_as("SELECT limits, revision FROM product_types WHERE name = $1")
            .bind(name)
            .fetch_optional(&mut *conn)
            .await?;
    row.map(|(json, revision)| {
        let value: serde_json::Value = serde_json::from_str(&json)?;
        let limits = ProductLimits::from_json(&value, "limits")
            .map_err(|e| StoreError::Corrupt(format!("product type {name}: {e}")))?;
        Ok(Limits { limits, revision })
    })
    .transpose()
}

/// Values and σ of a result's `parameters` JSON in canonical order (NaN
/// where it lacks one).
fn values_and_sigmas(json: &str) -> Result<([f64; N_PARAMS], [f64; N_PARAMS]), StoreError> {
    let parameters: BTreeMap<String, ParameterEstimate> = serde_json::from_str(json)?;
    let mut values = [f64::NAN; N_PARAMS];
    let mut sigmas = [f64::NAN; N_PARAMS];
    for (i, info) in PARAMETERS.iter().enumerate() {
        if let Some(e) = parameters.get(info.name) {
            values[i] = e.value;
            sigmas[i] = e.sigma;
        }
    }
    Ok((values, sigmas))
}

fn names(json: Option<&str>) -> Result<Vec<String>, StoreError> {
    Ok(json
        .map(serde_json::from_str)
        .transpose()?
        .unwrap_or_default())
}

/// A stored verdict read back: the whole verdict and what it was judged
/// against.
#[derive(Clone, Debug)]
pub struct StoredVerdict {
    pub run_id: RunId,
    pub verdict: Verdict,
    /// The product the run named (`None`: none).
    pub product: Option<String>,
    /// The product type's revision applied (`None`: no product type).
    pub revision: Option<i64>,
    /// When the stored verdict last changed.
    pub judged_at: i64,
}

impl StoredVerdict {
    /// From a row's verdict columns; `None` when it has no verdict.
    pub(super) fn from_columns(
        run_id: RunId,
        detail: Option<&str>,
        product: Option<String>,
        revision: Option<i64>,
        judged_at: Option<i64>,
    ) -> Result<Option<StoredVerdict>, StoreError> {
        let (Some(detail), Some(judged_at)) = (detail, judged_at) else {
            return Ok(None);
        };
        Ok(Some(StoredVerdict {
            run_id,
            verdict: serde_json::from_str(detail)?,
            product,
            revision,
            judged_at,
        }))
    }

    pub fn status(&self) -> VerdictStatus {
        self.verdict.status()
    }
}
