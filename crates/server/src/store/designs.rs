//! Design jobs as rows: queueing one with its request, storing its answer
//! under the job's fence, and reading both back. A design job is a `jobs`
//! row of kind `design` (no run) and a `designs` row beside it; the worker
//! claims it through `queue` like any other job.

use sqlx::FromRow;

use super::db::{now_ms, Store};
use super::dialect::hint_job_queued;
use super::error::StoreError;
use super::ids::JobId;
use super::jobs::{count_queued, JobRow};
use super::queue::Fence;

/// A design job with its request and, once it succeeded, its answer.
#[derive(Clone, Debug)]
pub struct DesignRow {
    pub job: JobRow,
    /// The request as the client wrote it (JSON).
    pub request: String,
    /// The token that asked.
    pub requested_by: String,
    /// The design (JSON), once the job succeeded.
    pub design: Option<String>,
}

#[derive(FromRow)]
struct DesignCols {
    request: String,
    requested_by: String,
    design: Option<String>,
}

/// What `queue_design_job` did.
#[derive(Clone, Debug)]
pub enum DesignQueued {
    Created(Box<DesignRow>),
    /// The queue holds `max_queue` jobs already.
    QueueFull,
}

impl Store {
    /// Queues a design job for `request` (a design spec as JSON) asked by
    /// the token `by`, unless the queue is full.
    pub async fn queue_design_job(
        &self,
        request: &str,
        by: &str,
        (max_attempts, max_queue): (i64, i64),
    ) -> Result<DesignQueued, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        if count_queued(&mut *tx).await? >= max_queue {
            return Ok(DesignQueued::QueueFull);
        }
        let job: JobRow = sqlx::query_as(
            "INSERT INTO jobs (id, run_id, kind, state, max_attempts, run_after, created_at)
             VALUES ($1, NULL, 'design', 'queued', $2, $3, $4)
             RETURNING *",
        )
        .bind(JobId::new())
        .bind(max_attempts)
        .bind(now)
        .bind(now)
        .fetch_one(&mut *tx)
        .await?;
        sqlx::query(
            "INSERT INTO designs (job_id, request, requested_by, created_at) VALUES ($1, $2, $3, $4)",
        )
        .bind(job.id)
        .bind(request)
        .bind(by)
        .bind(now)
        .execute(&mut *tx)
        .await?;
        hint_job_queued(self.backend, &mut tx).await?;
        tx.commit().await?;
        Ok(DesignQueued::Created(Box::new(DesignRow {
            job,
            request: request.to_string(),
            requested_by: by.to_string(),
            design: None,
        })))
    }

    /// A design job and its row; `None` if `id` is no design job.
    pub async fn get_design(&self, id: JobId) -> Result<Option<DesignRow>, StoreError> {
        let job: Option<JobRow> =
            sqlx::query_as("SELECT * FROM jobs WHERE id = $1 AND kind = 'design'")
                .bind(id)
                .fetch_optional(&self.read)
                .await?;
        let Some(job) = job else {
            return Ok(None);
        };
        let cols: Option<DesignCols> =
            sqlx::query_as("SELECT request, requested_by, design FROM designs WHERE job_id = $1")
                .bind(id)
                .fetch_optional(&self.read)
                .await?;
        Ok(cols.map(|c| DesignRow {
            job,
            request: c.request,
            requested_by: c.requested_by,
            design: c.design,
        }))
    }

    /// Stores a design job's answer and marks it succeeded, in one
    /// transaction, if and only if `fence` still holds the lease (as
    /// [`Store::complete_job`]).
    pub async fn complete_design_job(
        &self,
        fence: &Fence,
        design: &str,
    ) -> Result<bool, StoreError> {
        let now = now_ms();
        let Some(mut tx) = self.begin_succeeded(fence, now).await? else {
            return Ok(false);
        };
        sqlx::query("UPDATE designs SET design = $1, completed_at = $2 WHERE job_id = $3")
            .bind(design)
            .bind(now)
            .bind(fence.job_id)
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::{JobKind, JobState, Subject};
    use std::time::Duration;

    /// A queued design is claimed with its request and no run; its answer
    /// is stored only under its fence and read back with the job
    /// succeeded; a full queue refuses the next.
    #[tokio::test]
    async fn a_design_job_is_queued_claimed_and_answered() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open_for_test(&dir.path().join("d.db")).await;
        let DesignQueued::Created(row) = store
            .queue_design_job(r#"{"margin":3}"#, "tok", (2, 1))
            .await
            .unwrap()
        else {
            panic!("an empty queue takes a design")
        };
        assert_eq!((row.job.kind, row.job.run_id), (JobKind::Design, None));
        let full = store.queue_design_job("{}", "tok", (2, 1)).await.unwrap();
        assert!(matches!(full, DesignQueued::QueueFull));

        let claim = store
            .claim_job("w", Duration::from_secs(30))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(claim.kind, JobKind::Design);
        let Subject::Design { request } = &claim.subject else {
            panic!("a design job's claim carries its request")
        };
        assert_eq!(request, r#"{"margin":3}"#);
        let stale = Fence {
            attempt: 0,
            ..claim.fence.clone()
        };
        assert!(!store.complete_design_job(&stale, "{}").await.unwrap());
        assert!(store
            .complete_design_job(&claim.fence, r#"{"duration_s":1}"#)
            .await
            .unwrap());
        let back = store.get_design(row.job.id).await.unwrap().unwrap();
        assert_eq!(back.job.state, JobState::Succeeded);
        assert_eq!(back.requested_by, "tok");
        assert_eq!(back.design.as_deref(), Some(r#"{"duration_s":1}"#));
        assert!(store.get_design(JobId::new()).await.unwrap().is_none());
    }
}
