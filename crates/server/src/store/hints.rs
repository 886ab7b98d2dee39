//! Wake-up hints for workers in other processes: on PostgreSQL a
//! `LISTEN` on [`JOBS_CHANNEL`], which every transaction that queues a job
//! notifies (`dialect::hint_job_queued`). A hint carries nothing: the
//! worker that wakes still claims through the queue, and a worker that
//! misses one finds the job at its next poll. SQLite has none (its
//! workers share the server's process and its in-memory wake-up).

use sqlx::postgres::PgListener;

use super::db::{DatabaseUrl, Store};
use super::dialect::JOBS_CHANNEL;
use super::error::StoreError;

/// A subscription to the queue's notifications.
pub struct JobHints(PgListener);

impl JobHints {
    /// Waits for the next notification. After a lost connection the
    /// listener reconnects on the next call (notifications sent meanwhile
    /// are lost: the poll covers them).
    pub async fn next(&mut self) -> Result<(), StoreError> {
        self.0.recv().await?;
        Ok(())
    }
}

impl Store {
    /// A subscription to queued-job notifications, where the engine has
    /// them (PostgreSQL); `None` on SQLite.
    pub async fn job_hints(&self) -> Result<Option<JobHints>, StoreError> {
        let DatabaseUrl::Postgres(url) = self.url() else {
            return Ok(None);
        };
        let mut listener = PgListener::connect(url).await?;
        listener.listen(JOBS_CHANNEL).await?;
        Ok(Some(JobHints(listener)))
    }
}
