//! Jobs as rows: reading them, counting them, cancelling them, and queueing
//! a diagnosis or a calibration again (with a model adopted for the run). (What a worker does to the job it holds is `queue`.)

use std::collections::BTreeMap;

use sqlx::FromRow;

use super::db::{now_ms, Store, WriteTx};
use super::dialect::{hint_job_queued, lock_key, run_key, unit_key};
use super::error::StoreError;
use super::ids::{JobId, RunId};
use super::kinds::{Flag, JobKind, JobState};
use super::verdicts::refresh_unit;
use super::versions::supersede_current;
use sinscal_core::calib::ErrorModel;

#[derive(Clone, Debug, FromRow)]
pub struct JobRow {
    pub id: JobId,
    /// The job's run; `None` for a design job, which has none.
    pub run_id: Option<RunId>,
    pub kind: JobKind,
    pub state: JobState,
    pub attempts: i64,
    pub max_attempts: i64,
    pub lease_owner: Option<String>,
    pub lease_expires_at: Option<i64>,
    pub heartbeat_at: Option<i64>,
    pub progress: f64,
    pub stage: Option<String>,
    #[sqlx(try_from = "Flag")]
    pub cancel_requested: bool,
    pub error: Option<String>,
    pub created_at: i64,
    pub started_at: Option<i64>,
    pub finished_at: Option<i64>,
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

/// How many jobs of one state (`SELECT state, COUNT(*) AS n ...`).
#[derive(FromRow)]
pub(super) struct StateCount {
    state: JobState,
    n: i64,
}

/// Jobs per state: what the queue's gauges and a unit's page show. Only
/// the states counted are present; JSON is an object keyed by the states'
/// names in their alphabetical order (the order of the metrics' labels).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct JobCounts(BTreeMap<&'static str, (JobState, i64)>);

impl JobCounts {
    /// Every state, each with no job.
    fn zero() -> JobCounts {
        JobCounts(
            JobState::ALL
                .iter()
                .map(|&s| (s.as_str(), (s, 0)))
                .collect(),
        )
    }

    fn add(&mut self, rows: Vec<StateCount>) {
        for c in rows {
            self.0.insert(c.state.as_str(), (c.state, c.n));
        }
    }

    /// Jobs in `state` (0 when not counted).
    pub fn of(&self, state: JobState) -> i64 {
        self.0.get(state.as_str()).map_or(0, |&(_, n)| n)
    }

    /// The states counted, by name, with their counts.
    pub fn iter(&self) -> impl Iterator<Item = (JobState, i64)> + '_ {
        self.0.values().copied()
    }

    /// How many states are counted.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl serde::Serialize for JobCounts {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(self.0.iter().map(|(name, (_, n))| (name, n)))
    }
}

/// Counts of the states present in `rows`.
pub(super) fn by_state(rows: Vec<StateCount>) -> JobCounts {
    let mut counts = JobCounts::default();
    counts.add(rows);
    counts
}

/// Jobs waiting for a worker, on either pool or inside a transaction.
pub(super) async fn count_queued<'e>(
    e: impl sqlx::Executor<'e, Database = sqlx::Any>,
) -> Result<i64, StoreError> {
    Ok(
        sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE state = 'queued'")
            .fetch_one(e)
            .await?,
    )
}

impl Store {
    pub async fn queue_depth(&self) -> Result<i64, StoreError> {
        count_queued(&self.read).await
    }

    pub async fn get_job(&self, id: JobId) -> Result<Option<JobRow>, StoreError> {
        Ok(sqlx::query_as("SELECT * FROM jobs WHERE id = $1")
            .bind(id)
            .fetch_optional(&self.read)
            .await?)
    }

    /// Jobs per state (every state present, zero included).
    pub async fn job_counts(&self) -> Result<JobCounts, StoreError> {
        let mut counts = JobCounts::zero();
        let rows = sqlx::query_as("SELECT state, COUNT(*) AS n FROM jobs GROUP BY state")
            .fetch_all(&self.read)
            .await?;
        counts.add(rows);
        Ok(counts)
    }

    /// A run's most recent diagnose job, if any.
    pub async fn latest_diagnose_job(&self, run_id: RunId) -> Result<Option<JobRow>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT * FROM jobs WHERE run_id = $1 AND kind = 'diagnose'
             ORDER BY created_at DESC, id DESC LIMIT 1",
        )
        .bind(run_id)
        .fetch_optional(&self.read)
        .await?)
    }

    /// Cancels a queued job at once, or asks a running one's worker to stop.
    /// Returns the job afterwards, `None` if there is none.
    pub async fn cancel_job(&self, id: JobId) -> Result<Option<JobRow>, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        sqlx::query(
            "UPDATE jobs SET state = 'cancelled', finished_at = $1, cancel_requested = TRUE
             WHERE id = $2 AND state = 'queued'",
        )
        .bind(now)
        .bind(id)
        .execute(&mut *tx)
        .await?;
        sqlx::query("UPDATE jobs SET cancel_requested = TRUE WHERE id = $1 AND state = 'running'")
            .bind(id)
            .execute(&mut *tx)
            .await?;
        let job = sqlx::query_as("SELECT * FROM jobs WHERE id = $1")
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(job)
    }

    /// Queues a diagnose job for a run, unless the run does not exist, a
    /// diagnose job for it is already queued or running (returned instead),
    /// or the queue is full.
    pub async fn queue_diagnose_job(
        &self,
        run_id: RunId,
        job_id: JobId,
        max_attempts: i64,
        max_queue: i64,
    ) -> Result<DiagnoseQueued, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, &run_key(run_id)).await?;
        let exists: Option<i64> = sqlx::query_scalar("SELECT 1 FROM runs WHERE id = $1")
            .bind(run_id)
            .fetch_optional(&mut *tx)
            .await?;
        if exists.is_none() {
            return Ok(DiagnoseQueued::NoRun);
        }
        let active: Option<JobRow> = sqlx::query_as(
            "SELECT * FROM jobs WHERE run_id = $1 AND kind = 'diagnose'
                AND state IN ('queued', 'running')",
        )
        .bind(run_id)
        .fetch_optional(&mut *tx)
        .await?;
        if let Some(job) = active {
            return Ok(DiagnoseQueued::Existing(job));
        }
        if count_queued(&mut *tx).await? >= max_queue {
            return Ok(DiagnoseQueued::QueueFull);
        }
        let job = sqlx::query_as(
            "INSERT INTO jobs (id, run_id, kind, state, max_attempts, run_after, created_at)
             VALUES ($1, $2, 'diagnose', 'queued', $3, $4, $5)
             RETURNING *",
        )
        .bind(job_id)
        .bind(run_id)
        .bind(max_attempts)
        .bind(now)
        .bind(now)
        .fetch_one(&mut *tx)
        .await?;
        hint_job_queued(self.backend, &mut tx).await?;
        tx.commit().await?;
        Ok(DiagnoseQueued::Created(job))
    }
}

/// What asking to calibrate a run again did.
#[derive(Debug)]
pub enum CalibrationRequeued {
    /// The run's calibration job is queued again; its earlier result (if
    /// any) is superseded (kept, no longer current) and the unit's
    /// verdicts judged again without it.
    Queued(JobRow),
    /// The calibration job is queued or running already.
    Busy(JobRow),
    NoRun,
    QueueFull,
}

/// A model adopted for a run from its diagnosis.
#[derive(Clone, Copy, Debug)]
pub struct Adoption<'a> {
    pub model: &'a ErrorModel,
    /// The diagnose job whose named effects the model adds.
    pub diagnosis: JobId,
    /// The token adopting it.
    pub by: &'a str,
}

impl Store {
    /// Queues a run's one calibration job again (after a change of the
    /// server's error model or tolerances, or a failure that was fixed),
    /// in one transaction with superseding the result it replaces. The
    /// attempt counter keeps counting, since it fences the job's leases: a
    /// worker of an earlier attempt can never write the new result.
    /// `fit_unseen_wander`, when given, is kept on the run for this and
    /// later calibrations (`EstimateOptions::fit_unseen_wander`).
    pub async fn requeue_calibration(
        &self,
        run_id: RunId,
        fit_unseen_wander: Option<bool>,
        max_attempts: i64,
        max_queue: i64,
    ) -> Result<CalibrationRequeued, StoreError> {
        let change = RunChange {
            adoption: None,
            fit_unseen_wander,
        };
        self.requeue_with(run_id, change, (max_attempts, max_queue))
            .await
    }

    /// Adopts a model for a run (its calibration jobs carry it from now
    /// on, whatever its product's or the server's model) and queues its
    /// calibration with it, as [`Store::requeue_calibration`]: the result
    /// of the old model stays readable as a superseded result.
    pub async fn adopt_model(
        &self,
        run_id: RunId,
        adoption: Adoption<'_>,
        max_attempts: i64,
        max_queue: i64,
    ) -> Result<CalibrationRequeued, StoreError> {
        let change = RunChange {
            adoption: Some(adoption),
            fit_unseen_wander: None,
        };
        self.requeue_with(run_id, change, (max_attempts, max_queue))
            .await
    }

    async fn requeue_with(
        &self,
        run_id: RunId,
        change: RunChange<'_>,
        (max_attempts, max_queue): (i64, i64),
    ) -> Result<CalibrationRequeued, StoreError> {
        let now = now_ms();
        let mut tx = self.begin_write().await?;
        lock_key(self.backend, &mut tx, &run_key(run_id)).await?;
        let job: Option<JobRow> =
            sqlx::query_as("SELECT * FROM jobs WHERE run_id = $1 AND kind = 'calibrate'")
                .bind(run_id)
                .fetch_optional(&mut *tx)
                .await?;
        let Some(job) = job else {
            return Ok(CalibrationRequeued::NoRun);
        };
        if matches!(job.state, JobState::Queued | JobState::Running) {
            return Ok(CalibrationRequeued::Busy(job));
        }
        if count_queued(&mut *tx).await? >= max_queue {
            return Ok(CalibrationRequeued::QueueFull);
        }
        let (serial, run_time): (String, i64) =
            sqlx::query_as("SELECT unit_serial, run_time FROM runs WHERE id = $1")
                .bind(run_id)
                .fetch_one(&mut *tx)
                .await?;
        lock_key(self.backend, &mut tx, &unit_key(&serial)).await?;
        if let Some(a) = change.adoption {
            record_adoption(&mut tx, run_id, a, now).await?;
        }
        if let Some(fit) = change.fit_unseen_wander {
            // Literals, which both dialects read as their boolean.
            let value = if fit { "TRUE" } else { "FALSE" };
            sqlx::query(&format!(
                "UPDATE runs SET fit_unseen_wander = {value} WHERE id = $1"
            ))
            .bind(run_id)
            .execute(&mut *tx)
            .await?;
        }
        supersede_current(&mut tx, run_id, now).await?;
        let job = sqlx::query_as(
            "UPDATE jobs SET state = 'queued', max_attempts = attempts + $1, lease_owner = NULL,
                 lease_expires_at = NULL, heartbeat_at = NULL, run_after = $2, progress = 0,
                 stage = NULL, cancel_requested = FALSE, error = NULL, started_at = NULL,
                 finished_at = NULL
             WHERE id = $3 RETURNING *",
        )
        .bind(max_attempts)
        .bind(now)
        .bind(job.id)
        .fetch_one(&mut *tx)
        .await?;
        refresh_unit(&mut tx, &serial, Some((run_time, run_id)), now).await?;
        hint_job_queued(self.backend, &mut tx).await?;
        tx.commit().await?;
        Ok(CalibrationRequeued::Queued(job))
    }
}

/// What asking for a run's calibration again changes on the run first.
struct RunChange<'a> {
    adoption: Option<Adoption<'a>>,
    fit_unseen_wander: Option<bool>,
}

async fn record_adoption(
    tx: &mut WriteTx,
    run_id: RunId,
    a: Adoption<'_>,
    now: i64,
) -> Result<(), StoreError> {
    sqlx::query(
        "UPDATE runs SET model = $1, model_diagnosis = $2, model_adopted_by = $3,
                         model_adopted_at = $4
         WHERE id = $5",
    )
    .bind(a.model.to_string())
    .bind(a.diagnosis)
    .bind(a.by)
    .bind(now)
    .bind(run_id)
    .execute(&mut **tx)
    .await?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job `id` of its own run (so the one-job-per-run indexes stay out
    /// of it; a design job has no run) with this kind and state, read back.
    async fn insert_job<'a, K, S>(
        conn: &mut sqlx::AnyConnection,
        id: &'a str,
        (kind, run): (K, Option<&'a str>),
        state: S,
    ) -> Result<JobRow, sqlx::Error>
    where
        K: sqlx::Encode<'a, sqlx::Any> + sqlx::Type<sqlx::Any> + Send + 'a,
        S: sqlx::Encode<'a, sqlx::Any> + sqlx::Type<sqlx::Any> + Send + 'a,
    {
        sqlx::query(
            "INSERT INTO runs (id, unit_serial, sha256, size_bytes, records, format,
                               gzip, blob_path, metadata, run_time, uploaded_at)
             VALUES ($1, 'U', $1, 0, 0, 'csv', FALSE, 'runs/x', '{}', 0, 0)",
        )
        .bind(id)
        .execute(&mut *conn)
        .await?;
        sqlx::query(
            "INSERT INTO jobs (id, run_id, kind, state, max_attempts, run_after, created_at)
             VALUES ($1, $2, $3, $4, 1, 0, 0)",
        )
        .bind(id)
        .bind(run)
        .bind(kind)
        .bind(state)
        .execute(&mut *conn)
        .await?;
        sqlx::query_as("SELECT * FROM jobs WHERE id = $1")
            .bind(id)
            .fetch_one(&mut *conn)
            .await
    }

    /// Every spelling of the Rust vocabularies is one the schema's CHECK
    /// constraints accept, read back as the same value; others are refused.
    #[tokio::test]
    async fn every_kind_and_state_is_a_value_the_schema_accepts() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open_for_test(&dir.path().join("k.db")).await;
        let mut tx = store.begin_write().await.unwrap();
        sqlx::query("INSERT INTO units (serial, created_at) VALUES ('U', 0)")
            .execute(&mut *tx)
            .await
            .unwrap();
        for kind in JobKind::ALL {
            for state in JobState::ALL {
                let id = JobId::new().to_string();
                let run = (kind != JobKind::Design).then_some(id.as_str());
                let row = insert_job(&mut tx, &id, (kind, run), state).await.unwrap();
                assert_eq!((row.kind, row.state), (kind, state));
            }
        }
        let ids: Vec<String> = (0..4).map(|_| JobId::new().to_string()).collect();
        let (a, b) = (Some(ids[0].as_str()), Some(ids[1].as_str()));
        assert!(insert_job(&mut tx, &ids[0], ("calibrate", a), "paused")
            .await
            .is_err());
        assert!(insert_job(&mut tx, &ids[1], ("replay", b), "queued")
            .await
            .is_err());
        // A run's kinds need their run; a design has none.
        assert!(insert_job(&mut tx, &ids[2], ("calibrate", None), "queued")
            .await
            .is_err());
        let with_run = insert_job(
            &mut tx,
            &ids[3],
            ("design", Some(ids[3].as_str())),
            "queued",
        );
        assert!(with_run.await.is_err());
    }
}
