//! Process-local counters for `GET /metrics`. Queue depth and jobs by state
//! are read from the database at scrape time (they survive restarts); what
//! only this process sees (bytes received, job durations, the claim's and
//! the run store's latency) is counted here.

use std::fmt::Write as _;
use std::sync::Mutex;

/// Upper bounds of the job-duration histogram, seconds.
const DURATION_BUCKETS_S: [f64; 11] = [
    0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0, 1800.0,
];

/// Upper bounds of the run-store latency histogram, seconds: a local
/// rename takes microseconds, an object store's round trip milliseconds,
/// a run's multipart upload or download seconds to minutes.
const STORE_BUCKETS_S: [f64; 12] = [
    0.001, 0.005, 0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 10.0, 30.0, 60.0, 300.0,
];

/// Upper bounds of the claim-latency histogram, seconds: one transaction
/// on the queue, sub-millisecond on an idle SQLite file, milliseconds on a
/// PostgreSQL across a network, longer when writers queue for the lock.
const CLAIM_BUCKETS_S: [f64; 12] = [
    0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 5.0,
];

/// Bucket counts, sum and count of one histogram series.
type Series<const N: usize> = ([u64; N], f64, u64);

fn observe<const N: usize>(series: &mut Series<N>, bounds: &[f64; N], seconds: f64) {
    let (buckets, sum, count) = series;
    for (b, le) in buckets.iter_mut().zip(bounds) {
        if seconds <= *le {
            *b += 1;
        }
    }
    *sum += seconds;
    *count += 1;
}

#[derive(Debug, Default)]
struct Inner {
    upload_bytes: u64,
    uploads: [u64; 3],
    /// Per outcome (succeeded, failed, cancelled): bucket counts, sum, count.
    durations: [Series<{ DURATION_BUCKETS_S.len() }>; 3],
    /// Writes of a finished job's product refused by a full disk (each
    /// retried).
    storage_full_retries: u64,
    /// Per run-store operation (put, get, delete, list).
    store_ops: [Series<{ STORE_BUCKETS_S.len() }>; 4],
    /// Per claim outcome (claimed, empty, error).
    claims: [Series<{ CLAIM_BUCKETS_S.len() }>; 3],
}

/// How an upload ended.
#[derive(Clone, Copy, Debug)]
pub enum UploadOutcome {
    Accepted = 0,
    Duplicate = 1,
    Refused = 2,
}

/// An operation on the run store, for its latency histogram.
#[derive(Clone, Copy, Debug)]
pub enum StoreOp {
    /// A run's bytes made durable in the store (the local commit, or the
    /// upload of an object).
    Put = 0,
    /// A run's bytes fetched for a reader (object stores only: a local
    /// file is read in place).
    Get = 1,
    Delete = 2,
    /// A listing for the sweep.
    List = 3,
}

/// What a worker's claim found, for the claim-latency histogram.
#[derive(Clone, Copy, Debug)]
pub enum ClaimOutcome {
    /// A job was claimed.
    Claimed = 0,
    /// Nothing was claimable.
    Empty = 1,
    /// The database refused or could not be reached.
    Error = 2,
}

/// How an attempt at a job ended, for the duration histogram.
#[derive(Clone, Copy, Debug)]
pub enum JobOutcome {
    Succeeded = 0,
    Failed = 1,
    Cancelled = 2,
}

#[derive(Debug, Default)]
pub struct Metrics {
    inner: Mutex<Inner>,
}

impl Metrics {
    pub fn add_upload_bytes(&self, n: u64) {
        self.inner.lock().expect("metrics lock").upload_bytes += n;
    }

    pub fn upload(&self, outcome: UploadOutcome) {
        self.inner.lock().expect("metrics lock").uploads[outcome as usize] += 1;
    }

    pub fn storage_full_retry(&self) {
        self.inner
            .lock()
            .expect("metrics lock")
            .storage_full_retries += 1;
    }

    pub fn job_finished(&self, outcome: JobOutcome, seconds: f64) {
        let mut inner = self.inner.lock().expect("metrics lock");
        observe(
            &mut inner.durations[outcome as usize],
            &DURATION_BUCKETS_S,
            seconds,
        );
    }

    /// One run-store operation took `seconds` (successful or not).
    pub fn store_op(&self, op: StoreOp, seconds: f64) {
        let mut inner = self.inner.lock().expect("metrics lock");
        observe(&mut inner.store_ops[op as usize], &STORE_BUCKETS_S, seconds);
    }

    /// One claim transaction took `seconds`.
    pub fn claim(&self, outcome: ClaimOutcome, seconds: f64) {
        let mut inner = self.inner.lock().expect("metrics lock");
        observe(
            &mut inner.claims[outcome as usize],
            &CLAIM_BUCKETS_S,
            seconds,
        );
    }

    /// The Prometheus text exposition (format 0.0.4), with the database's
    /// job counts: those queued, and each state's by its name.
    pub fn render<'a>(
        &self,
        queued: i64,
        jobs_by_state: impl Iterator<Item = (&'a str, i64)>,
    ) -> String {
        let inner = self.inner.lock().expect("metrics lock");
        let mut s = String::new();
        let _ = writeln!(s, "# HELP sinscal_queue_depth Jobs waiting for a worker.");
        let _ = writeln!(s, "# TYPE sinscal_queue_depth gauge");
        let _ = writeln!(s, "sinscal_queue_depth {queued}");
        let _ = writeln!(s, "# HELP sinscal_jobs Jobs by state.");
        let _ = writeln!(s, "# TYPE sinscal_jobs gauge");
        for (state, n) in jobs_by_state {
            let _ = writeln!(s, "sinscal_jobs{{state=\"{state}\"}} {n}");
        }
        let _ = writeln!(
            s,
            "# HELP sinscal_upload_bytes_total Bytes of run data received."
        );
        let _ = writeln!(s, "# TYPE sinscal_upload_bytes_total counter");
        let _ = writeln!(s, "sinscal_upload_bytes_total {}", inner.upload_bytes);
        let _ = writeln!(s, "# HELP sinscal_uploads_total Uploads by outcome.");
        let _ = writeln!(s, "# TYPE sinscal_uploads_total counter");
        for (name, n) in ["accepted", "duplicate", "refused"]
            .iter()
            .zip(inner.uploads)
        {
            let _ = writeln!(s, "sinscal_uploads_total{{outcome=\"{name}\"}} {n}");
        }
        let _ = writeln!(
            s,
            "# HELP sinscal_job_duration_seconds Wall time of job attempts."
        );
        let _ = writeln!(s, "# TYPE sinscal_job_duration_seconds histogram");
        for (name, series) in ["succeeded", "failed", "cancelled"]
            .iter()
            .zip(&inner.durations)
        {
            let label = format!("outcome=\"{name}\"");
            histogram(
                &mut s,
                "sinscal_job_duration_seconds",
                &label,
                &DURATION_BUCKETS_S,
                series,
            );
        }
        let _ = writeln!(
            s,
            "# HELP sinscal_run_store_seconds Latency of run-store operations by kind."
        );
        let _ = writeln!(s, "# TYPE sinscal_run_store_seconds histogram");
        for (name, series) in ["put", "get", "delete", "list"]
            .iter()
            .zip(&inner.store_ops)
        {
            let label = format!("op=\"{name}\"");
            histogram(
                &mut s,
                "sinscal_run_store_seconds",
                &label,
                &STORE_BUCKETS_S,
                series,
            );
        }
        let _ = writeln!(
            s,
            "# HELP sinscal_claim_seconds Latency of this process's claims on the job queue, by what they found."
        );
        let _ = writeln!(s, "# TYPE sinscal_claim_seconds histogram");
        for (name, series) in ["claimed", "empty", "error"].iter().zip(&inner.claims) {
            let label = format!("outcome=\"{name}\"");
            histogram(
                &mut s,
                "sinscal_claim_seconds",
                &label,
                &CLAIM_BUCKETS_S,
                series,
            );
        }
        let _ = writeln!(
            s,
            "# HELP sinscal_storage_full_retries_total Result writes refused by a full disk, retried."
        );
        let _ = writeln!(s, "# TYPE sinscal_storage_full_retries_total counter");
        let _ = writeln!(
            s,
            "sinscal_storage_full_retries_total {}",
            inner.storage_full_retries
        );
        s
    }
}

/// One labelled series of a histogram in the text exposition.
fn histogram<const N: usize>(
    s: &mut String,
    name: &str,
    label: &str,
    bounds: &[f64; N],
    (buckets, sum, count): &Series<N>,
) {
    for (le, b) in bounds.iter().zip(buckets) {
        let _ = writeln!(s, "{name}_bucket{{{label},le=\"{le}\"}} {b}");
    }
    let _ = writeln!(s, "{name}_bucket{{{label},le=\"+Inf\"}} {count}");
    let _ = writeln!(s, "{name}_sum{{{label}}} {sum}");
    let _ = writeln!(s, "{name}_count{{{label}}} {count}");
}
