//! The durable queue as workers see it: claiming a job with a lease,
//! renewing it, and every write that ends an attempt (succeeded, failed,
//! cancelled, handed back). Each of those writes goes through [`Fenced`],
//! so a worker that lost its lease writes nothing.

use std::time::Duration;

use sqlx::any::{Any, AnyArguments};
use sqlx::{FromRow, Row};

use super::db::{now_ms, Store, WriteTx};
use super::dialect::{hint_job_queued, lock_key, run_key, unit_key};
use super::document::Stored;
use super::error::StoreError;
use super::ids::{JobId, RunId};
use super::kinds::{Flag, JobKind, JobState};
use super::results::{insert_result, StoredResult};
use sinscal_core::calib::CalibrationResult;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::UnitSerial;

/// The identity of one attempt at a job. Every write a worker makes about
/// its job must match all three fields: a worker whose lease was reclaimed
/// (and whose job was claimed again, so `attempt` moved on) cannot write
/// over the new attempt.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fence {
    pub job_id: JobId,
    pub attempt: i64,
    pub owner: String,
}

/// A job a worker has just claimed.
#[derive(Clone, Debug)]
pub struct Claim {
    pub fence: Fence,
    /// What the worker runs.
    pub kind: JobKind,
    pub max_attempts: i64,
    /// What it runs on: a run, or a design's request.
    pub subject: Subject,
}

/// What a claimed job works on.
#[derive(Clone, Debug)]
pub enum Subject {
    /// A calibrate or diagnose job's run.
    Run(RunClaim),
    /// A design job's request, as the client wrote it (a
    /// `sinscal_core::design::DesignSpec` as JSON), parsed by the worker
    /// so that a value it refuses fails this job alone.
    Design { request: String },
}

/// What a worker needs of a claimed job's run.
#[derive(Clone, Debug, FromRow)]
pub struct RunClaim {
    pub run_id: RunId,
    #[sqlx(try_from = "String")]
    pub unit_serial: UnitSerial,
    pub run_time: i64,
    pub blob_path: String,
    #[sqlx(try_from = "String")]
    pub metadata: Stored<RunMetadata>,
    /// The model a calibration job carries: the one adopted for the run,
    /// else its product type's (`None`: the server's). As stored, parsed
    /// by the worker, so that a value it refuses fails this job alone.
    pub model: Option<String>,
    /// Fit a bias wander the run's dwells do not show, as an engineer
    /// asked (`EstimateOptions::fit_unseen_wander`).
    #[sqlx(try_from = "Flag")]
    pub fit_unseen_wander: bool,
    /// The noise model held for the unit (`unit_noise_models`), as
    /// stored, with its use: parsed by the worker, as `model` is.
    pub held_noise: Option<String>,
    pub held_noise_use: Option<String>,
}

/// What storing a result sets going when its model check fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OnInadequate {
    /// Queue a diagnose job for the run (unless one is queued or running).
    pub queue_diagnose: bool,
    /// Its attempts, as for any job.
    pub max_attempts: i64,
}

/// An `UPDATE jobs` that applies only while a [`Fence`] holds: the row is
/// the fenced attempt, held by its owner, still running. The fence takes
/// parameters ?1–?3; the statement's own parameters are numbered from ?4
/// and bound after [`Fenced::query`].
struct Fenced(String);

impl Fenced {
    fn update(set: &str) -> Fenced {
        Fenced::update_returning(set, "")
    }

    fn update_returning(set: &str, returning: &str) -> Fenced {
        Fenced(format!(
            "UPDATE jobs SET {set}
             WHERE id = $1 AND attempts = $2 AND lease_owner = $3 AND state = 'running' {returning}"
        ))
    }

    fn query<'q>(&'q self, fence: &'q Fence) -> sqlx::query::Query<'q, Any, AnyArguments<'q>> {
        sqlx::query(&self.0)
            .bind(fence.job_id)
            .bind(fence.attempt)
            .bind(&fence.owner)
    }
}

/// The job row a claim took.
#[derive(FromRow)]
struct Claimed {
    id: JobId,
    run_id: Option<RunId>,
    attempts: i64,
    max_attempts: i64,
    kind: JobKind,
}

impl Store {
    /// A write transaction in which the fenced job is already marked
    /// succeeded, for its product to be written beside; `None` (and nothing
    /// written) when the lease no longer holds.
    pub(super) async fn begin_succeeded(
        &self,
        fence: &Fence,
        now: i64,
    ) -> Result<Option<WriteTx>, StoreError> {
        let mut tx = self.begin_write().await?;
        let sql = Fenced::update(
            "state = 'succeeded', progress = 1, stage = 'done', finished_at = $4,
                lease_owner = NULL, lease_expires_at = NULL",
        );
        let updated = sql.query(fence).bind(now).execute(&mut *tx).await?;
        if updated.rows_affected() == 1 {
            Ok(Some(tx))
        } else {
            tx.rollback().await?;
            Ok(None)
        }
    }

    /// Claims the oldest claimable job for `owner`: a queued job whose
    /// backoff has passed, or a running job whose lease expired (its worker
    /// died). Expired jobs that were asked to cancel are closed, and those
    /// that used their last attempt dead-lettered, instead of claimed.
    pub async fn claim_job(
        &self,
        owner: &str,
        lease: Duration,
    ) -> Result<Option<Claim>, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        sqlx::query(
            "UPDATE jobs SET state = 'cancelled', finished_at = $1, lease_owner = NULL, lease_expires_at = NULL
             WHERE state = 'running' AND lease_expires_at < $1 AND cancel_requested = TRUE",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        sqlx::query(
            "UPDATE jobs SET state = 'dead_letter', finished_at = $1, lease_owner = NULL, lease_expires_at = NULL,
                    error = 'the worker was lost (lease expired) on the last allowed attempt'
             WHERE state = 'running' AND lease_expires_at < $1 AND attempts >= max_attempts",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        let claim_sql = format!(
            "UPDATE jobs SET state = 'running', attempts = attempts + 1, lease_owner = $1,
                    lease_expires_at = $2, heartbeat_at = $3, started_at = COALESCE(started_at, $3),
                    progress = 0, stage = 'claimed'
             WHERE id = (SELECT id FROM jobs
                         WHERE (state = 'queued' AND run_after <= $3)
                            OR (state = 'running' AND lease_expires_at < $3)
                         ORDER BY created_at, id LIMIT 1 {})
             RETURNING id, run_id, attempts, max_attempts, kind",
            self.backend.skip_locked()
        );
        let claimed: Option<Claimed> = sqlx::query_as(&claim_sql)
            .bind(owner)
            .bind(now + lease.as_millis() as i64)
            .bind(now)
            .fetch_optional(&mut *tx)
            .await?;
        let Some(c) = claimed else {
            tx.commit().await?;
            return Ok(None);
        };
        let subject = match (c.kind, c.run_id) {
            (JobKind::Design, _) => Subject::Design {
                request: sqlx::query_scalar("SELECT request FROM designs WHERE job_id = $1")
                    .bind(c.id)
                    .fetch_one(&mut *tx)
                    .await?,
            },
            (_, Some(run_id)) => Subject::Run(
                sqlx::query_as(
                    "SELECT r.id AS run_id, r.unit_serial, r.run_time, r.blob_path, r.metadata,
                            COALESCE(r.model, p.model) AS model, r.fit_unseen_wander,
                            n.noise AS held_noise, n.used_as AS held_noise_use
                     FROM runs r LEFT JOIN product_types p ON p.name = r.product
                     LEFT JOIN unit_noise_models n ON n.unit_serial = r.unit_serial
                     WHERE r.id = $1",
                )
                .bind(run_id)
                .fetch_one(&mut *tx)
                .await?,
            ),
            // The schema's CHECK gives every other kind its run.
            (kind, None) => {
                return Err(StoreError::Corrupt(format!("a {kind} job without a run")));
            }
        };
        tx.commit().await?;
        Ok(Some(Claim {
            fence: Fence {
                job_id: c.id,
                attempt: c.attempts,
                owner: owner.to_string(),
            },
            max_attempts: c.max_attempts,
            kind: c.kind,
            subject,
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
        let sql = Fenced::update_returning(
            "lease_expires_at = $4, heartbeat_at = $5, progress = $6, stage = $7",
            "RETURNING cancel_requested",
        );
        let row = sql
            .query(fence)
            .bind(now + lease.as_millis() as i64)
            .bind(now)
            .bind(progress)
            .bind(stage)
            .fetch_optional(&self.write)
            .await?;
        let cancel = row.map(|r| r.try_get::<Flag, _>("cancel_requested"));
        Ok(cancel.transpose()?.map(bool::from))
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
        (fence, claim): (&Fence, &RunClaim),
        result: &CalibrationResult,
        on_inadequate: OnInadequate,
    ) -> Result<bool, StoreError> {
        let now = now_ms();
        let result_json = serde_json::to_string(result)?;
        let Some(mut tx) = self.begin_succeeded(fence, now).await? else {
            return Ok(false);
        };
        lock_key(self.backend, &mut tx, &run_key(claim.run_id)).await?;
        lock_key(self.backend, &mut tx, &unit_key(claim.unit_serial.as_str())).await?;
        let stored = StoredResult {
            run_id: claim.run_id,
            job_id: fence.job_id,
            unit_serial: &claim.unit_serial,
            run_time: claim.run_time,
            completed_at: now,
            parameters: &result.parameters,
            model_check: result.model_check.as_ref(),
            poorly_observable: &result.poorly_observable,
            cross_check_flagged: result
                .cross_check
                .as_ref()
                .map_or(&[], |c| c.flagged.as_slice()),
            temperature: result.temperature,
            scheme: result.scheme_coverage,
            model: Some(&result.model),
            document: &result_json,
        };
        insert_result(&mut tx, &stored).await?;
        let adequate = result.model_check.as_ref().map_or(true, |c| c.adequate);
        if !adequate && on_inadequate.queue_diagnose {
            sqlx::query(
                "INSERT INTO jobs (id, run_id, kind, state, max_attempts, run_after, created_at)
                 SELECT $1, $2, 'diagnose', 'queued', $3, $4, $5
                 WHERE NOT EXISTS (SELECT 1 FROM jobs WHERE run_id = $6 AND kind = 'diagnose'
                                   AND state IN ('queued', 'running'))",
            )
            .bind(JobId::new())
            .bind(claim.run_id)
            .bind(on_inadequate.max_attempts)
            .bind(now)
            .bind(now)
            .bind(claim.run_id)
            .execute(&mut *tx)
            .await?;
            hint_job_queued(self.backend, &mut tx).await?;
        }
        tx.commit().await?;
        Ok(true)
    }

    /// Stores a diagnose job's report and marks it succeeded, in one
    /// transaction, if and only if `fence` still holds the lease (as
    /// [`Store::complete_job`]). Writes no calibration result rows.
    pub async fn complete_diagnose_job(
        &self,
        (fence, claim): (&Fence, &RunClaim),
        report: &serde_json::Value,
    ) -> Result<bool, StoreError> {
        let now = now_ms();
        let report_json = serde_json::to_string(report)?;
        let Some(mut tx) = self.begin_succeeded(fence, now).await? else {
            return Ok(false);
        };
        sqlx::query(
            "INSERT INTO diagnoses (job_id, run_id, completed_at, report) VALUES ($1, $2, $3, $4)",
        )
        .bind(fence.job_id)
        .bind(claim.run_id)
        .bind(now)
        .bind(&report_json)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(true)
    }

    /// Records a failed attempt: back to the queue after `backoff` while
    /// attempts remain and `retry` holds; dead-lettered when `retry` holds
    /// but the attempts are spent; else failed for good. The error is kept
    /// in every case. Returns the new state, `None` if the lease was lost.
    pub async fn fail_job(
        &self,
        fence: &Fence,
        error: &str,
        retry: bool,
        backoff: Duration,
    ) -> Result<Option<JobState>, StoreError> {
        let now = now_ms();
        let sql = Fenced::update_returning(
            "state = CASE WHEN $4 AND attempts < max_attempts THEN 'queued'
                          WHEN $4 THEN 'dead_letter' ELSE 'failed' END,
                finished_at = CASE WHEN $4 AND attempts < max_attempts THEN NULL ELSE $5 END,
                run_after = $6, error = $7, stage = 'failed attempt',
                lease_owner = NULL, lease_expires_at = NULL",
            "RETURNING state",
        );
        let row = sql
            .query(fence)
            .bind(retry)
            .bind(now)
            .bind(now + backoff.as_millis() as i64)
            .bind(error)
            .fetch_optional(&self.write)
            .await?;
        Ok(row.map(|r| r.try_get("state")).transpose()?)
    }

    /// Marks a job cancelled after its worker stopped on request.
    pub async fn finish_cancelled(&self, fence: &Fence) -> Result<bool, StoreError> {
        let sql = Fenced::update(
            "state = 'cancelled', finished_at = $4, stage = 'cancelled',
                lease_owner = NULL, lease_expires_at = NULL",
        );
        let r = sql.query(fence).bind(now_ms()).execute(&self.write).await?;
        Ok(r.rows_affected() == 1)
    }

    /// Hands a job back to the queue at shutdown. The attempt is not
    /// counted: the job did not fail, the server stopped.
    pub async fn release_job(&self, fence: &Fence) -> Result<bool, StoreError> {
        let sql = Fenced::update(
            "state = 'queued', attempts = attempts - 1, run_after = $4,
                stage = 'handed back at shutdown', progress = 0,
                lease_owner = NULL, lease_expires_at = NULL",
        );
        let mut tx = self.begin_write().await?;
        let r = sql.query(fence).bind(now_ms()).execute(&mut *tx).await?;
        // Another process's idle worker may take it at once.
        hint_job_queued(self.backend, &mut tx).await?;
        tx.commit().await?;
        Ok(r.rows_affected() == 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::{InsertOutcome, NewRun, RunFile};
    use sinscal_core::io::data::DataFormat;

    async fn store_with_one_job() -> (tempfile::TempDir, Store, JobId) {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open_for_test(&dir.path().join("q.db")).await;
        let job_id = JobId::new();
        let new = NewRun {
            run_id: RunId::new(),
            job_id,
            unit_serial: "U-1".parse().unwrap(),
            file: RunFile {
                sha256: "00".into(),
                size_bytes: 0,
                records: 0,
                format: DataFormat::Csv,
                gzip: false,
                blob_path: "runs/ru/run-1.csv".into(),
                metadata: Stored::new("{}".into()),
            },
            recorded_at: None,
            uploaded_at: 0,
            max_attempts: 2,
            uploaded_by: None,
            product: None,
        };
        let outcome = store.insert_run_and_job(&new, 10).await.unwrap();
        assert_eq!(outcome, InsertOutcome::Created);
        (dir, store, job_id)
    }

    /// A lease that ran out is reclaimed as the next attempt; from then on
    /// every fenced write of the old attempt is refused, and the new one's
    /// writes land, their states read back typed.
    #[tokio::test]
    async fn every_fenced_write_of_a_reclaimed_attempt_is_refused() {
        let (_dir, store, job) = store_with_one_job().await;
        let lease = Duration::from_secs(30);
        let old = store.claim_job("a", Duration::ZERO).await.unwrap().unwrap();
        assert_eq!((old.kind, old.fence.attempt), (JobKind::Calibrate, 1));
        tokio::time::sleep(Duration::from_millis(5)).await;
        let new = store.claim_job("b", lease).await.unwrap().unwrap();
        assert_eq!(new.fence.attempt, 2);

        assert_eq!(
            store.heartbeat(&old.fence, lease, 0.5, "x").await.unwrap(),
            None
        );
        let failed = store.fail_job(&old.fence, "e", true, Duration::ZERO);
        assert_eq!(failed.await.unwrap(), None);
        assert!(!store.finish_cancelled(&old.fence).await.unwrap());
        assert!(!store.release_job(&old.fence).await.unwrap());
        let report = serde_json::json!({});
        let Subject::Run(run) = &old.subject else {
            panic!("a calibrate job's claim names its run")
        };
        let completed = store.complete_diagnose_job((&old.fence, run), &report);
        assert!(!completed.await.unwrap());

        assert_eq!(
            store.heartbeat(&new.fence, lease, 0.5, "x").await.unwrap(),
            Some(false)
        );
        // The second attempt is the last: a retryable failure fails for good.
        let failed = store.fail_job(&new.fence, "e", true, Duration::ZERO);
        assert_eq!(failed.await.unwrap(), Some(JobState::DeadLetter));
        let row = store.get_job(job).await.unwrap().unwrap();
        assert_eq!(
            (row.kind, row.state),
            (JobKind::Calibrate, JobState::DeadLetter)
        );
        assert_eq!(row.error.as_deref(), Some("e"));
        let counts = store.job_counts().await.unwrap();
        assert_eq!(counts.of(JobState::DeadLetter), 1);
        assert_eq!(counts.len(), JobState::ALL.len());
    }

    /// A failed attempt with attempts left goes back to the queue; a
    /// release at shutdown does not count the attempt.
    #[tokio::test]
    async fn retry_and_release_put_the_job_back_in_the_queue() {
        let (_dir, store, job) = store_with_one_job().await;
        let lease = Duration::from_secs(30);
        let first = store.claim_job("a", lease).await.unwrap().unwrap();
        let failed = store.fail_job(&first.fence, "e", true, Duration::ZERO);
        assert_eq!(failed.await.unwrap(), Some(JobState::Queued));
        let second = store.claim_job("a", lease).await.unwrap().unwrap();
        assert_eq!(second.fence.attempt, 2);
        assert!(store.release_job(&second.fence).await.unwrap());
        let row = store.get_job(job).await.unwrap().unwrap();
        assert_eq!((row.state, row.attempts), (JobState::Queued, 1));
        assert_eq!(store.queue_depth().await.unwrap(), 1);
    }
}
