//! The database handle: the two pools (one writer connection, readers),
//! opening with migrations, and the write transaction every write starts.
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
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use sqlx::sqlite::{
    SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteSynchronous,
};

use sqlx::Row;

use super::error::StoreError;
use super::spread;
use super::verdicts;
use crate::calib::ParameterEstimate;

/// The migrations in `migrations/`, embedded in the binary so that a fresh
/// machine needs nothing but the executable.
static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("./migrations");

/// How long a statement waits for a lock held by another connection (the
/// `sinscal token create` CLI, a second server) before SQLITE_BUSY.
const BUSY_TIMEOUT: Duration = Duration::from_secs(10);

/// A write transaction on the writer connection.
pub(super) type WriteTx = sqlx::Transaction<'static, sqlx::Sqlite>;

/// Milliseconds since the Unix epoch, the unit of every stored time.
pub fn now_ms() -> i64 {
    chrono::Utc::now().timestamp_millis()
}

/// The database: a single-connection writer pool and a reader pool. Its
/// methods, spread over the files of `store` by what they own, are the
/// one storage interface of the server.
#[derive(Clone, Debug)]
pub struct Store {
    pub(super) read: SqlitePool,
    pub(super) write: SqlitePool,
    /// While set, every write transaction fails as if the disk were full:
    /// the seam tests use where a small filesystem cannot be mounted.
    simulate_full: Arc<AtomicBool>,
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
        {
            let mut conn = write.acquire().await?;
            verdicts::backfill(&mut conn, now_ms()).await?;
        }
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
    pub(super) async fn begin_write(&self) -> Result<WriteTx, StoreError> {
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
}

/// Gives every result stored before `param_values` existed its value blob,
/// from the `parameters` JSON it has always carried. A no-op afterwards.
async fn backfill_param_values(write: &SqlitePool) -> Result<(), StoreError> {
    let rows = sqlx::query("SELECT run_id, parameters FROM results WHERE param_values IS NULL")
        .fetch_all(write)
        .await?;
    if rows.is_empty() {
        return Ok(());
    }
    let mut tx = write.begin_with("BEGIN IMMEDIATE").await?;
    for row in rows {
        let run_id: String = row.try_get("run_id")?;
        let json: &str = row.try_get("parameters")?;
        let parameters: BTreeMap<String, ParameterEstimate> = serde_json::from_str(json)?;
        sqlx::query("UPDATE results SET param_values = ? WHERE run_id = ?")
            .bind(spread::encode(&parameters))
            .bind(&run_id)
            .execute(&mut *tx)
            .await?;
    }
    tx.commit().await?;
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
