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
