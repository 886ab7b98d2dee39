//! Runs: the row an upload writes with its calibration job, reads of a run,
//! and deletion. (The run's file on disk is `crate::runfiles`'s; a row
//! only names it by `blob_path`.)

use sqlx::FromRow;

use super::db::{now_ms, Store, WriteTx};
use super::dialect::{hint_job_queued, lock_key, run_key, unit_key};
use super::document::Stored;
use super::error::StoreError;
use super::ids::{JobId, RunId};
use super::jobs::count_queued;
use super::kinds::{Flag, JobState, OptionalFlag};
use super::verdicts::{refresh_unit, refresh_unit_row, StoredVerdict};
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::UnitSerial;

/// A run's row with its calibration job and its result's columns (`r` the
/// run).
const RUN_COLUMNS: &str =
    "r.*, j.id AS job_id, j.state AS job_state, res.run_id IS NOT NULL AS calibrated,
    res.model_adequate, res.model_summary, res.verdict_detail,
    res.verdict_product, res.verdict_revision, res.verdict_at FROM runs r
    JOIN jobs j ON j.run_id = r.id AND j.kind = 'calibrate'
    LEFT JOIN results res ON res.run_id = r.id";

/// A run's file as stored: what an upload writes and a run row reads back.
#[derive(Clone, Debug, FromRow)]
pub struct RunFile {
    pub sha256: String,
    pub size_bytes: i64,
    pub records: i64,
    #[sqlx(try_from = "String")]
    pub format: DataFormat,
    #[sqlx(try_from = "Flag")]
    pub gzip: bool,
    pub blob_path: String,
    /// The metadata (SPEC §5), validated at upload.
    #[sqlx(try_from = "String")]
    pub metadata: Stored<RunMetadata>,
}

/// A stored run, with its job's id.
#[derive(Clone, Debug, FromRow)]
pub struct RunRow {
    pub id: RunId,
    #[sqlx(try_from = "String")]
    pub unit_serial: UnitSerial,
    #[sqlx(flatten)]
    pub file: RunFile,
    pub recorded_at: Option<i64>,
    pub run_time: i64,
    pub uploaded_at: i64,
    /// The token that uploaded it (`None` for runs stored before uploaders
    /// were recorded).
    pub uploaded_by: Option<String>,
    pub job_id: JobId,
    /// Its calibration job's state.
    pub job_state: JobState,
    /// The model adopted for the run from a diagnosis, and when (`None`:
    /// its calibration carries its product type's or the server's).
    #[sqlx(default)]
    pub model: Option<String>,
    #[sqlx(default)]
    pub model_adopted_at: Option<i64>,
    /// Whether the run has a result (read by [`Store::get_run`]).
    #[sqlx(default, try_from = "Flag")]
    pub calibrated: bool,
    /// The result's model check, when there is a result.
    #[sqlx(default, try_from = "OptionalFlag")]
    pub model_adequate: Option<bool>,
    #[sqlx(default)]
    pub model_summary: Option<String>,
    /// The result's verdict columns, when there is a result.
    #[sqlx(default)]
    pub verdict_detail: Option<String>,
    #[sqlx(default)]
    pub verdict_product: Option<String>,
    #[sqlx(default)]
    pub verdict_revision: Option<i64>,
    #[sqlx(default)]
    pub verdict_at: Option<i64>,
}

impl RunRow {
    /// The result's verdict, once there is one.
    pub fn verdict(&self) -> Result<Option<StoredVerdict>, StoreError> {
        StoredVerdict::from_columns(
            self.id,
            self.verdict_detail.as_deref(),
            self.verdict_product.clone(),
            self.verdict_revision,
            self.verdict_at,
        )
    }
}

/// Whether a run needs an engineer's look.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Review {
    /// Not calibrated yet.
    Pending,
    /// Calibrated, and the model explains the run.
    Clear,
    /// Calibrated, but the model check found a misfit the 24 parameters
    /// cannot explain: the values may be biased by a missing effect.
    NeedsReview,
}

impl Review {
    /// The review of a run from its result: none yet, or its model check
    /// (a result stored before the check existed counts as clear).
    pub fn of(calibrated: bool, model_adequate: Option<bool>) -> Self {
        match (calibrated, model_adequate) {
            (false, _) => Review::Pending,
            (true, Some(false)) => Review::NeedsReview,
            (true, _) => Review::Clear,
        }
    }
}

/// What an upload stores once its bytes are on disk.
#[derive(Clone, Debug)]
pub struct NewRun {
    pub run_id: RunId,
    pub job_id: JobId,
    pub unit_serial: UnitSerial,
    pub file: RunFile,
    pub recorded_at: Option<i64>,
    pub uploaded_at: i64,
    pub max_attempts: i64,
    /// The uploading token's id.
    pub uploaded_by: Option<String>,
    /// The product the metadata names.
    pub product: Option<String>,
}

#[cfg(test)]
impl NewRun {
    /// A run of `serial` recorded at `recorded_at` (ms), naming `product`,
    /// with an empty CSV file of its own: what the store's tests seed.
    pub(crate) fn for_test(serial: &str, recorded_at: i64, product: Option<&str>) -> Self {
        let id = RunId::new();
        NewRun {
            run_id: id,
            job_id: JobId::new(),
            unit_serial: serial.parse().unwrap(),
            file: RunFile {
                sha256: id.to_string(),
                size_bytes: 0,
                records: 0,
                format: DataFormat::Csv,
                gzip: false,
                blob_path: format!("runs/x/{id}.csv"),
                metadata: Stored::new("{}".into()),
            },
            recorded_at: Some(recorded_at),
            uploaded_at: 0,
            max_attempts: 1,
            uploaded_by: None,
            product: product.map(str::to_string),
        }
    }
}

/// What `insert_run_and_job` did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InsertOutcome {
    Created,
    /// The same bytes were already stored for this unit: its run and job.
    Existing {
        run_id: RunId,
        job_id: JobId,
    },
    /// The queue holds `max_queue` jobs already.
    QueueFull,
}

/// What `delete_run` did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RunDeletion {
    /// The rows are gone; the run's file (this blob path) is the caller's
    /// to remove.
    Deleted {
        blob_path: String,
    },
    NoRun,
    /// One of the run's jobs is in this state (running): nothing deleted.
    JobBusy(JobState),
}

/// A run's id and its calibration job's id.
#[derive(FromRow)]
struct RunAndJob {
    run_id: RunId,
    job_id: JobId,
}

impl Store {
    pub async fn find_run_by_hash(
        &self,
        unit_serial: &UnitSerial,
        sha256: &str,
    ) -> Result<Option<RunRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT r.*, j.id AS job_id, j.state AS job_state FROM runs r
             JOIN jobs j ON j.run_id = r.id AND j.kind = 'calibrate'
             WHERE r.unit_serial = $1 AND r.sha256 = $2",
        )
        .bind(unit_serial.as_str())
        .bind(sha256)
        .fetch_optional(&self.read)
        .await?)
    }

    /// Writes a run and its job in one transaction, unless the same bytes
    /// are already stored for the unit or the queue is full.
    pub async fn insert_run_and_job(
        &self,
        new: &NewRun,
        max_queue: i64,
    ) -> Result<InsertOutcome, StoreError> {
        let mut tx = self.begin_write().await?;
        // Two servers receiving the same bytes for the unit at once: the
        // second waits, then finds the first's run.
        lock_key(self.backend, &mut tx, &unit_key(new.unit_serial.as_str())).await?;
        let existing: Option<RunAndJob> = sqlx::query_as(
            "SELECT r.id AS run_id, j.id AS job_id FROM runs r
             JOIN jobs j ON j.run_id = r.id AND j.kind = 'calibrate'
             WHERE r.unit_serial = $1 AND r.sha256 = $2",
        )
        .bind(new.unit_serial.as_str())
        .bind(&new.file.sha256)
        .fetch_optional(&mut *tx)
        .await?;
        if let Some(RunAndJob { run_id, job_id }) = existing {
            return Ok(InsertOutcome::Existing { run_id, job_id });
        }
        if count_queued(&mut *tx).await? >= max_queue {
            return Ok(InsertOutcome::QueueFull);
        }
        insert_unit_and_run(&mut tx, new).await?;
        sqlx::query(
            "INSERT INTO jobs (id, run_id, state, max_attempts, run_after, created_at)
             VALUES ($1, $2, 'queued', $3, $4, $5)",
        )
        .bind(new.job_id)
        .bind(new.run_id)
        .bind(new.max_attempts)
        .bind(new.uploaded_at)
        .bind(new.uploaded_at)
        .execute(&mut *tx)
        .await?;
        hint_job_queued(self.backend, &mut tx).await?;
        tx.commit().await?;
        Ok(InsertOutcome::Created)
    }

    pub async fn get_run(&self, id: RunId) -> Result<Option<RunRow>, StoreError> {
        Ok(
            sqlx::query_as(&format!("SELECT {RUN_COLUMNS} WHERE r.id = $1"))
                .bind(id)
                .fetch_optional(&self.read)
                .await?,
        )
    }

    /// The latest runs a token uploaded, newest first (index
    /// `runs_uploaded_by`): what a station's upload page lists.
    pub async fn runs_uploaded_by(
        &self,
        token_id: &str,
        limit: i64,
    ) -> Result<Vec<RunRow>, StoreError> {
        Ok(sqlx::query_as(&format!(
            "SELECT {RUN_COLUMNS} WHERE r.uploaded_by = $1
             ORDER BY r.uploaded_at DESC, r.id DESC LIMIT $2"
        ))
        .bind(token_id)
        .bind(limit)
        .fetch_all(&self.read)
        .await?)
    }

    /// Every stored blob path: the startup sweep keeps these and removes
    /// any other run file.
    pub async fn all_blob_paths(&self) -> Result<Vec<String>, StoreError> {
        Ok(sqlx::query_scalar("SELECT blob_path FROM runs")
            .fetch_all(&self.read)
            .await?)
    }

    /// Deletes a run with its jobs, results and diagnoses, unless one of
    /// its jobs is running.
    pub async fn delete_run(&self, id: RunId) -> Result<RunDeletion, StoreError> {
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, &run_key(id)).await?;
        let run: Option<(String, String, i64)> =
            sqlx::query_as("SELECT blob_path, unit_serial, run_time FROM runs WHERE id = $1")
                .bind(id)
                .fetch_optional(&mut *tx)
                .await?;
        let Some((blob_path, serial, run_time)) = run else {
            return Ok(RunDeletion::NoRun);
        };
        lock_key(self.backend, &mut tx, &unit_key(&serial)).await?;
        // Any of the run's jobs (calibration or diagnosis) still working
        // holds its file open and would write rows after the delete.
        let running: i64 =
            sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE run_id = $1 AND state = 'running'")
                .bind(id)
                .fetch_one(&mut *tx)
                .await?;
        if running > 0 {
            return Ok(RunDeletion::JobBusy(JobState::Running));
        }
        for sql in [
            "DELETE FROM result_documents WHERE run_id = $1",
            "DELETE FROM results WHERE run_id = $1",
            "DELETE FROM diagnoses WHERE run_id = $1",
            "DELETE FROM jobs WHERE run_id = $1",
            "DELETE FROM runs WHERE id = $1",
        ] {
            sqlx::query(sql).bind(id).execute(&mut *tx).await?;
        }
        // Later results lose this one from their repeatability.
        refresh_unit(&mut tx, &serial, Some((run_time, id)), now_ms()).await?;
        tx.commit().await?;
        Ok(RunDeletion::Deleted { blob_path })
    }
}

/// The unit's row unless it exists, inside the caller's write
/// transaction, created at `now` (ms).
pub(super) async fn insert_unit(
    tx: &mut WriteTx,
    serial: &UnitSerial,
    now: i64,
) -> Result<(), StoreError> {
    sqlx::query("INSERT INTO units (serial, created_at) VALUES ($1, $2) ON CONFLICT DO NOTHING")
        .bind(serial.as_str())
        .bind(now)
        .execute(&mut **tx)
        .await?;
    Ok(())
}

/// The unit (if new) and the run's row, inside the caller's write
/// transaction; a run's time is its recording time, else its upload time.
pub(super) async fn insert_unit_and_run(tx: &mut WriteTx, new: &NewRun) -> Result<(), StoreError> {
    insert_unit(tx, &new.unit_serial, new.uploaded_at).await?;
    sqlx::query(
        "INSERT INTO runs (id, unit_serial, sha256, size_bytes, records, format, gzip, blob_path,
                           metadata, recorded_at, run_time, uploaded_at, uploaded_by, product)
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14)",
    )
    .bind(new.run_id)
    .bind(new.unit_serial.as_str())
    .bind(&new.file.sha256)
    .bind(new.file.size_bytes)
    .bind(new.file.records)
    .bind(new.file.format.as_str())
    .bind(new.file.gzip)
    .bind(&new.file.blob_path)
    .bind(new.file.metadata.as_json())
    .bind(new.recorded_at)
    .bind(new.recorded_at.unwrap_or(new.uploaded_at))
    .bind(new.uploaded_at)
    .bind(&new.uploaded_by)
    .bind(&new.product)
    .execute(&mut **tx)
    .await?;
    refresh_unit_row(tx, new.unit_serial.as_str()).await
}
