//! Errors of the storage layer, and which of them mean a full disk.

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
    /// The database could not be opened: unreachable server, refused
    /// login, missing database or file. `target` is the URL without its
    /// password.
    #[error("cannot open the database {target}: {source}")]
    Connect {
        target: String,
        #[source]
        source: sqlx::Error,
    },
    #[error("database migration failed: {0}")]
    Migrate(#[from] sqlx::migrate::MigrateError),
    #[error("stored JSON is malformed: {0}")]
    Json(#[from] serde_json::Error),
    /// A stored value the library refuses (e.g. a product type's limits).
    #[error("stored data is invalid: {0}")]
    Corrupt(String),
}

/// SQLite's primary result code for "database or disk is full".
const SQLITE_FULL: i64 = 13;
/// PostgreSQL's SQLSTATE for "disk full".
const POSTGRES_DISK_FULL: &str = "53100";

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
            sqlx::Error::Database(db) => db.code().is_some_and(|c| {
                // SQLite's codes are numbers (extended result codes keep the
                // primary code in the low byte); PostgreSQL's are SQLSTATEs.
                c == POSTGRES_DISK_FULL
                    || (c.len() < 5 && c.parse::<i64>().is_ok_and(|n| n & 0xff == SQLITE_FULL))
            }),
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
