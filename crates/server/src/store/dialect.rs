//! Where the two database engines differ, each difference said once: how
//! a write transaction starts, how a read-modify-write holds its key, how
//! workers elsewhere hear of a queued job. The SQL text of every other
//! statement is shared (`$N` parameters, `ON CONFLICT`, `RETURNING`,
//! `TRUE`/`FALSE`, which both engines read alike). A leaf of `store`.

use super::error::StoreError;
use super::ids::RunId;

/// The lock key of a unit's rows: its runs, results and verdicts. Keys
/// are taken in the order run, then unit (a product type's, then its
/// units'), so two transactions never wait for each other in a circle.
pub(super) fn unit_key(serial: &str) -> String {
    format!("unit:{serial}")
}

/// The lock key of a run's jobs.
pub(super) fn run_key(run_id: RunId) -> String {
    format!("run:{run_id}")
}

/// The lock key of a product type's revisions.
pub(super) fn product_key(name: &str) -> String {
    format!("product:{name}")
}

/// The PostgreSQL channel on which a queued job is announced.
pub const JOBS_CHANNEL: &str = "sinscal_jobs";

/// Which engine the store runs on. The SQL text is shared; these are the
/// places where the two differ, each said once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    Sqlite,
    Postgres,
}

impl Backend {
    /// How a write transaction starts. SQLite: `IMMEDIATE` takes the write
    /// lock at once, so a transaction that reads before it writes cannot
    /// fail with SQLITE_BUSY half-way. PostgreSQL: READ COMMITTED, with
    /// the row and advisory locks each read-modify-write takes
    /// ([`lock_key`]).
    pub(super) fn begin_write(self) -> &'static str {
        match self {
            Backend::Sqlite => "BEGIN IMMEDIATE",
            Backend::Postgres => "BEGIN",
        }
    }

    /// What the claim's choice of a job row adds: on PostgreSQL, workers
    /// of several processes claim at once, and each passes over the rows
    /// another's claim holds instead of waiting for them. SQLite's claims
    /// are serialised by its one write lock.
    pub(super) fn skip_locked(self) -> &'static str {
        match self {
            Backend::Sqlite => "",
            Backend::Postgres => "FOR UPDATE SKIP LOCKED",
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Backend::Sqlite => "sqlite",
            Backend::Postgres => "postgres",
        }
    }
}

/// Holds `key` (a unit, a product type) until the transaction ends,
/// for a read-modify-write that must not interleave with another on the
/// same key. On SQLite every write transaction already holds the one
/// write lock, so nothing is taken; on PostgreSQL, a transaction-scoped
/// advisory lock on the key's 64-bit hash.
pub(super) async fn lock_key(
    backend: Backend,
    conn: &mut sqlx::AnyConnection,
    key: &str,
) -> Result<(), StoreError> {
    if backend == Backend::Postgres {
        // The function returns void, which no driver decodes: the
        // cast gives a row that can be read (and is ignored).
        sqlx::query("SELECT CAST(pg_advisory_xact_lock(hashtextextended($1, 0)) AS TEXT)")
            .bind(key)
            .execute(conn)
            .await?;
    }
    Ok(())
}

/// Tells workers on other processes that a job was queued, when the
/// transaction commits: PostgreSQL's `NOTIFY` on [`JOBS_CHANNEL`]. Only
/// a hint (a worker also polls); SQLite's workers share the process
/// and its in-memory wake-up.
pub(super) async fn hint_job_queued(
    backend: Backend,
    conn: &mut sqlx::AnyConnection,
) -> Result<(), StoreError> {
    if backend == Backend::Postgres {
        sqlx::query(&format!("NOTIFY {JOBS_CHANNEL}"))
            .execute(conn)
            .await?;
    }
    Ok(())
}
