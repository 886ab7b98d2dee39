//! Results and what is read from them: a run's result document and latest
//! diagnosis, units with their counts, a unit's history and the spread of
//! its parameters over runs (repeatability).

use std::collections::BTreeMap;

use sqlx::FromRow;

use super::db::{Store, WriteTx};
use super::document::Stored;
use super::error::StoreError;
use super::ids::{JobId, RunId};
use super::jobs::{by_state, JobCounts};
use super::kinds::OptionalFlag;
use super::runs::{insert_unit_and_run, NewRun};
use super::spread::{self, ParamSpread, SpreadAccumulator};
use super::verdicts::{refresh_unit, StoredVerdict};
use sinscal_core::accept::VerdictStatus;
use sinscal_core::calib::result::{RunTemperature, SchemeCoverage};
use sinscal_core::calib::{CalibrationResult, ErrorModel, ModelCheck, ParameterEstimate};
use sinscal_core::diagnose::DiagnoseReport;
use sinscal_core::io::UnitSerial;

#[derive(Clone, Debug, FromRow)]
pub struct UnitSummary {
    #[sqlx(try_from = "String")]
    pub serial: UnitSerial,
    pub created_at: i64,
    pub runs: i64,
    pub calibrated: i64,
    pub last_run_time: Option<i64>,
    /// When its latest calibrated run's result was stored.
    pub calibrated_at: Option<i64>,
    /// The product its latest run names.
    pub product: Option<String>,
    /// The verdict of its latest calibrated run (the columns of
    /// [`UnitSummary::verdict`]).
    pub verdict_run_id: Option<RunId>,
    pub verdict_detail: Option<String>,
    pub verdict_product: Option<String>,
    pub verdict_revision: Option<i64>,
    pub verdict_at: Option<i64>,
}

impl UnitSummary {
    /// The verdict of the unit's latest calibrated run.
    pub fn verdict(&self) -> Result<Option<StoredVerdict>, StoreError> {
        let Some(run_id) = self.verdict_run_id else {
            return Ok(None);
        };
        StoredVerdict::from_columns(
            run_id,
            self.verdict_detail.as_deref(),
            self.verdict_product.clone(),
            self.verdict_revision,
            self.verdict_at,
        )
    }
}

/// Which units a list returns: `None` fields do not filter.
#[derive(Clone, Debug, Default)]
pub struct UnitFilter {
    /// Units whose latest calibrated run has this verdict.
    pub verdict: Option<VerdictStatus>,
    /// Units whose latest run names this product.
    pub product: Option<String>,
    /// Units whose serial contains this text (the pages' search).
    pub serial_contains: Option<String>,
}

#[derive(Clone, Debug, FromRow)]
pub struct HistoryRow {
    pub run_id: RunId,
    pub job_id: JobId,
    pub run_time: i64,
    pub completed_at: i64,
    pub parameters: String,
    /// The model the result was made with, as stored (read through
    /// [`HistoryRow::model`]).
    pub model: Option<String>,
    #[sqlx(try_from = "OptionalFlag")]
    pub model_adequate: Option<bool>,
    pub model_summary: Option<String>,
    pub verdict_detail: Option<String>,
    pub verdict_product: Option<String>,
    pub verdict_revision: Option<i64>,
    pub verdict_at: Option<i64>,
}

impl HistoryRow {
    /// The model the result was made with (`None`: not known, a result
    /// seeded without one).
    pub fn model(&self) -> Result<Option<ErrorModel>, StoreError> {
        stored_model(self.run_id, self.model.as_deref())
    }

    pub fn verdict(&self) -> Result<Option<StoredVerdict>, StoreError> {
        StoredVerdict::from_columns(
            self.run_id,
            self.verdict_detail.as_deref(),
            self.verdict_product.clone(),
            self.verdict_revision,
            self.verdict_at,
        )
    }
}

/// A result's model column, parsed.
fn stored_model(run_id: RunId, model: Option<&str>) -> Result<Option<ErrorModel>, StoreError> {
    model
        .map(|m| {
            m.parse()
                .map_err(|e| StoreError::Corrupt(format!("the result of run {run_id}: {e}")))
        })
        .transpose()
}

/// A unit's parameter spread over its calibrated runs, and the runs it
/// covers.
#[derive(Clone, Debug)]
pub struct UnitSpread {
    /// The runs, in time order, each with the model it was made with.
    pub runs: Vec<SpreadRun>,
    pub parameters: Vec<ParamSpread>,
}

/// A run a spread covers.
#[derive(Clone, Debug)]
pub struct SpreadRun {
    pub run_id: RunId,
    pub run_time: i64,
    /// `None`: not known (a result seeded without one).
    pub model: Option<ErrorModel>,
}

/// A result's row as the spread reads it.
#[derive(FromRow)]
struct SpreadRow {
    run_id: RunId,
    run_time: i64,
    model: Option<String>,
    param_values: Vec<u8>,
}

impl UnitSpread {
    /// The spread of `rows`, given in time order.
    fn of(rows: Vec<SpreadRow>) -> Result<Self, StoreError> {
        let mut acc = SpreadAccumulator::default();
        let mut runs = Vec::with_capacity(rows.len());
        for r in rows {
            acc.push(&r.param_values);
            runs.push(SpreadRun {
                model: stored_model(r.run_id, r.model.as_deref())?,
                run_id: r.run_id,
                run_time: r.run_time,
            });
        }
        Ok(UnitSpread {
            runs,
            parameters: acc.finish(),
        })
    }
}

/// A result as a thermal model reads it.
#[derive(Clone, Debug, FromRow)]
pub struct ThermalRow {
    pub run_id: RunId,
    pub run_time: i64,
    /// The parameters' JSON.
    pub parameters: String,
    pub temperature_c: f64,
}

/// A unit's summary columns (`u` the unit, `v` its latest result).
const UNIT_COLUMNS: &str = "u.serial, u.created_at,
    (SELECT COUNT(*) FROM runs r WHERE r.unit_serial = u.serial) AS runs,
    (SELECT COUNT(*) FROM results s WHERE s.unit_serial = u.serial) AS calibrated,
    (SELECT MAX(run_time) FROM runs r WHERE r.unit_serial = u.serial) AS last_run_time,
    v.completed_at AS calibrated_at, u.product, v.run_id AS verdict_run_id, v.verdict_detail, v.verdict_product,
    v.verdict_revision, v.verdict_at
    FROM units u LEFT JOIN results v ON v.run_id =
        (SELECT s.run_id FROM results s WHERE s.unit_serial = u.serial
         ORDER BY s.run_time DESC, s.run_id DESC LIMIT 1)";

impl Store {
    pub async fn get_result(
        &self,
        run_id: RunId,
    ) -> Result<Option<Stored<CalibrationResult>>, StoreError> {
        let json: Option<String> =
            sqlx::query_scalar("SELECT result FROM result_documents WHERE run_id = $1")
                .bind(run_id)
                .fetch_optional(&self.read)
                .await?;
        Ok(json.map(Stored::new))
    }

    /// The report of a run's most recent successful diagnosis.
    pub async fn latest_diagnosis(
        &self,
        run_id: RunId,
    ) -> Result<Option<Stored<DiagnoseReport>>, StoreError> {
        let json: Option<String> = sqlx::query_scalar(
            "SELECT report FROM diagnoses WHERE run_id = $1
             ORDER BY completed_at DESC, job_id DESC LIMIT 1",
        )
        .bind(run_id)
        .fetch_optional(&self.read)
        .await?;
        Ok(json.map(Stored::new))
    }

    /// A page of units in serial order, filtered by their latest run's
    /// product and their latest calibrated run's verdict (indexed columns
    /// of `units`, kept up to date by the store).
    pub async fn list_units(
        &self,
        filter: &UnitFilter,
        limit: i64,
        offset: i64,
    ) -> Result<(i64, Vec<UnitSummary>), StoreError> {
        // Each condition takes the next parameter number; LIMIT and OFFSET
        // follow the last.
        let mut conditions: Vec<String> = Vec::new();
        let mut next = |condition: &str| {
            let n = conditions.len() + 1;
            conditions.push(condition.replace("$?", &format!("${n}")));
        };
        if filter.verdict.is_some() {
            next("u.verdict = $?");
        }
        if filter.product.is_some() {
            next("u.product = $?");
        }
        // LIKE's wildcards in the search text match themselves.
        let pattern = filter.serial_contains.as_ref().map(|text| {
            let escaped = text
                .replace('\\', "\\\\")
                .replace('%', "\\%")
                .replace('_', "\\_");
            format!("%{escaped}%")
        });
        if pattern.is_some() {
            next("u.serial LIKE $? ESCAPE '\\'");
        }
        let (limit_n, offset_n) = (conditions.len() + 1, conditions.len() + 2);
        let filter_sql = if conditions.is_empty() {
            String::new()
        } else {
            format!("WHERE {}", conditions.join(" AND "))
        };
        let count_sql = format!("SELECT COUNT(*) FROM units u {filter_sql}");
        let mut count = sqlx::query_scalar(&count_sql);
        let rows_sql =
            format!("SELECT {UNIT_COLUMNS} {filter_sql} ORDER BY u.serial LIMIT ${limit_n} OFFSET ${offset_n}");
        let mut rows = sqlx::query_as(&rows_sql);
        if let Some(v) = filter.verdict {
            count = count.bind(v.as_str());
            rows = rows.bind(v.as_str());
        }
        if let Some(p) = &filter.product {
            count = count.bind(p);
            rows = rows.bind(p);
        }
        if let Some(p) = &pattern {
            count = count.bind(p);
            rows = rows.bind(p);
        }
        let total = count.fetch_one(&self.read).await?;
        let rows = rows.bind(limit).bind(offset).fetch_all(&self.read).await?;
        Ok((total, rows))
    }

    pub async fn get_unit(&self, serial: &UnitSerial) -> Result<Option<UnitSummary>, StoreError> {
        Ok(
            sqlx::query_as(&format!("SELECT {UNIT_COLUMNS} WHERE u.serial = $1"))
                .bind(serial.as_str())
                .fetch_optional(&self.read)
                .await?,
        )
    }

    /// Jobs of a unit's runs per state.
    pub async fn unit_job_counts(&self, serial: &UnitSerial) -> Result<JobCounts, StoreError> {
        let rows = sqlx::query_as(
            "SELECT j.state, COUNT(*) AS n FROM jobs j JOIN runs r ON r.id = j.run_id
             WHERE r.unit_serial = $1 GROUP BY j.state",
        )
        .bind(serial.as_str())
        .fetch_all(&self.read)
        .await?;
        Ok(by_state(rows))
    }

    /// A unit's calibrated runs with `from <= run_time < to`, oldest first,
    /// only those with the verdict `verdict` when given (index
    /// `results_unit_verdict`).
    pub async fn history(
        &self,
        serial: &UnitSerial,
        (from, to): (i64, i64),
        verdict: Option<VerdictStatus>,
        limit: i64,
        offset: i64,
    ) -> Result<(i64, Vec<HistoryRow>), StoreError> {
        // Two fixed statements rather than `?4 IS NULL OR …`, which the
        // planner cannot serve from an index.
        let filter = if verdict.is_some() {
            "unit_serial = $1 AND verdict = $4 AND run_time >= $2 AND run_time < $3"
        } else {
            "unit_serial = $1 AND run_time >= $2 AND run_time < $3 AND $4 IS NULL"
        };
        let total = sqlx::query_scalar(&format!("SELECT COUNT(*) FROM results WHERE {filter}"))
            .bind(serial.as_str())
            .bind(from)
            .bind(to)
            .bind(verdict.map(VerdictStatus::as_str))
            .fetch_one(&self.read)
            .await?;
        let rows = sqlx::query_as(&format!(
            "SELECT run_id, job_id, run_time, completed_at, parameters, model, model_adequate,
                    model_summary, verdict_detail, verdict_product, verdict_revision, verdict_at
             FROM results
             WHERE {filter}
             ORDER BY run_time, run_id LIMIT $5 OFFSET $6"
        ))
        .bind(serial.as_str())
        .bind(from)
        .bind(to)
        .bind(verdict.map(VerdictStatus::as_str))
        .bind(limit)
        .bind(offset)
        .fetch_all(&self.read)
        .await?;
        Ok((total, rows))
    }

    /// A unit's calibrated runs that state a temperature spanning at most
    /// `max_span_c`, with `from <= run_time < to` and, when given, the
    /// verdict `verdict`, oldest first: what its thermal model is fitted
    /// from.
    pub async fn thermal_rows(
        &self,
        serial: &UnitSerial,
        (from, to): (i64, i64),
        verdict: Option<VerdictStatus>,
        max_span_c: f64,
    ) -> Result<Vec<ThermalRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT run_id, run_time, parameters, temperature_c FROM results
             WHERE unit_serial = $1 AND run_time >= $2 AND run_time < $3
               AND temperature_c IS NOT NULL AND temperature_span_c <= $4
               AND ($5 IS NULL OR verdict = $5)
             ORDER BY run_time, run_id",
        )
        .bind(serial.as_str())
        .bind(from)
        .bind(to)
        .bind(max_span_c)
        .bind(verdict.map(VerdictStatus::as_str))
        .fetch_all(&self.read)
        .await?)
    }

    /// Per-parameter spread over a unit's calibrated runs with
    /// `run_time >= since`, the `last` most recent of them (`None`: all),
    /// and those runs with their models.
    ///
    /// One range scan of `results_unit_time_run` reading one value blob
    /// (with the run's id, time and model) per run, in time order (ties by
    /// run id, as history orders them).
    pub async fn repeatability(
        &self,
        serial: &UnitSerial,
        since: i64,
        last: Option<i64>,
    ) -> Result<UnitSpread, StoreError> {
        // Newest first so that LIMIT keeps the `last` most recent (all of
        // them: the largest LIMIT both engines take), then back to time
        // order.
        let mut rows: Vec<SpreadRow> = sqlx::query_as(
            "SELECT run_id, run_time, model, param_values FROM results
             WHERE unit_serial = $1 AND run_time >= $2
             ORDER BY run_time DESC, run_id DESC LIMIT $3",
        )
        .bind(serial.as_str())
        .bind(since)
        .bind(last.unwrap_or(i64::MAX))
        .fetch_all(&self.read)
        .await?;
        rows.reverse();
        UnitSpread::of(rows)
    }

    /// Per-parameter spread over a unit's calibrated runs up to and
    /// including `run_time` (ties by run id, up to `run_id`), with those
    /// runs and their models: the runs a certificate of that run states its
    /// repeatability over, which later runs do not change.
    pub async fn repeatability_through(
        &self,
        serial: &UnitSerial,
        run_time: i64,
        run_id: RunId,
    ) -> Result<UnitSpread, StoreError> {
        let rows: Vec<SpreadRow> = sqlx::query_as(
            "SELECT run_id, run_time, model, param_values FROM results
             WHERE unit_serial = $1 AND (run_time < $2 OR (run_time = $2 AND run_id <= $3))
             ORDER BY run_time, run_id",
        )
        .bind(serial.as_str())
        .bind(run_time)
        .bind(run_id)
        .fetch_all(&self.read)
        .await?;
        UnitSpread::of(rows)
    }

    /// Stores a finished result for a run directly (benchmark seeding and
    /// tests of the statistics): a run and a succeeded job in one
    /// transaction.
    pub async fn seed_calibrated_run(
        &self,
        new: &NewRun,
        parameters: &BTreeMap<String, ParameterEstimate>,
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        let run_time = new.recorded_at.unwrap_or(new.uploaded_at);
        insert_unit_and_run(&mut tx, new).await?;
        sqlx::query(
            "INSERT INTO jobs (id, run_id, state, attempts, max_attempts, run_after, progress, created_at, finished_at)
             VALUES ($1, $2, 'succeeded', 1, $3, $4, 1, $5, $6)",
        )
        .bind(new.job_id)
        .bind(new.run_id)
        .bind(new.max_attempts)
        .bind(new.uploaded_at)
        .bind(new.uploaded_at)
        .bind(new.uploaded_at)
        .execute(&mut *tx)
        .await?;
        let document = serde_json::json!({ "parameters": parameters }).to_string();
        let stored = StoredResult {
            run_id: new.run_id,
            job_id: new.job_id,
            unit_serial: &new.unit_serial,
            run_time,
            completed_at: new.uploaded_at,
            parameters,
            model_check: None,
            poorly_observable: &[],
            cross_check_flagged: &[],
            temperature: None,
            scheme: None,
            model: None,
            document: &document,
        };
        insert_result(&mut tx, &stored).await?;
        tx.commit().await?;
        Ok(())
    }
}

/// A finished calibration as stored: the summary row history and
/// repeatability read, and the whole document apart.
pub(super) struct StoredResult<'a> {
    pub(super) run_id: RunId,
    pub(super) job_id: JobId,
    pub(super) unit_serial: &'a UnitSerial,
    pub(super) run_time: i64,
    pub(super) completed_at: i64,
    pub(super) parameters: &'a BTreeMap<String, ParameterEstimate>,
    pub(super) model_check: Option<&'a ModelCheck>,
    pub(super) poorly_observable: &'a [String],
    pub(super) cross_check_flagged: &'a [String],
    /// The run's temperature, when it stated one.
    pub(super) temperature: Option<RunTemperature>,
    /// Its dwells against its declared scheme's positions, when declared.
    pub(super) scheme: Option<SchemeCoverage>,
    /// The model it was made with (`None`: not known, a seeded result).
    pub(super) model: Option<&'a ErrorModel>,
    /// The whole `CalibrationResult` JSON.
    pub(super) document: &'a str,
}

pub(super) async fn insert_result(
    tx: &mut WriteTx,
    r: &StoredResult<'_>,
) -> Result<(), StoreError> {
    sqlx::query(
        "INSERT INTO results (run_id, job_id, unit_serial, run_time, completed_at, parameters,
                              param_values, model_adequate, model_summary, poorly_observable,
                              cross_check_flagged, temperature_c, temperature_span_c,
                              scheme_dwells_found, scheme_positions_declared, model)
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16)",
    )
    .bind(r.run_id)
    .bind(r.job_id)
    .bind(r.unit_serial.as_str())
    .bind(r.run_time)
    .bind(r.completed_at)
    .bind(serde_json::to_string(r.parameters)?)
    .bind(spread::encode(r.parameters))
    .bind(r.model_check.map(|c| c.adequate))
    .bind(r.model_check.map(|c| c.summary.as_str()))
    .bind(serde_json::to_string(r.poorly_observable)?)
    .bind(serde_json::to_string(r.cross_check_flagged)?)
    .bind(r.temperature.map(|t| t.mean_c))
    .bind(r.temperature.map(|t| t.max_c - t.min_c))
    .bind(r.scheme.map(|s| s.dwells_found as i64))
    .bind(r.scheme.map(|s| s.positions_declared as i64))
    .bind(r.model.map(ErrorModel::to_string))
    .execute(&mut **tx)
    .await?;
    sqlx::query("INSERT INTO result_documents (run_id, result) VALUES ($1, $2)")
        .bind(r.run_id)
        .bind(r.document)
        .execute(&mut **tx)
        .await?;
    // Its verdict, and those of any results after it in the unit's history
    // (their repeatability now includes it).
    refresh_unit(
        tx,
        r.unit_serial.as_str(),
        Some((r.run_time, r.run_id)),
        r.completed_at,
    )
    .await
}
