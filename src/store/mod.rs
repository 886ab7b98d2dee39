//! The server's SQLite database: the pool, the migrations and every SQL
//! statement of the project. Nothing outside this module writes SQL.
//!
//! Durability choices (see docs/ARCHITECTURE.md, "Server"):
//! - WAL journal, set explicitly (sqlx does not choose it for us), so readers
//!   never block the writer.
//! - `synchronous = FULL`: in WAL mode a commit survives a process crash at
//!   any level, but survives power loss only at FULL. A calibration run is
//!   expensive to repeat and the server commits a few rows a second, so the
//!   extra fsync per commit is cheap insurance.
//! - Every write goes through one writer connection and every write
//!   transaction starts with `BEGIN IMMEDIATE`: a deferred `BEGIN` that later
//!   writes can fail with SQLITE_BUSY without waiting for the busy timeout.
//!   Reads use a separate pool and never take the write lock.

use std::collections::BTreeMap;
use std::path::Path;
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use sqlx::sqlite::{
    SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteSynchronous,
};
use sqlx::{FromRow, Row};

use crate::calib::{CalibrationResult, ModelCheck, ParameterEstimate};

mod spread;
pub use spread::ParamSpread;
use spread::SpreadAccumulator;

/// The migrations in `migrations/`, embedded in the binary so that a fresh
/// machine needs nothing but the executable.
static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("./migrations");

/// How long a statement waits for a lock held by another connection (the
/// `sinscal token create` CLI, a second server) before SQLITE_BUSY.
const BUSY_TIMEOUT: Duration = Duration::from_secs(10);

/// Errors of the storage layer.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The disk (or quota) holding the database is full: SQLITE_FULL,
    /// ENOSPC or EDQUOT. Transient: the write may succeed once space is
    /// freed, and the writer connection stays usable.
    #[error("storage full: {0}")]
    StorageFull(String),
    #[error("database error: {0}")]
    Db(sqlx::Error),
    #[error("database migration failed: {0}")]
    Migrate(#[from] sqlx::migrate::MigrateError),
    #[error("stored JSON is malformed: {0}")]
    Json(#[from] serde_json::Error),
}

/// SQLite's primary result code for "database or disk is full".
const SQLITE_FULL: i64 = 13;

/// Whether an I/O error means the disk or the quota is full.
pub fn is_storage_full_io(e: &std::io::Error) -> bool {
    matches!(e.raw_os_error(), Some(code) if code == ENOSPC || code == EDQUOT)
}

/// Linux errno values (stable ABI): no space left on device, disk quota
/// exceeded.
const ENOSPC: i32 = 28;
const EDQUOT: i32 = 122;

impl From<sqlx::Error> for StoreError {
    fn from(e: sqlx::Error) -> Self {
        let full = match &e {
            sqlx::Error::Database(db) => db
                .code()
                .and_then(|c| c.parse::<i64>().ok())
                // Extended result codes keep the primary code in the low byte.
                .is_some_and(|c| c & 0xff == SQLITE_FULL),
            sqlx::Error::Io(io) => is_storage_full_io(io),
            _ => false,
        };
        if full {
            StoreError::StorageFull(e.to_string())
        } else {
            StoreError::Db(e)
        }
    }
}

impl StoreError {
    /// True for errors that say the disk is full (retry once space returns).
    pub fn is_storage_full(&self) -> bool {
        matches!(self, StoreError::StorageFull(_))
    }
}

/// Milliseconds since the Unix epoch, the unit of every stored time.
pub fn now_ms() -> i64 {
    chrono::Utc::now().timestamp_millis()
}

/// The database: a single-connection writer pool and a reader pool.
#[derive(Clone, Debug)]
pub struct Store {
    read: SqlitePool,
    write: SqlitePool,
    /// While set, every write transaction fails as if the disk were full:
    /// the seam tests use where a small filesystem cannot be mounted.
    simulate_full: Arc<AtomicBool>,
}

/// A bearer token's role.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Uploads runs and follows their jobs.
    Station,
    /// Reads everything, cancels jobs.
    Engineer,
    /// Everything, including tokens and deletes.
    Admin,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Station => "station",
            Role::Engineer => "engineer",
            Role::Admin => "admin",
        }
    }
}

impl FromStr for Role {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "station" => Ok(Role::Station),
            "engineer" => Ok(Role::Engineer),
            "admin" => Ok(Role::Admin),
            other => Err(format!(
                "unknown role {other:?}: station, engineer or admin"
            )),
        }
    }
}

#[derive(Clone, Debug, FromRow, serde::Serialize)]
pub struct TokenRow {
    pub id: String,
    pub role: String,
    pub label: Option<String>,
    pub created_at: i64,
    pub revoked_at: Option<i64>,
}

/// A stored run, with its job's id.
#[derive(Clone, Debug, FromRow)]
pub struct RunRow {
    pub id: String,
    pub unit_serial: String,
    pub sha256: String,
    pub size_bytes: i64,
    pub records: i64,
    pub format: String,
    pub gzip: bool,
    pub blob_path: String,
    pub metadata: String,
    pub recorded_at: Option<i64>,
    pub run_time: i64,
    pub uploaded_at: i64,
    /// The token that uploaded it (`None` for runs stored before uploaders
    /// were recorded).
    pub uploaded_by: Option<String>,
    pub job_id: String,
    /// Whether the run has a result (read by [`Store::get_run`]).
    #[sqlx(default)]
    pub calibrated: bool,
    /// The result's model check, when there is a result.
    #[sqlx(default)]
    pub model_adequate: Option<bool>,
    #[sqlx(default)]
    pub model_summary: Option<String>,
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

/// What storing a result sets going when its model check fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OnInadequate {
    /// Queue a diagnose job for the run (unless one is queued or running).
    pub queue_diagnose: bool,
    /// Its attempts, as for any job.
    pub max_attempts: i64,
}

#[derive(Clone, Debug, FromRow)]
pub struct JobRow {
    pub id: String,
    pub run_id: String,
    /// `calibrate` or `diagnose`.
    pub kind: String,
    pub state: String,
    pub attempts: i64,
    pub max_attempts: i64,
    pub lease_owner: Option<String>,
    pub lease_expires_at: Option<i64>,
    pub heartbeat_at: Option<i64>,
    pub progress: f64,
    pub stage: Option<String>,
    pub cancel_requested: bool,
    pub error: Option<String>,
    pub created_at: i64,
    pub started_at: Option<i64>,
    pub finished_at: Option<i64>,
}

/// What an upload stores once its bytes are on disk.
#[derive(Clone, Debug)]
pub struct NewRun {
    pub run_id: String,
    pub job_id: String,
    pub unit_serial: String,
    pub sha256: String,
    pub size_bytes: i64,
    pub records: i64,
    pub format: String,
    pub gzip: bool,
    pub blob_path: String,
    pub metadata: String,
    pub recorded_at: Option<i64>,
    pub uploaded_at: i64,
    pub max_attempts: i64,
    /// The uploading token's id.
    pub uploaded_by: Option<String>,
}

/// What `insert_run_and_job` did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InsertOutcome {
    Created,
    /// The same bytes were already stored for this unit: its run and job.
    Existing {
        run_id: String,
        job_id: String,
    },
    /// The queue holds `max_queue` jobs already.
    QueueFull,
}

/// What `queue_diagnose_job` did.
#[derive(Clone, Debug)]
pub enum DiagnoseQueued {
    /// A new diagnose job, queued.
    Created(JobRow),
    /// A diagnose job for this run was already queued or running: it.
    Existing(JobRow),
    NoRun,
    /// The queue holds `max_queue` jobs already.
    QueueFull,
}

/// The identity of one attempt at a job. Every write a worker makes about
/// its job must match all three fields: a worker whose lease was reclaimed
/// (and whose job was claimed again, so `attempt` moved on) cannot write
/// over the new attempt.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fence {
    pub job_id: String,
    pub attempt: i64,
    pub owner: String,
}

/// A job a worker has just claimed.
#[derive(Clone, Debug)]
pub struct Claim {
    pub fence: Fence,
    /// `calibrate` or `diagnose`: what the worker runs.
    pub kind: String,
    pub run_id: String,
    pub unit_serial: String,
    pub run_time: i64,
    pub blob_path: String,
    pub metadata: String,
    pub max_attempts: i64,
}

#[derive(Clone, Debug, FromRow)]
pub struct UnitSummary {
    pub serial: String,
    pub created_at: i64,
    pub runs: i64,
    pub calibrated: i64,
    pub last_run_time: Option<i64>,
}

#[derive(Clone, Debug, FromRow)]
pub struct HistoryRow {
    pub run_id: String,
    pub job_id: String,
    pub run_time: i64,
    pub completed_at: i64,
    pub parameters: String,
    pub model_adequate: Option<bool>,
    pub model_summary: Option<String>,
}

fn connect_options(db_path: &Path) -> SqliteConnectOptions {
    SqliteConnectOptions::new()
        .filename(db_path)
        .create_if_missing(true)
        .journal_mode(SqliteJournalMode::Wal)
        .synchronous(SqliteSynchronous::Full)
        .busy_timeout(BUSY_TIMEOUT)
        .foreign_keys(true)
}

impl Store {
    /// Opens (creating if needed) the database and applies the migrations.
    pub async fn open(db_path: &Path, readers: u32) -> Result<Store, StoreError> {
        let write = SqlitePoolOptions::new()
            .max_connections(1)
            // A writer waiting for the single connection must not give up
            // while a long transaction (an upload's rows, a backfill) commits.
            .acquire_timeout(Duration::from_secs(30))
            .connect_with(connect_options(db_path))
            .await?;
        MIGRATOR.run(&write).await?;
        backfill_param_values(&write).await?;
        let read = SqlitePoolOptions::new()
            .max_connections(readers.max(1))
            .acquire_timeout(Duration::from_secs(30))
            .connect_with(connect_options(db_path).read_only(true))
            .await?;
        Ok(Store {
            read,
            write,
            simulate_full: Arc::new(AtomicBool::new(false)),
        })
    }

    /// Makes every later write transaction fail with
    /// [`StoreError::StorageFull`] (true) or behave again (false), as a
    /// full disk would, for machines where tests cannot mount a small
    /// filesystem. The failure is raised where `BEGIN IMMEDIATE` would be,
    /// so callers take the same path as for SQLITE_FULL.
    #[doc(hidden)]
    pub fn simulate_storage_full(&self, on: bool) {
        self.simulate_full.store(on, Ordering::SeqCst);
    }

    /// Starts a write transaction on the writer connection.
    ///
    /// When a write fails with SQLITE_FULL, SQLite may roll the transaction
    /// back on its own; the pool's rollback on drop then finds no
    /// transaction, fails, and sqlx keeps counting one open, so every later
    /// `BEGIN` on that connection is refused ("non-zero transaction
    /// depth"). Such a connection is closed here (SQLite rolls back
    /// whatever it still holds) and a fresh one opened, so one failed write
    /// never wedges the writer.
    async fn begin_write(&self) -> Result<sqlx::Transaction<'static, sqlx::Sqlite>, StoreError> {
        if self.simulate_full.load(Ordering::SeqCst) {
            return Err(StoreError::StorageFull(
                "database or disk is full (simulated)".into(),
            ));
        }
        match self.write.begin_with("BEGIN IMMEDIATE").await {
            Err(sqlx::Error::InvalidSavePointStatement) => {
                let conn = self.write.acquire().await?;
                if sqlx::Connection::is_in_transaction(&*conn) {
                    tracing::warn!(
                        "writer connection left inside a failed transaction: reopening it"
                    );
                    let _ = conn.close().await;
                }
                Ok(self.write.begin_with("BEGIN IMMEDIATE").await?)
            }
            other => Ok(other?),
        }
    }

    /// A write that must reach the database file (one row rewritten), for
    /// the readiness probe: fails while the disk is full or the writer is
    /// unusable.
    pub async fn write_probe(&self) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        sqlx::query(
            "INSERT INTO write_probe (id, checked_at) VALUES (1, ?)
             ON CONFLICT (id) DO UPDATE SET checked_at = excluded.checked_at",
        )
        .bind(now_ms())
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(())
    }

    pub async fn close(&self) {
        self.read.close().await;
        self.write.close().await;
    }

    /// `SELECT 1` on both pools: the readiness probe.
    pub async fn ping(&self) -> Result<(), StoreError> {
        sqlx::query("SELECT 1").execute(&self.read).await?;
        sqlx::query("SELECT 1").execute(&self.write).await?;
        Ok(())
    }

    // ----- tokens -------------------------------------------------------

    pub async fn count_tokens(&self) -> Result<i64, StoreError> {
        Ok(sqlx::query_scalar("SELECT COUNT(*) FROM tokens")
            .fetch_one(&self.write)
            .await?)
    }

    pub async fn insert_token(
        &self,
        id: &str,
        hash: &str,
        role: Role,
        label: Option<&str>,
    ) -> Result<(), StoreError> {
        sqlx::query(
            "INSERT INTO tokens (id, hash, role, label, created_at) VALUES (?, ?, ?, ?, ?)",
        )
        .bind(id)
        .bind(hash)
        .bind(role.as_str())
        .bind(label)
        .bind(now_ms())
        .execute(&self.write)
        .await?;
        Ok(())
    }

    /// Inserts the first admin token unless any token exists, atomically, so
    /// two processes starting together cannot both create one.
    pub async fn insert_first_token(&self, id: &str, hash: &str) -> Result<bool, StoreError> {
        let mut tx = self.begin_write().await?;
        let n: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM tokens")
            .fetch_one(&mut *tx)
            .await?;
        if n > 0 {
            return Ok(false);
        }
        sqlx::query(
            "INSERT INTO tokens (id, hash, role, label, created_at) VALUES (?, ?, 'admin', 'first start', ?)",
        )
        .bind(id)
        .bind(hash)
        .bind(now_ms())
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(true)
    }

    /// The role of a live token by its hash.
    pub async fn token_role(&self, hash: &str) -> Result<Option<(String, Role)>, StoreError> {
        let row = sqlx::query("SELECT id, role FROM tokens WHERE hash = ? AND revoked_at IS NULL")
            .bind(hash)
            .fetch_optional(&self.read)
            .await?;
        Ok(row.and_then(|r| {
            let role: String = r.get(1);
            role.parse().ok().map(|role| (r.get(0), role))
        }))
    }

    pub async fn list_tokens(&self) -> Result<Vec<TokenRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT id, role, label, created_at, revoked_at FROM tokens ORDER BY created_at, id",
        )
        .fetch_all(&self.read)
        .await?)
    }

    /// Revokes a token; false if no live token has this id.
    pub async fn revoke_token(&self, id: &str) -> Result<bool, StoreError> {
        let r = sqlx::query("UPDATE tokens SET revoked_at = ? WHERE id = ? AND revoked_at IS NULL")
            .bind(now_ms())
            .bind(id)
            .execute(&self.write)
            .await?;
        Ok(r.rows_affected() == 1)
    }

    // ----- runs and uploads --------------------------------------------

    pub async fn find_run_by_hash(
        &self,
        unit_serial: &str,
        sha256: &str,
    ) -> Result<Option<RunRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT r.*, j.id AS job_id FROM runs r
             JOIN jobs j ON j.run_id = r.id AND j.kind = 'calibrate'
             WHERE r.unit_serial = ? AND r.sha256 = ?",
        )
        .bind(unit_serial)
        .bind(sha256)
        .fetch_optional(&self.read)
        .await?)
    }

    pub async fn queue_depth(&self) -> Result<i64, StoreError> {
        Ok(
            sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE state = 'queued'")
                .fetch_one(&self.read)
                .await?,
        )
    }

    /// Writes a run and its job in one transaction, unless the same bytes
    /// are already stored for the unit or the queue is full.
    pub async fn insert_run_and_job(
        &self,
        new: &NewRun,
        max_queue: i64,
    ) -> Result<InsertOutcome, StoreError> {
        let mut tx = self.begin_write().await?;
        let existing = sqlx::query(
            "SELECT r.id, j.id FROM runs r
             JOIN jobs j ON j.run_id = r.id AND j.kind = 'calibrate'
             WHERE r.unit_serial = ? AND r.sha256 = ?",
        )
        .bind(&new.unit_serial)
        .bind(&new.sha256)
        .fetch_optional(&mut *tx)
        .await?;
        if let Some(row) = existing {
            return Ok(InsertOutcome::Existing {
                run_id: row.get(0),
                job_id: row.get(1),
            });
        }
        let depth: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE state = 'queued'")
            .fetch_one(&mut *tx)
            .await?;
        if depth >= max_queue {
            return Ok(InsertOutcome::QueueFull);
        }
        insert_unit_and_run(&mut tx, new).await?;
        sqlx::query(
            "INSERT INTO jobs (id, run_id, state, max_attempts, run_after, created_at)
             VALUES (?, ?, 'queued', ?, ?, ?)",
        )
        .bind(&new.job_id)
        .bind(&new.run_id)
        .bind(new.max_attempts)
        .bind(new.uploaded_at)
        .bind(new.uploaded_at)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(InsertOutcome::Created)
    }

    pub async fn get_run(&self, id: &str) -> Result<Option<RunRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT r.*, j.id AS job_id, res.run_id IS NOT NULL AS calibrated,
                    res.model_adequate, res.model_summary FROM runs r
             JOIN jobs j ON j.run_id = r.id AND j.kind = 'calibrate'
             LEFT JOIN results res ON res.run_id = r.id
             WHERE r.id = ?",
        )
        .bind(id)
        .fetch_optional(&self.read)
        .await?)
    }

    /// Every stored blob path: the startup sweep keeps these and removes
    /// any other file under `runs/`.
    pub async fn all_blob_paths(&self) -> Result<Vec<String>, StoreError> {
        Ok(sqlx::query_scalar("SELECT blob_path FROM runs")
            .fetch_all(&self.read)
            .await?)
    }

    /// Deletes a run with its job and results. `Err(state)` when its job
    /// is running; `Ok(None)` when there is no such run; else the blob path
    /// to remove.
    pub async fn delete_run(&self, id: &str) -> Result<Result<Option<String>, String>, StoreError> {
        let mut tx = self.begin_write().await?;
        let blob: Option<String> = sqlx::query_scalar("SELECT blob_path FROM runs WHERE id = ?")
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?;
        let Some(blob) = blob else {
            return Ok(Ok(None));
        };
        // Any of the run's jobs (calibration or diagnosis) still working
        // holds its file open and would write rows after the delete.
        let running: i64 =
            sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE run_id = ? AND state = 'running'")
                .bind(id)
                .fetch_one(&mut *tx)
                .await?;
        if running > 0 {
            return Ok(Err("running".into()));
        }
        for sql in [
            "DELETE FROM result_documents WHERE run_id = ?",
            "DELETE FROM results WHERE run_id = ?",
            "DELETE FROM diagnoses WHERE run_id = ?",
            "DELETE FROM jobs WHERE run_id = ?",
            "DELETE FROM runs WHERE id = ?",
        ] {
            sqlx::query(sql).bind(id).execute(&mut *tx).await?;
        }
        tx.commit().await?;
        Ok(Ok(Some(blob)))
    }

    // ----- jobs ---------------------------------------------------------

    pub async fn get_job(&self, id: &str) -> Result<Option<JobRow>, StoreError> {
        Ok(sqlx::query_as("SELECT * FROM jobs WHERE id = ?")
            .bind(id)
            .fetch_optional(&self.read)
            .await?)
    }

    /// Jobs per state (every state present, zero included).
    pub async fn job_counts(&self) -> Result<BTreeMap<String, i64>, StoreError> {
        let mut counts: BTreeMap<String, i64> =
            ["queued", "running", "succeeded", "failed", "cancelled"]
                .iter()
                .map(|s| (s.to_string(), 0))
                .collect();
        let rows = sqlx::query("SELECT state, COUNT(*) FROM jobs GROUP BY state")
            .fetch_all(&self.read)
            .await?;
        for r in rows {
            counts.insert(r.get(0), r.get(1));
        }
        Ok(counts)
    }

    /// Cancels a queued job at once, or asks a running one's worker to stop.
    /// Returns the job afterwards, `None` if there is none.
    pub async fn cancel_job(&self, id: &str) -> Result<Option<JobRow>, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        sqlx::query(
            "UPDATE jobs SET state = 'cancelled', finished_at = ?, cancel_requested = 1
             WHERE id = ? AND state = 'queued'",
        )
        .bind(now)
        .bind(id)
        .execute(&mut *tx)
        .await?;
        sqlx::query("UPDATE jobs SET cancel_requested = 1 WHERE id = ? AND state = 'running'")
            .bind(id)
            .execute(&mut *tx)
            .await?;
        let job = sqlx::query_as("SELECT * FROM jobs WHERE id = ?")
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(job)
    }

    /// Claims the oldest claimable job for `owner`: a queued job whose
    /// backoff has passed, or a running job whose lease expired (its worker
    /// died). Expired jobs that were asked to cancel, or that used their
    /// last attempt, are closed instead of claimed.
    pub async fn claim_job(
        &self,
        owner: &str,
        lease: Duration,
    ) -> Result<Option<Claim>, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        sqlx::query(
            "UPDATE jobs SET state = 'cancelled', finished_at = ?1, lease_owner = NULL, lease_expires_at = NULL
             WHERE state = 'running' AND lease_expires_at < ?1 AND cancel_requested = 1",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        sqlx::query(
            "UPDATE jobs SET state = 'failed', finished_at = ?1, lease_owner = NULL, lease_expires_at = NULL,
                    error = 'the worker was lost (lease expired) on the last allowed attempt'
             WHERE state = 'running' AND lease_expires_at < ?1 AND attempts >= max_attempts",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        let claimed = sqlx::query(
            "UPDATE jobs SET state = 'running', attempts = attempts + 1, lease_owner = ?1,
                    lease_expires_at = ?2, heartbeat_at = ?3, started_at = COALESCE(started_at, ?3),
                    progress = 0, stage = 'claimed'
             WHERE id = (SELECT id FROM jobs
                         WHERE (state = 'queued' AND run_after <= ?3)
                            OR (state = 'running' AND lease_expires_at < ?3)
                         ORDER BY created_at, id LIMIT 1)
             RETURNING id, run_id, attempts, max_attempts, kind",
        )
        .bind(owner)
        .bind(now + lease.as_millis() as i64)
        .bind(now)
        .fetch_optional(&mut *tx)
        .await?;
        let Some(c) = claimed else {
            tx.commit().await?;
            return Ok(None);
        };
        let run_id: String = c.get(1);
        let run =
            sqlx::query("SELECT unit_serial, run_time, blob_path, metadata FROM runs WHERE id = ?")
                .bind(&run_id)
                .fetch_one(&mut *tx)
                .await?;
        tx.commit().await?;
        Ok(Some(Claim {
            fence: Fence {
                job_id: c.get(0),
                attempt: c.get(2),
                owner: owner.to_string(),
            },
            max_attempts: c.get(3),
            kind: c.get(4),
            run_id,
            unit_serial: run.get(0),
            run_time: run.get(1),
            blob_path: run.get(2),
            metadata: run.get(3),
        }))
    }

    /// Renews the lease and records progress. `None`: the lease is lost
    /// (reclaimed, or the job was deleted); else whether cancel was asked.
    pub async fn heartbeat(
        &self,
        fence: &Fence,
        lease: Duration,
        progress: f64,
        stage: &str,
    ) -> Result<Option<bool>, StoreError> {
        let now = now_ms();
        let row = sqlx::query(
            "UPDATE jobs SET lease_expires_at = ?, heartbeat_at = ?, progress = ?, stage = ?
             WHERE id = ? AND attempts = ? AND lease_owner = ? AND state = 'running'
             RETURNING cancel_requested",
        )
        .bind(now + lease.as_millis() as i64)
        .bind(now)
        .bind(progress)
        .bind(stage)
        .bind(&fence.job_id)
        .bind(fence.attempt)
        .bind(&fence.owner)
        .fetch_optional(&self.write)
        .await?;
        Ok(row.map(|r| r.get::<bool, _>(0)))
    }

    /// Queues a diagnose job for a run, unless the run does not exist, a
    /// diagnose job for it is already queued or running (returned instead),
    /// or the queue is full.
    pub async fn queue_diagnose_job(
        &self,
        run_id: &str,
        job_id: &str,
        max_attempts: i64,
        max_queue: i64,
    ) -> Result<DiagnoseQueued, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        let exists: Option<i64> = sqlx::query_scalar("SELECT 1 FROM runs WHERE id = ?")
            .bind(run_id)
            .fetch_optional(&mut *tx)
            .await?;
        if exists.is_none() {
            return Ok(DiagnoseQueued::NoRun);
        }
        let active: Option<JobRow> = sqlx::query_as(
            "SELECT * FROM jobs WHERE run_id = ? AND kind = 'diagnose'
                AND state IN ('queued', 'running')",
        )
        .bind(run_id)
        .fetch_optional(&mut *tx)
        .await?;
        if let Some(job) = active {
            return Ok(DiagnoseQueued::Existing(job));
        }
        let depth: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE state = 'queued'")
            .fetch_one(&mut *tx)
            .await?;
        if depth >= max_queue {
            return Ok(DiagnoseQueued::QueueFull);
        }
        let job = sqlx::query_as(
            "INSERT INTO jobs (id, run_id, kind, state, max_attempts, run_after, created_at)
             VALUES (?, ?, 'diagnose', 'queued', ?, ?, ?)
             RETURNING *",
        )
        .bind(job_id)
        .bind(run_id)
        .bind(max_attempts)
        .bind(now)
        .bind(now)
        .fetch_one(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(DiagnoseQueued::Created(job))
    }

    /// Stores a diagnose job's report and marks it succeeded, in one
    /// transaction, if and only if `fence` still holds the lease (as
    /// [`Store::complete_job`]). Writes no calibration result rows.
    pub async fn complete_diagnose_job(
        &self,
        claim: &Claim,
        report: &serde_json::Value,
    ) -> Result<bool, StoreError> {
        let now = now_ms();
        let fence = &claim.fence;
        let report_json = serde_json::to_string(report)?;
        let mut tx = self.begin_write().await?;
        if !mark_succeeded(&mut tx, fence, now).await? {
            tx.rollback().await?;
            return Ok(false);
        }
        sqlx::query(
            "INSERT INTO diagnoses (job_id, run_id, completed_at, report) VALUES (?, ?, ?, ?)",
        )
        .bind(&fence.job_id)
        .bind(&claim.run_id)
        .bind(now)
        .bind(&report_json)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(true)
    }

    /// Stores a result and marks the job succeeded, in one transaction, if
    /// and only if `fence` still holds the lease. False: it did not, and
    /// nothing was written.
    ///
    /// A result whose model check fails (the run then reads
    /// `needs_review`) also queues a diagnose job when `on_inadequate`
    /// says so. That job bypasses the queue limit: there
    /// is at most one per calibrated run, whose upload passed the limit.
    pub async fn complete_job(
        &self,
        claim: &Claim,
        result: &CalibrationResult,
        on_inadequate: OnInadequate,
    ) -> Result<bool, StoreError> {
        let now = now_ms();
        let fence = &claim.fence;
        let result_json = serde_json::to_string(result)?;
        let mut tx = self.begin_write().await?;
        if !mark_succeeded(&mut tx, fence, now).await? {
            tx.rollback().await?;
            return Ok(false);
        }
        let stored = StoredResult {
            run_id: &claim.run_id,
            job_id: &fence.job_id,
            unit_serial: &claim.unit_serial,
            run_time: claim.run_time,
            completed_at: now,
            parameters: &result.parameters,
            model_check: result.model_check.as_ref(),
            document: &result_json,
        };
        insert_result(&mut tx, &stored).await?;
        let adequate = result.model_check.as_ref().map_or(true, |c| c.adequate);
        if !adequate && on_inadequate.queue_diagnose {
            sqlx::query(
                "INSERT INTO jobs (id, run_id, kind, state, max_attempts, run_after, created_at)
                 SELECT ?, ?, 'diagnose', 'queued', ?, ?, ?
                 WHERE NOT EXISTS (SELECT 1 FROM jobs WHERE run_id = ? AND kind = 'diagnose'
                                   AND state IN ('queued', 'running'))",
            )
            .bind(uuid::Uuid::new_v4().to_string())
            .bind(&claim.run_id)
            .bind(on_inadequate.max_attempts)
            .bind(now)
            .bind(now)
            .bind(&claim.run_id)
            .execute(&mut *tx)
            .await?;
        }
        tx.commit().await?;
        Ok(true)
    }

    /// Records a failed attempt: back to the queue after `backoff` while
    /// attempts remain and `retry` holds, else failed for good. The error is
    /// kept either way. Returns the new state, `None` if the lease was lost.
    pub async fn fail_job(
        &self,
        fence: &Fence,
        error: &str,
        retry: bool,
        backoff: Duration,
    ) -> Result<Option<String>, StoreError> {
        let now = now_ms();
        let row = sqlx::query(
            "UPDATE jobs SET
                state = CASE WHEN ?1 AND attempts < max_attempts THEN 'queued' ELSE 'failed' END,
                finished_at = CASE WHEN ?1 AND attempts < max_attempts THEN NULL ELSE ?2 END,
                run_after = ?3, error = ?4, stage = 'failed attempt',
                lease_owner = NULL, lease_expires_at = NULL
             WHERE id = ?5 AND attempts = ?6 AND lease_owner = ?7 AND state = 'running'
             RETURNING state",
        )
        .bind(retry)
        .bind(now)
        .bind(now + backoff.as_millis() as i64)
        .bind(error)
        .bind(&fence.job_id)
        .bind(fence.attempt)
        .bind(&fence.owner)
        .fetch_optional(&self.write)
        .await?;
        Ok(row.map(|r| r.get(0)))
    }

    /// Marks a job cancelled after its worker stopped on request.
    pub async fn finish_cancelled(&self, fence: &Fence) -> Result<bool, StoreError> {
        let r = sqlx::query(
            "UPDATE jobs SET state = 'cancelled', finished_at = ?, stage = 'cancelled',
                    lease_owner = NULL, lease_expires_at = NULL
             WHERE id = ? AND attempts = ? AND lease_owner = ? AND state = 'running'",
        )
        .bind(now_ms())
        .bind(&fence.job_id)
        .bind(fence.attempt)
        .bind(&fence.owner)
        .execute(&self.write)
        .await?;
        Ok(r.rows_affected() == 1)
    }

    /// Hands a job back to the queue at shutdown. The attempt is not
    /// counted: the job did not fail, the server stopped.
    pub async fn release_job(&self, fence: &Fence) -> Result<bool, StoreError> {
        let r = sqlx::query(
            "UPDATE jobs SET state = 'queued', attempts = attempts - 1, run_after = ?,
                    stage = 'handed back at shutdown', progress = 0,
                    lease_owner = NULL, lease_expires_at = NULL
             WHERE id = ? AND attempts = ? AND lease_owner = ? AND state = 'running'",
        )
        .bind(now_ms())
        .bind(&fence.job_id)
        .bind(fence.attempt)
        .bind(&fence.owner)
        .execute(&self.write)
        .await?;
        Ok(r.rows_affected() == 1)
    }

    // ----- results, units, statistics ----------------------------------

    pub async fn get_result(&self, run_id: &str) -> Result<Option<String>, StoreError> {
        Ok(
            sqlx::query_scalar("SELECT result FROM result_documents WHERE run_id = ?")
                .bind(run_id)
                .fetch_optional(&self.read)
                .await?,
        )
    }

    /// The report of a run's most recent successful diagnosis.
    pub async fn latest_diagnosis(&self, run_id: &str) -> Result<Option<String>, StoreError> {
        Ok(sqlx::query_scalar(
            "SELECT report FROM diagnoses WHERE run_id = ?
             ORDER BY completed_at DESC, job_id DESC LIMIT 1",
        )
        .bind(run_id)
        .fetch_optional(&self.read)
        .await?)
    }

    /// A run's most recent diagnose job, if any.
    pub async fn latest_diagnose_job(&self, run_id: &str) -> Result<Option<JobRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT * FROM jobs WHERE run_id = ? AND kind = 'diagnose'
             ORDER BY created_at DESC, id DESC LIMIT 1",
        )
        .bind(run_id)
        .fetch_optional(&self.read)
        .await?)
    }

    pub async fn list_units(
        &self,
        limit: i64,
        offset: i64,
    ) -> Result<(i64, Vec<UnitSummary>), StoreError> {
        let total = sqlx::query_scalar("SELECT COUNT(*) FROM units")
            .fetch_one(&self.read)
            .await?;
        let rows = sqlx::query_as(
            "SELECT u.serial, u.created_at,
                    (SELECT COUNT(*) FROM runs r WHERE r.unit_serial = u.serial) AS runs,
                    (SELECT COUNT(*) FROM results s WHERE s.unit_serial = u.serial) AS calibrated,
                    (SELECT MAX(run_time) FROM runs r WHERE r.unit_serial = u.serial) AS last_run_time
             FROM units u ORDER BY u.serial LIMIT ? OFFSET ?",
        )
        .bind(limit)
        .bind(offset)
        .fetch_all(&self.read)
        .await?;
        Ok((total, rows))
    }

    pub async fn get_unit(&self, serial: &str) -> Result<Option<UnitSummary>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT u.serial, u.created_at,
                    (SELECT COUNT(*) FROM runs r WHERE r.unit_serial = u.serial) AS runs,
                    (SELECT COUNT(*) FROM results s WHERE s.unit_serial = u.serial) AS calibrated,
                    (SELECT MAX(run_time) FROM runs r WHERE r.unit_serial = u.serial) AS last_run_time
             FROM units u WHERE u.serial = ?",
        )
        .bind(serial)
        .fetch_optional(&self.read)
        .await?)
    }

    /// Jobs of a unit's runs per state.
    pub async fn unit_job_counts(&self, serial: &str) -> Result<BTreeMap<String, i64>, StoreError> {
        let rows = sqlx::query(
            "SELECT j.state, COUNT(*) FROM jobs j JOIN runs r ON r.id = j.run_id
             WHERE r.unit_serial = ? GROUP BY j.state",
        )
        .bind(serial)
        .fetch_all(&self.read)
        .await?;
        Ok(rows.into_iter().map(|r| (r.get(0), r.get(1))).collect())
    }

    /// A unit's calibrated runs with `from <= run_time < to`, oldest first.
    pub async fn history(
        &self,
        serial: &str,
        from: i64,
        to: i64,
        limit: i64,
        offset: i64,
    ) -> Result<(i64, Vec<HistoryRow>), StoreError> {
        let total = sqlx::query_scalar(
            "SELECT COUNT(*) FROM results WHERE unit_serial = ? AND run_time >= ? AND run_time < ?",
        )
        .bind(serial)
        .bind(from)
        .bind(to)
        .fetch_one(&self.read)
        .await?;
        let rows = sqlx::query_as(
            "SELECT run_id, job_id, run_time, completed_at, parameters, model_adequate, model_summary
             FROM results
             WHERE unit_serial = ? AND run_time >= ? AND run_time < ?
             ORDER BY run_time, run_id LIMIT ? OFFSET ?",
        )
        .bind(serial)
        .bind(from)
        .bind(to)
        .bind(limit)
        .bind(offset)
        .fetch_all(&self.read)
        .await?;
        Ok((total, rows))
    }

    /// Per-parameter spread over a unit's calibrated runs with
    /// `run_time >= since`, the `last` most recent of them (`None`: all).
    ///
    /// One range scan of `results_unit_time_run` reading one value blob per
    /// run, in time order (ties by run id, as history orders them).
    pub async fn repeatability(
        &self,
        serial: &str,
        since: i64,
        last: Option<i64>,
    ) -> Result<Vec<ParamSpread>, StoreError> {
        // Newest first so that LIMIT keeps the `last` most recent (a
        // negative LIMIT is none in SQLite), then back to time order.
        let mut blobs: Vec<Vec<u8>> = sqlx::query_scalar(
            "SELECT param_values FROM results WHERE unit_serial = ? AND run_time >= ?
             ORDER BY run_time DESC, run_id DESC LIMIT ?",
        )
        .bind(serial)
        .bind(since)
        .bind(last.unwrap_or(-1))
        .fetch_all(&self.read)
        .await?;
        blobs.reverse();
        let mut acc = SpreadAccumulator::default();
        for b in &blobs {
            acc.push(b);
        }
        Ok(acc.finish())
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
             VALUES (?, ?, 'succeeded', 1, ?, ?, 1, ?, ?)",
        )
        .bind(&new.job_id)
        .bind(&new.run_id)
        .bind(new.max_attempts)
        .bind(new.uploaded_at)
        .bind(new.uploaded_at)
        .bind(new.uploaded_at)
        .execute(&mut *tx)
        .await?;
        let document = serde_json::json!({ "parameters": parameters }).to_string();
        let stored = StoredResult {
            run_id: &new.run_id,
            job_id: &new.job_id,
            unit_serial: &new.unit_serial,
            run_time,
            completed_at: new.uploaded_at,
            parameters,
            model_check: None,
            document: &document,
        };
        insert_result(&mut tx, &stored).await?;
        tx.commit().await?;
        Ok(())
    }
}

/// Marks the fenced job succeeded inside the caller's write transaction;
/// false when the lease no longer holds (the caller then writes nothing).
async fn mark_succeeded(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    fence: &Fence,
    now: i64,
) -> Result<bool, StoreError> {
    let updated = sqlx::query(
        "UPDATE jobs SET state = 'succeeded', progress = 1, stage = 'done', finished_at = ?,
                lease_owner = NULL, lease_expires_at = NULL
         WHERE id = ? AND attempts = ? AND lease_owner = ? AND state = 'running'",
    )
    .bind(now)
    .bind(&fence.job_id)
    .bind(fence.attempt)
    .bind(&fence.owner)
    .execute(&mut **tx)
    .await?;
    Ok(updated.rows_affected() == 1)
}

/// A finished calibration as stored: the summary row history and
/// repeatability read, and the whole document apart.
struct StoredResult<'a> {
    run_id: &'a str,
    job_id: &'a str,
    unit_serial: &'a str,
    run_time: i64,
    completed_at: i64,
    parameters: &'a BTreeMap<String, ParameterEstimate>,
    model_check: Option<&'a ModelCheck>,
    /// The whole `CalibrationResult` JSON.
    document: &'a str,
}

async fn insert_result(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    r: &StoredResult<'_>,
) -> Result<(), StoreError> {
    sqlx::query(
        "INSERT INTO results (run_id, job_id, unit_serial, run_time, completed_at, parameters,
                              param_values, model_adequate, model_summary)
         VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
    )
    .bind(r.run_id)
    .bind(r.job_id)
    .bind(r.unit_serial)
    .bind(r.run_time)
    .bind(r.completed_at)
    .bind(serde_json::to_string(r.parameters)?)
    .bind(spread::encode(r.parameters))
    .bind(r.model_check.map(|c| c.adequate))
    .bind(r.model_check.map(|c| c.summary.as_str()))
    .execute(&mut **tx)
    .await?;
    sqlx::query("INSERT INTO result_documents (run_id, result) VALUES (?, ?)")
        .bind(r.run_id)
        .bind(r.document)
        .execute(&mut **tx)
        .await?;
    Ok(())
}

/// Gives every result stored before `param_values` existed its value blob,
/// from the `parameters` JSON it has always carried. A no-op afterwards.
async fn backfill_param_values(write: &SqlitePool) -> Result<(), StoreError> {
    let rows: Vec<(String, String)> =
        sqlx::query_as("SELECT run_id, parameters FROM results WHERE param_values IS NULL")
            .fetch_all(write)
            .await?;
    if rows.is_empty() {
        return Ok(());
    }
    let mut tx = write.begin_with("BEGIN IMMEDIATE").await?;
    for (run_id, json) in rows {
        let parameters: BTreeMap<String, ParameterEstimate> = serde_json::from_str(&json)?;
        sqlx::query("UPDATE results SET param_values = ? WHERE run_id = ?")
            .bind(spread::encode(&parameters))
            .bind(&run_id)
            .execute(&mut *tx)
            .await?;
    }
    tx.commit().await?;
    Ok(())
}

/// The unit (if new) and the run's row, inside the caller's write
/// transaction; a run's time is its recording time, else its upload time.
async fn insert_unit_and_run(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    new: &NewRun,
) -> Result<(), StoreError> {
    sqlx::query("INSERT OR IGNORE INTO units (serial, created_at) VALUES (?, ?)")
        .bind(&new.unit_serial)
        .bind(new.uploaded_at)
        .execute(&mut **tx)
        .await?;
    sqlx::query(
        "INSERT INTO runs (id, unit_serial, sha256, size_bytes, records, format, gzip, blob_path,
                           metadata, recorded_at, run_time, uploaded_at, uploaded_by)
         VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
    )
    .bind(&new.run_id)
    .bind(&new.unit_serial)
    .bind(&new.sha256)
    .bind(new.size_bytes)
    .bind(new.records)
    .bind(&new.format)
    .bind(new.gzip)
    .bind(&new.blob_path)
    .bind(&new.metadata)
    .bind(new.recorded_at)
    .bind(new.recorded_at.unwrap_or(new.uploaded_at))
    .bind(new.uploaded_at)
    .bind(&new.uploaded_by)
    .execute(&mut **tx)
    .await?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::PARAMETERS;

    /// A database left by the schema before `param_values` (migrations 1–3:
    /// the document inside `results`, per-parameter rows) opens with every
    /// result's value blob filled in and its document kept.
    #[tokio::test]
    async fn results_stored_before_the_value_blob_are_backfilled() {
        let dir = tempfile::tempdir().unwrap();
        let db_path = dir.path().join("old.db");
        let pool = SqlitePool::connect_with(connect_options(&db_path))
            .await
            .unwrap();
        let old = sqlx::migrate::Migrator {
            migrations: MIGRATOR.migrations[..3].to_vec().into(),
            ..sqlx::migrate::Migrator::DEFAULT
        };
        old.run(&pool).await.unwrap();
        sqlx::query("INSERT INTO units (serial, created_at) VALUES ('OLD-1', 0)")
            .execute(&pool)
            .await
            .unwrap();
        for (k, offset) in [0.0, 0.4, 0.1].into_iter().enumerate() {
            let params: BTreeMap<String, ParameterEstimate> = PARAMETERS
                .iter()
                .map(|p| {
                    let e = ParameterEstimate {
                        value: 500.0 + offset,
                        sigma: 0.1,
                        unit: p.unit.into(),
                    };
                    (p.name.to_string(), e)
                })
                .collect();
            let run = format!("run-{k}");
            sqlx::query(
                "INSERT INTO runs (id, unit_serial, sha256, size_bytes, records, format, gzip,
                                   blob_path, metadata, run_time, uploaded_at)
                 VALUES (?, 'OLD-1', ?, 0, 0, 'csv', 0, 'runs/x', '{}', ?, 0)",
            )
            .bind(&run)
            .bind(&run)
            .bind(k as i64)
            .execute(&pool)
            .await
            .unwrap();
            sqlx::query(
                "INSERT INTO results (run_id, job_id, unit_serial, run_time, completed_at,
                                      parameters, result)
                 VALUES (?, 'job', 'OLD-1', ?, 0, ?, '{}')",
            )
            .bind(&run)
            .bind(k as i64)
            .bind(serde_json::to_string(&params).unwrap())
            .execute(&pool)
            .await
            .unwrap();
        }
        pool.close().await;

        let store = Store::open(&db_path, 1).await.unwrap();
        let missing: i64 =
            sqlx::query_scalar("SELECT COUNT(*) FROM results WHERE param_values IS NULL")
                .fetch_one(&store.read)
                .await
                .unwrap();
        assert_eq!(missing, 0);
        assert_eq!(
            store.get_result("run-1").await.unwrap().as_deref(),
            Some("{}")
        );
        let spread = store.repeatability("OLD-1", i64::MIN, None).await.unwrap();
        assert_eq!(spread.len(), PARAMETERS.len());
        let s = &spread[0];
        assert_eq!(s.n, 3);
        assert!((s.mean - (1500.5 / 3.0)).abs() < 1e-9);
        // In time order 500.0, 500.4, 500.1: the largest change is 0.4.
        assert!((s.max_change.unwrap() - 0.4).abs() < 1e-9);
        let last2 = store
            .repeatability("OLD-1", i64::MIN, Some(2))
            .await
            .unwrap();
        assert_eq!(last2[0].n, 2);
        assert!((last2[0].mean - 500.25).abs() < 1e-9);
        store.close().await;
    }
}
