//! A design job: the scheme design of a stored request on a blocking
//! thread, with the job's own time limit (`JobSettings::design_time_limit`,
//! longer than a synchronous request's), its progress written as the
//! lease's heartbeat, and its answer stored under the job's fence.
//!
//! A design is deterministic: an invalid request or a time-out fails the
//! job for good, with the reason in words; only a lost thread is retried.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use futures_util::FutureExt as _;

use super::{panicked, JobEnd, JobError, JobRunner, StopReason};
use crate::store::Claim;
use sinscal_core::design::{design_watched, Design, DesignError, DesignSpec, Watch};

impl JobRunner {
    /// Runs a claimed design job to its end.
    pub(super) async fn run_design(
        &self,
        claim: &Claim,
        request: &str,
    ) -> Result<JobEnd, JobError> {
        let fence = &claim.fence;
        let limit = self.settings.design_time_limit.as_secs_f64();
        // Checked when it was queued; if it no longer parses, no retry helps.
        let spec = match serde_json::from_str::<DesignSpec>(request) {
            Ok(s) => s,
            Err(e) => {
                return self
                    .fail(claim, &format!("the stored request: {e}"), false)
                    .await
            }
        };
        let req = match spec.request(Some(limit)) {
            Ok(r) => r,
            Err(e) => return self.fail(claim, &e.to_string(), false).await,
        };
        let cancel = Arc::new(AtomicBool::new(false));
        let progress = Arc::new(Mutex::new((0.0_f64, String::from("starting"))));
        let task = {
            let (cancel, progress) = (cancel.clone(), progress.clone());
            tokio::task::spawn_blocking(move || {
                // Only the latest value is kept; the heartbeat writes it.
                let report = |fraction: f64, stage: &str| {
                    *progress.lock().expect("progress lock") =
                        (fraction.clamp(0.0, 1.0), stage.to_string());
                };
                design_watched(&req, &Watch::new(&report, &cancel))
            })
        };
        let (joined, reason) = self.watch(fence, task, &cancel, &progress).await;
        if reason == Some(StopReason::LeaseLost) {
            return Ok(JobEnd::LeaseLost);
        }
        match joined {
            Ok(Ok(design)) => self.store_design(claim, &design).await,
            Ok(Err(DesignError::Cancelled)) => self.stopped(fence, reason).await,
            Ok(Err(e)) => self.fail(claim, &e.to_string(), false).await,
            Err(join) => self.fail(claim, &panicked(&join), true).await,
        }
    }

    async fn store_design(&self, claim: &Claim, design: &Design) -> Result<JobEnd, JobError> {
        let json = match serde_json::to_string(design) {
            Ok(j) => j,
            Err(e) => {
                return self
                    .fail(claim, &format!("design to JSON: {e}"), false)
                    .await
            }
        };
        let fence = &claim.fence;
        let write = || self.store.complete_design_job(fence, &json).boxed();
        self.store_product(fence, &write).await
    }
}
