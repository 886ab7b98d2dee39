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
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use sqlx::any::{AnyConnectOptions, AnyPoolOptions};
use sqlx::sqlite::SqliteConnectOptions;
use sqlx::{AnyPool, ConnectOptions, Connection, Executor, Row};

use super::dialect::Backend;
use super::error::StoreError;
use super::spread;
use super::verdicts;
use sinscal_core::calib::ParameterEstimate;

/// The migrations of each engine, embedded in the binary so that a fresh
/// machine needs nothing but the executable. SQLite's history is kept as
/// it grew (databases in the field are at every step of it); PostgreSQL
/// starts at the schema SQLite's last migration reaches.
static SQLITE_MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("../../migrations/sqlite");
static POSTGRES_MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("../../migrations/postgres");

/// How long a statement waits for a lock held by another connection (the
/// `sinscal token create` CLI, a second server) before SQLITE_BUSY.
const BUSY_TIMEOUT: Duration = Duration::from_secs(10);

/// How long opening the store waits for a first connection: an unreachable
/// database is reported at start instead of after the pool's default 30 s.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(10);

/// Connections of the writer pool on PostgreSQL, where writes do not queue
/// behind one connection: enough for the API's uploads and a process's
/// workers' heartbeats at once.
const POSTGRES_WRITERS: u32 = 8;

/// A write transaction on the writer pool.
pub(super) type WriteTx = sqlx::Transaction<'static, sqlx::Any>;

/// Milliseconds since the Unix epoch, the unit of every stored time.
pub fn now_ms() -> i64 {
    chrono::Utc::now().timestamp_millis()
}

/// Where the store's database is: `--database-url`.
#[derive(Clone, PartialEq, Eq)]
pub enum DatabaseUrl {
    /// A SQLite file (the embedded default: `<data dir>/sinscal.db`).
    Sqlite(PathBuf),
    /// A PostgreSQL server shared by any number of sinscal processes.
    Postgres(String),
}

impl DatabaseUrl {
    /// Parses `sqlite:PATH` (also `sqlite://PATH`) or `postgres://…`
    /// (also `postgresql://…`).
    pub fn parse(url: &str) -> Result<DatabaseUrl, String> {
        if let Some(rest) = url.strip_prefix("sqlite:") {
            let path = rest.strip_prefix("//").unwrap_or(rest);
            let path = path.split('?').next().unwrap_or_default();
            if path.is_empty() {
                return Err(format!("{url:?} names no file: sqlite:PATH"));
            }
            Ok(DatabaseUrl::Sqlite(PathBuf::from(path)))
        } else if url.starts_with("postgres://") || url.starts_with("postgresql://") {
            Ok(DatabaseUrl::Postgres(url.to_string()))
        } else {
            Err(format!(
                "{:?} is neither sqlite:PATH nor postgres://USER@HOST/DB",
                redact(url)
            ))
        }
    }

    /// The URL without its password, for messages and logs.
    pub fn redacted(&self) -> String {
        match self {
            DatabaseUrl::Sqlite(p) => format!("sqlite:{}", p.display()),
            DatabaseUrl::Postgres(u) => redact(u),
        }
    }
}

impl std::fmt::Debug for DatabaseUrl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.redacted())
    }
}

/// `scheme://user:secret@host/…` → `scheme://user:***@host/…`.
fn redact(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else {
        return url.to_string();
    };
    let (authority, path) = rest.split_at(rest.find('/').unwrap_or(rest.len()));
    match authority.rsplit_once('@') {
        Some((userinfo, host)) => {
            let user = userinfo.split(':').next().unwrap_or_default();
            let hidden = if userinfo.contains(':') { ":***" } else { "" };
            format!("{scheme}://{user}{hidden}@{host}{path}")
        }
        None => url.to_string(),
    }
}

/// The database: a writer pool and a reader pool. Its methods, spread
/// over the files of `store` by what they own, are the one storage
/// interface of the server.
#[derive(Clone, Debug)]
pub struct Store {
    pub(super) read: AnyPool,
    pub(super) write: AnyPool,
    pub(super) backend: Backend,
    url: DatabaseUrl,
    /// While set, every write transaction fails as if the disk were full:
    /// the seam tests use where a small filesystem cannot be mounted.
    simulate_full: Arc<AtomicBool>,
}

/// The `AnyConnectOptions` of a SQLite file. The PRAGMAs a URL cannot
/// carry are set on each new connection ([`sqlite_pragmas`]).
fn sqlite_options(db_path: &Path, read_only: bool) -> Result<AnyConnectOptions, StoreError> {
    let url = SqliteConnectOptions::new()
        .filename(db_path)
        .create_if_missing(!read_only)
        .read_only(read_only)
        .to_url_lossy();
    Ok(AnyConnectOptions::from_url(&url)?)
}

/// WAL and FULL sync (see the module's head), the busy timeout, foreign
/// keys. A read-only connection cannot switch the journal; the writer,
/// opened first, has.
fn sqlite_pragmas(read_only: bool) -> String {
    let journal = if read_only {
        ""
    } else {
        "PRAGMA journal_mode = WAL; "
    };
    format!(
        "{journal}PRAGMA synchronous = FULL; PRAGMA busy_timeout = {}; PRAGMA foreign_keys = ON;",
        BUSY_TIMEOUT.as_millis()
    )
}

fn sqlite_pool(max: u32, read_only: bool) -> AnyPoolOptions {
    AnyPoolOptions::new()
        .max_connections(max)
        // A writer waiting for the single connection must not give up
        // while a long transaction (an upload's rows, a backfill) commits.
        .acquire_timeout(Duration::from_secs(30))
        .after_connect(move |conn, _| {
            Box::pin(async move {
                conn.execute(sqlite_pragmas(read_only).as_str()).await?;
                Ok(())
            })
        })
}

impl Store {
    /// Opens (creating if needed) a SQLite database file and applies the
    /// migrations.
    pub async fn open(db_path: &Path, readers: u32) -> Result<Store, StoreError> {
        Store::connect(&DatabaseUrl::Sqlite(db_path.to_path_buf()), readers).await
    }

    /// Opens the database `url` names and applies the migrations. An
    /// unreachable server, a refused login or a missing database is
    /// [`StoreError::Connect`], saying which.
    pub async fn connect(url: &DatabaseUrl, readers: u32) -> Result<Store, StoreError> {
        sqlx::any::install_default_drivers();
        let unreachable = |e: sqlx::Error| StoreError::Connect {
            target: url.redacted(),
            source: e,
        };
        let (backend, read, write) = match url {
            DatabaseUrl::Sqlite(path) => {
                let write = sqlite_pool(1, false)
                    .connect_with(sqlite_options(path, false)?)
                    .await
                    .map_err(unreachable)?;
                SQLITE_MIGRATOR.run(&write).await?;
                let read = sqlite_pool(readers.max(1), true)
                    .connect_with(sqlite_options(path, true)?)
                    .await
                    .map_err(unreachable)?;
                (Backend::Sqlite, read, write)
            }
            DatabaseUrl::Postgres(u) => {
                let options = u.parse::<AnyConnectOptions>()?;
                // One connection first: a pool that cannot connect reports
                // only that it timed out, this reports why (refused,
                // password, no such database).
                let probe = sqlx::AnyConnection::connect_with(&options)
                    .await
                    .map_err(unreachable)?;
                let _ = probe.close().await;
                let pool = |max: u32| {
                    AnyPoolOptions::new()
                        .max_connections(max)
                        .acquire_timeout(CONNECT_TIMEOUT)
                        .connect_with(options.clone())
                };
                let write = pool(POSTGRES_WRITERS).await.map_err(unreachable)?;
                // Several processes may start at once: sqlx holds an
                // advisory lock while it migrates PostgreSQL.
                POSTGRES_MIGRATOR.run(&write).await?;
                let read = pool(readers.max(1)).await.map_err(unreachable)?;
                (Backend::Postgres, read, write)
            }
        };
        if backend == Backend::Sqlite {
            backfill_param_values(&write).await?;
        }
        {
            let mut conn = write.acquire().await?;
            verdicts::backfill(&mut conn, now_ms()).await?;
        }
        Ok(Store {
            read,
            write,
            backend,
            url: url.clone(),
            simulate_full: Arc::new(AtomicBool::new(false)),
        })
    }

    /// The engine this store runs on.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// Where the database is (for messages; the password is not kept in
    /// what [`DatabaseUrl::redacted`] shows).
    pub fn url(&self) -> &DatabaseUrl {
        &self.url
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
        let begin = self.backend.begin_write();
        match self.write.begin_with(begin).await {
            Err(sqlx::Error::InvalidSavePointStatement) => {
                let conn = self.write.acquire().await?;
                if sqlx::Connection::is_in_transaction(&*conn) {
                    tracing::warn!(
                        "writer connection left inside a failed transaction: reopening it"
                    );
                    let _ = conn.close().await;
                }
                Ok(self.write.begin_with(begin).await?)
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
            "INSERT INTO write_probe (id, checked_at) VALUES (1, $1)
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

#[cfg(test)]
impl Store {
    /// The store a unit test works on: SQLite at `db_path`, or, when
    /// `SINSCAL_TEST_DATABASE_URL` names a PostgreSQL server, a new
    /// database there (the suite's second engine, as in `tests/suite/common`).
    pub(crate) async fn open_for_test(db_path: &Path) -> Store {
        use sqlx::Connection;
        let Ok(admin) = std::env::var("SINSCAL_TEST_DATABASE_URL") else {
            return Store::open(db_path, 1).await.unwrap();
        };
        let name = format!("sinscal_unit_{}", uuid::Uuid::new_v4().simple());
        let mut conn = sqlx::PgConnection::connect(&admin).await.unwrap();
        conn.execute(format!("CREATE DATABASE {name}").as_str())
            .await
            .unwrap();
        let (root, _) = admin.rsplit_once('/').unwrap();
        let url = DatabaseUrl::Postgres(format!("{root}/{name}"));
        Store::connect(&url, 1).await.unwrap()
    }
}

/// Gives every result stored before `param_values` existed its value blob,
/// from the `parameters` JSON it has always carried. A no-op afterwards.
async fn backfill_param_values(write: &AnyPool) -> Result<(), StoreError> {
    let rows = sqlx::query("SELECT run_id, parameters FROM results WHERE param_values IS NULL")
        .fetch_all(write)
        .await?;
    if rows.is_empty() {
        return Ok(());
    }
    let mut tx = write.begin_with(Backend::Sqlite.begin_write()).await?;
    for row in rows {
        let run_id: String = row.try_get("run_id")?;
        let json: &str = row.try_get("parameters")?;
        let parameters: BTreeMap<String, ParameterEstimate> = serde_json::from_str(json)?;
        sqlx::query("UPDATE results SET param_values = $1 WHERE run_id = $2")
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
    use crate::store::{RunId, Stored};
    use sinscal_core::model::PARAMETERS;

    /// The id of the `k`th run a test writes by hand.
    fn run_id(k: usize) -> RunId {
        format!("00000000-0000-4000-8000-{k:012}").parse().unwrap()
    }

    /// A database left by the schema before `param_values` (migrations 1–3:
    /// the document inside `results`, per-parameter rows) opens with every
    /// result's value blob filled in and its document kept.
    #[tokio::test]
    async fn results_stored_before_the_value_blob_are_backfilled() {
        let dir = tempfile::tempdir().unwrap();
        let db_path = dir.path().join("old.db");
        let options = sqlx::sqlite::SqliteConnectOptions::new()
            .filename(&db_path)
            .create_if_missing(true);
        let pool = sqlx::SqlitePool::connect_with(options).await.unwrap();
        let old = sqlx::migrate::Migrator {
            migrations: SQLITE_MIGRATOR.migrations[..3].to_vec().into(),
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
            let run = run_id(k).to_string();
            sqlx::query(
                "INSERT INTO runs (id, unit_serial, sha256, size_bytes, records, format, gzip,
                                   blob_path, metadata, run_time, uploaded_at)
                 VALUES ($1, 'OLD-1', $2, 0, 0, 'csv', 0, 'runs/x', '{}', $3, 0)",
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
                 VALUES ($1, 'job', 'OLD-1', $2, 0, $3, '{}')",
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
            store
                .get_result(run_id(1))
                .await
                .unwrap()
                .map(Stored::into_json)
                .as_deref(),
            Some("{}")
        );
        let serial = "OLD-1".parse().unwrap();
        let over = store.repeatability(&serial, i64::MIN, None).await.unwrap();
        assert_eq!(over.runs.len(), 3);
        let spread = over.parameters;
        assert_eq!(spread.len(), PARAMETERS.len());
        let s = &spread[0];
        assert_eq!(s.n, 3);
        assert!((s.mean - (1500.5 / 3.0)).abs() < 1e-9);
        // In time order 500.0, 500.4, 500.1: the largest change is 0.4.
        assert!((s.max_change.unwrap() - 0.4).abs() < 1e-9);
        let last2 = store
            .repeatability(&serial, i64::MIN, Some(2))
            .await
            .unwrap();
        assert_eq!(last2.runs.len(), 2);
        let last2 = last2.parameters;
        assert_eq!(last2[0].n, 2);
        assert!((last2[0].mean - 500.25).abs() < 1e-9);
        store.close().await;
    }
}
