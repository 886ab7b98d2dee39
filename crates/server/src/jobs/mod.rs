//! The durable job queue's workers: claim a job with a lease, run the
//! estimator (a `calibrate` job) or the discrepancy workflow (a `diagnose`
//! job) on a blocking thread, renew the lease while it works, and
//! write the outcome only while the lease still holds (fencing, see
//! [`crate::store::Fence`]).
//!
//! The queue itself lives in SQLite (`store`); this module never writes SQL
//! and never runs the estimator on the async runtime.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::Notify;
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

mod design;

use futures_util::future::BoxFuture;
use futures_util::FutureExt as _;

use crate::metrics::{ClaimOutcome, JobOutcome, Metrics};
use crate::runstore::{LocalCopy, RunStore};
use crate::store::{
    Claim, Fence, JobId, JobKind, JobState, OnInadequate, RunClaim, Store, StoreError, Subject,
};
use sinscal_core::calib::{CalibError, CalibrationResult, EstimateOptions, HeldNoise, Progress};
use sinscal_core::diagnose::{DiagnoseError, DiagnoseOptions};
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::pipeline::{calibrate_file, diagnose_file};

/// Errors of the job layer (only the database can fail it: an estimator
/// failure is an outcome of the job, not an error of the worker).
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// How an attempt at a job ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobEnd {
    Succeeded,
    /// Failed; queued again for another attempt.
    Retrying,
    /// Failed for good.
    Failed,
    /// Failed on its last allowed attempt with an error worth retrying:
    /// set aside in the dead-letter state.
    DeadLettered,
    Cancelled,
    /// Stopped at shutdown and returned to the queue, attempt not counted.
    HandedBack,
    /// The lease was reclaimed by another worker; nothing was written.
    LeaseLost,
}

/// What one step of a worker did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    Ran { job_id: JobId, end: JobEnd },
    Empty,
}

/// What a job's blocking work produced.
enum Done {
    Calibration(Box<CalibrationResult>),
    /// The `DiagnoseReport` as JSON, serialized on the blocking thread
    /// (it carries the gap series, so it is not small).
    Diagnosis(serde_json::Value),
}

/// Why a job's blocking work stopped without a product.
enum Failure {
    /// The cancel flag was seen.
    Cancelled,
    /// Possibly transient (I/O on our own stored file): worth another attempt.
    Transient(String),
    /// Will fail the same way again: failed at once.
    Permanent(String),
}

impl From<CalibError> for Failure {
    fn from(e: CalibError) -> Self {
        match e {
            CalibError::Cancelled => Failure::Cancelled,
            // A source error is I/O on our own stored file (the data was
            // validated at upload): possibly transient, so retried. A run
            // the estimator finds unusable or numerically hopeless will be
            // so again.
            e @ CalibError::Source(_) => Failure::Transient(e.to_string()),
            e => Failure::Permanent(e.to_string()),
        }
    }
}

impl From<DiagnoseError> for Failure {
    fn from(e: DiagnoseError) -> Self {
        match e {
            // The workflow runs the estimator: its errors mean what they
            // mean for a calibration job.
            DiagnoseError::Calib(c) => c.into(),
            // A scheme that cannot be reconstructed, or a gap fit that
            // breaks down, is a property of the run's data.
            e @ (DiagnoseError::Scheme(_) | DiagnoseError::Numerical(_)) => {
                Failure::Permanent(e.to_string())
            }
        }
    }
}

/// What fetching a claimed run's file came to.
enum Fetched {
    Copy(LocalCopy),
    /// Possibly transient (the store did not answer): worth another attempt.
    Failed(String),
    LeaseLost,
}

/// Why the estimator's cancel flag was raised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum StopReason {
    CancelRequested,
    HandBack,
    LeaseLost,
}

/// Settings of the workers.
#[derive(Clone, Debug)]
pub struct JobSettings {
    /// Where the runs' files are read from.
    pub run_store: RunStore,
    pub lease: Duration,
    pub estimate: EstimateOptions,
    /// First retry delay; doubled per attempt, at most a minute.
    pub retry_backoff: Duration,
    /// What a result whose model check fails sets going.
    pub on_inadequate: OnInadequate,
    /// Wall time a design job may take; beyond it the job fails, saying so.
    pub design_time_limit: Duration,
}

/// Runs jobs. One per server; each worker task calls
/// [`JobRunner::try_run_next_job`] in a loop, tests call it directly.
pub struct JobRunner {
    store: Store,
    settings: JobSettings,
    metrics: Arc<Metrics>,
    /// Names this process in lease owners: `<instance>/<worker>`.
    instance: String,
    /// Fired when shutdown's grace period is over: running jobs stop and go
    /// back to the queue.
    hand_back: CancellationToken,
}

impl JobRunner {
    pub fn new(store: Store, settings: JobSettings, metrics: Arc<Metrics>) -> Self {
        JobRunner {
            store,
            settings,
            metrics,
            instance: uuid::Uuid::new_v4().simple().to_string(),
            hand_back: CancellationToken::new(),
        }
    }

    /// Stops running jobs and returns them to the queue.
    pub fn hand_back_running_jobs(&self) {
        self.hand_back.cancel();
    }

    /// How often a running job's lease is renewed and its progress written:
    /// a third of the lease, so two heartbeats may be lost before it expires,
    /// and at least once a second so that progress reads stay fresh.
    fn heartbeat_every(&self) -> Duration {
        (self.settings.lease / 3).clamp(Duration::from_millis(100), Duration::from_secs(1))
    }

    /// The heartbeat's clock: its first tick a period from now (the claim
    /// or the last write has just renewed the lease), late ticks delayed
    /// rather than bunched.
    async fn heartbeat_clock(&self) -> tokio::time::Interval {
        let mut tick = tokio::time::interval(self.heartbeat_every());
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        tick.tick().await;
        tick
    }

    /// Claims the next job and runs it to its end, or reports that none is
    /// claimable.
    pub async fn try_run_next_job(&self, worker: usize) -> Result<Outcome, JobError> {
        let owner = format!("{}/{worker}", self.instance);
        let asked = Instant::now();
        let claimed = self.store.claim_job(&owner, self.settings.lease).await;
        let outcome = match &claimed {
            Ok(Some(_)) => ClaimOutcome::Claimed,
            Ok(None) => ClaimOutcome::Empty,
            Err(_) => ClaimOutcome::Error,
        };
        self.metrics.claim(outcome, asked.elapsed().as_secs_f64());
        let Some(claim) = claimed? else {
            return Ok(Outcome::Empty);
        };
        let job_id = claim.fence.job_id;
        tracing::info!(job = %job_id, kind = %claim.kind, attempt = claim.fence.attempt, "job claimed");
        let started = Instant::now();
        let end = match &claim.subject {
            Subject::Run(run) => self.run_claimed(&claim, run).await?,
            Subject::Design { request } => self.run_design(&claim, request).await?,
        };
        let seconds = started.elapsed().as_secs_f64();
        match end {
            JobEnd::Succeeded => self.metrics.job_finished(JobOutcome::Succeeded, seconds),
            JobEnd::Failed | JobEnd::Retrying | JobEnd::DeadLettered => {
                self.metrics.job_finished(JobOutcome::Failed, seconds)
            }
            JobEnd::Cancelled => self.metrics.job_finished(JobOutcome::Cancelled, seconds),
            JobEnd::HandedBack | JobEnd::LeaseLost => {}
        }
        tracing::info!(job = %job_id, ?end, seconds, "job attempt ended");
        Ok(Outcome::Ran { job_id, end })
    }

    async fn run_claimed(&self, claim: &Claim, run: &RunClaim) -> Result<JobEnd, JobError> {
        let fence = &claim.fence;
        let meta = match run.metadata.parse() {
            Ok(m) => m,
            // Validated at upload; if it no longer parses, no retry helps.
            Err(e) => {
                return self
                    .fail(claim, &format!("stored metadata: {e}"), false)
                    .await
            }
        };
        let estimate = match self.estimate_options(run) {
            Ok(o) => o,
            // Validated when it was set; if it no longer parses, no retry helps.
            Err(e) => return self.fail(claim, &e, false).await,
        };
        // A local file to stream (for an object store, a scratch download
        // that goes when `local` is dropped, once the blocking work ends
        // however it ends). A store that cannot answer now may later.
        let local = match self.fetch_run_file(fence, run).await {
            Fetched::Copy(local) => local,
            Fetched::Failed(e) => return self.fail(claim, &e, true).await,
            Fetched::LeaseLost => return Ok(JobEnd::LeaseLost),
        };
        let path = local.path().to_path_buf();
        let cancel = Arc::new(AtomicBool::new(false));
        let progress = Arc::new(Mutex::new((0.0_f64, String::from("starting"))));
        let task = spawn_estimator(
            claim.kind,
            path,
            meta,
            estimate,
            (cancel.clone(), progress.clone()),
        );
        let (joined, reason) = self.watch(&claim.fence, task, &cancel, &progress).await;
        // The blocking work is over: a scratch copy goes before the outcome
        // is written.
        drop(local);
        if reason == Some(StopReason::LeaseLost) {
            return Ok(JobEnd::LeaseLost);
        }
        match joined {
            Ok(Ok(Done::Calibration(result))) => {
                let on = self.settings.on_inadequate;
                let write = || self.store.complete_job((fence, run), &result, on).boxed();
                self.store_product(fence, &write).await
            }
            Ok(Ok(Done::Diagnosis(report))) => {
                let write = || {
                    self.store
                        .complete_diagnose_job((fence, run), &report)
                        .boxed()
                };
                self.store_product(fence, &write).await
            }
            Ok(Err(Failure::Cancelled)) => self.stopped(fence, reason).await,
            Ok(Err(Failure::Transient(e))) => self.fail(claim, &e, true).await,
            Ok(Err(Failure::Permanent(e))) => self.fail(claim, &e, false).await,
            Err(join) => self.fail(claim, &panicked(&join), true).await,
        }
    }

    /// Ends a job whose work stopped on its cancel flag: handed back to
    /// the queue at shutdown, else cancelled; lost if its lease is.
    async fn stopped(&self, fence: &Fence, reason: Option<StopReason>) -> Result<JobEnd, JobError> {
        let done = match reason {
            Some(StopReason::HandBack) => {
                if self.store.release_job(fence).await? {
                    return Ok(JobEnd::HandedBack);
                }
                false
            }
            _ => self.store.finish_cancelled(fence).await?,
        };
        Ok(if done {
            JobEnd::Cancelled
        } else {
            JobEnd::LeaseLost
        })
    }

    /// The estimator's options for a claimed job: the server's, carrying
    /// the run's own model (adopted, or its product type's) when it has one,
    /// the fit of unseen wander when an engineer asked for it, and the
    /// noise model held for the unit where its use puts it.
    fn estimate_options(&self, run: &RunClaim) -> Result<EstimateOptions, String> {
        let mut estimate = self.settings.estimate.clone();
        if let Some(model) = &run.model {
            estimate.model = model
                .parse()
                .map_err(|e| format!("the run's stored model: {e}"))?;
        }
        estimate.fit_unseen_wander = run.fit_unseen_wander;
        if let Some(held) = held_noise(run)? {
            held.apply_to(&mut estimate);
        }
        Ok(estimate)
    }

    /// Waits for the estimator, writing its progress as the lease's
    /// heartbeat; asks it to stop when the job is cancelled, the lease is
    /// lost or the worker hands its jobs back, and says which.
    async fn watch<T>(
        &self,
        fence: &Fence,
        task: JoinHandle<T>,
        cancel: &AtomicBool,
        progress: &Mutex<(f64, String)>,
    ) -> (Result<T, tokio::task::JoinError>, Option<StopReason>) {
        tokio::pin!(task);
        let mut tick = self.heartbeat_clock().await;
        let mut reason: Option<StopReason> = None;
        let joined = loop {
            tokio::select! {
                joined = &mut task => break joined,
                _ = tick.tick() => {
                    let (fraction, stage) = progress.lock().expect("progress lock").clone();
                    match self.store.heartbeat(fence, self.settings.lease, fraction, &stage).await {
                        Ok(Some(true)) if reason.is_none() => {
                            reason = Some(StopReason::CancelRequested);
                            cancel.store(true, Ordering::Relaxed);
                        }
                        Ok(Some(_)) => {}
                        Ok(None) => {
                            tracing::warn!(job = %fence.job_id, "lease lost; stopping without writing");
                            reason = Some(StopReason::LeaseLost);
                            cancel.store(true, Ordering::Relaxed);
                        }
                        // A missed heartbeat is not fatal: the lease has two
                        // more periods to run before another worker may
                        // take the job, and fencing covers that case.
                        Err(e) => tracing::warn!(job = %fence.job_id, error = %e, "heartbeat failed"),
                    }
                }
                _ = self.hand_back.cancelled(), if reason.is_none() => {
                    reason = Some(StopReason::HandBack);
                    cancel.store(true, Ordering::Relaxed);
                }
            }
        };
        (joined, reason)
    }

    /// The claimed run's file as a local file, the lease renewed while it
    /// arrives: an object store's download of a large run can take longer
    /// than a lease.
    async fn fetch_run_file(&self, fence: &Fence, run: &RunClaim) -> Fetched {
        let fetch = self.settings.run_store.local_copy(&run.blob_path);
        tokio::pin!(fetch);
        let mut tick = self.heartbeat_clock().await;
        loop {
            tokio::select! {
                fetched = &mut fetch => {
                    return match fetched {
                        Ok(copy) => Fetched::Copy(copy),
                        Err(e) => Fetched::Failed(e.to_string()),
                    };
                }
                _ = tick.tick() => {
                    let lease = self.settings.lease;
                    match self.store.heartbeat(fence, lease, 0.0, "fetching the run").await {
                        Ok(None) => return Fetched::LeaseLost,
                        // A cancel request is seen by the first heartbeat
                        // of the work itself.
                        Ok(Some(_)) => {}
                        Err(e) => tracing::warn!(job = %fence.job_id, error = %e, "heartbeat failed"),
                    }
                }
            }
        }
    }

    /// Writes a finished job's product. A full disk does not fail the job:
    /// the product is kept and the write retried, with backoff, while the
    /// lease is renewed, until space returns, the lease is lost, or the
    /// server hands its jobs back.
    async fn store_product<'w>(
        &self,
        fence: &Fence,
        write: &(dyn Fn() -> BoxFuture<'w, Result<bool, StoreError>> + Sync),
    ) -> Result<JobEnd, JobError> {
        // Never longer than a heartbeat period, so the lease stays renewed.
        let longest = self.heartbeat_every();
        let mut wait = Duration::from_millis(50).min(longest);
        loop {
            let written = write().await;
            match written {
                Ok(true) => return Ok(JobEnd::Succeeded),
                Ok(false) => return Ok(JobEnd::LeaseLost),
                Err(e) if e.is_storage_full() => {
                    self.metrics.storage_full_retry();
                    tracing::warn!(job = %fence.job_id, error = %e, retry_in = ?wait,
                        "storage full: the result is kept and its write retried");
                }
                Err(e) => return Err(e.into()),
            }
            tokio::select! {
                _ = tokio::time::sleep(wait) => {}
                _ = self.hand_back.cancelled() => {
                    // The product is lost with the process; the job runs
                    // again after the restart, its attempt not counted.
                    return Ok(if self.store.release_job(fence).await? {
                        JobEnd::HandedBack
                    } else {
                        JobEnd::LeaseLost
                    });
                }
            }
            wait = (wait * 2).min(longest);
            let stage = "storing the result: storage full, retrying";
            match self
                .store
                .heartbeat(fence, self.settings.lease, 1.0, stage)
                .await
            {
                Ok(None) => return Ok(JobEnd::LeaseLost),
                Ok(Some(_)) => {}
                // Likely the same full disk: the lease has two more periods.
                Err(e) => tracing::warn!(job = %fence.job_id, error = %e, "heartbeat failed"),
            }
        }
    }

    async fn fail(&self, claim: &Claim, error: &str, retry: bool) -> Result<JobEnd, JobError> {
        let exp = u32::try_from(claim.fence.attempt.clamp(1, 6) - 1).unwrap_or(0);
        let backoff = (self.settings.retry_backoff * 2u32.pow(exp)).min(Duration::from_secs(60));
        tracing::warn!(job = %claim.fence.job_id, attempt = claim.fence.attempt, error, "job attempt failed");
        Ok(
            match self
                .store
                .fail_job(&claim.fence, error, retry, backoff)
                .await?
            {
                Some(JobState::Queued) => JobEnd::Retrying,
                Some(JobState::DeadLetter) => JobEnd::DeadLettered,
                Some(_) => JobEnd::Failed,
                None => JobEnd::LeaseLost,
            },
        )
    }
}

/// The noise model held for the claimed run's unit, checked again as when
/// it was set.
fn held_noise(run: &RunClaim) -> Result<Option<HeldNoise>, String> {
    let (Some(noise), Some(used_as)) = (&run.held_noise, &run.held_noise_use) else {
        return Ok(None);
    };
    HeldNoise::from_stored(noise, used_as)
        .map(Some)
        .map_err(|e| format!("the unit's held noise model: {e}"))
}

/// A blocking task's end that was no answer, in words.
fn panicked(join: &tokio::task::JoinError) -> String {
    if join.is_panic() {
        "the estimator panicked".into()
    } else {
        "the estimator task was aborted".into()
    }
}

/// The running worker tasks.
pub struct WorkerPool {
    handles: Vec<JoinHandle<()>>,
    stop: CancellationToken,
    runner: Arc<JobRunner>,
}

impl WorkerPool {
    /// Starts `n` workers. `wake` is notified on every upload; without it
    /// a worker still polls every `poll` (to reclaim expired leases and
    /// pick up retries whose backoff has passed).
    pub fn start(
        runner: Arc<JobRunner>,
        n: usize,
        wake: Arc<Notify>,
        poll: Duration,
    ) -> WorkerPool {
        let stop = CancellationToken::new();
        let handles = (0..n)
            .map(|worker| {
                let (runner, wake, stop) = (runner.clone(), wake.clone(), stop.clone());
                tokio::spawn(async move {
                    loop {
                        if stop.is_cancelled() {
                            break;
                        }
                        match runner.try_run_next_job(worker).await {
                            Ok(Outcome::Ran { .. }) => continue,
                            Ok(Outcome::Empty) => {}
                            Err(e) => tracing::error!(worker, error = %e, "worker step failed"),
                        }
                        tokio::select! {
                            _ = wake.notified() => {}
                            _ = tokio::time::sleep(poll) => {}
                            _ = stop.cancelled() => break,
                        }
                    }
                })
            })
            .collect();
        WorkerPool {
            handles,
            stop,
            runner,
        }
    }

    /// Stops taking work; running jobs get `grace` to finish, then are
    /// handed back to the queue.
    pub async fn shutdown(self, grace: Duration) {
        self.stop.cancel();
        let mut all = futures_util::future::join_all(self.handles);
        if tokio::time::timeout(grace, &mut all).await.is_err() {
            tracing::info!("grace period over: handing running jobs back to the queue");
            self.runner.hand_back_running_jobs();
            // The estimator checks its cancel flag between records; if it is
            // stuck nonetheless the lease expiry returns the job instead.
            let _ = tokio::time::timeout(Duration::from_secs(10), all).await;
        }
    }
}

/// The job's estimator on a blocking thread: a calibration or a diagnosis
/// of the run at `path`. It stores its latest progress in `progress` and
/// stops when `cancel` is set.
fn spawn_estimator(
    kind: JobKind,
    path: std::path::PathBuf,
    meta: RunMetadata,
    estimate: EstimateOptions,
    (cancel, progress): (Arc<AtomicBool>, Arc<Mutex<(f64, String)>>),
) -> JoinHandle<Result<Done, Failure>> {
    tokio::task::spawn_blocking(move || -> Result<Done, Failure> {
        // The callback only stores the latest value; the heartbeat writes
        // it, so progress costs one row update a second however often the
        // estimator reports.
        let mut report = |p: Progress| {
            *progress.lock().expect("progress lock") = (p.fraction.clamp(0.0, 1.0), p.stage);
        };
        // The schema's CHECK allows no other kind (a row with one would
        // already have failed to decode at the claim).
        match kind {
            JobKind::Diagnose => {
                let rep = diagnose_file(
                    &path,
                    &meta,
                    &DiagnoseOptions::default(),
                    &mut report,
                    &cancel,
                )?;
                serde_json::to_value(&rep)
                    .map(Done::Diagnosis)
                    .map_err(|e| Failure::Permanent(format!("report to JSON: {e}")))
            }
            JobKind::Calibrate => {
                let result = calibrate_file(&path, &meta, &estimate, &mut report, &cancel)?;
                Ok(Done::Calibration(Box::new(result)))
            }
            // A design job is claimed with its request, never a run file
            // (`design::run_design`).
            JobKind::Design => Err(Failure::Permanent("a design job has no run".into())),
        }
    })
}
