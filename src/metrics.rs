//! Process-local counters for `GET /metrics`. Queue depth and jobs by state
//! are read from the database at scrape time (they survive restarts); what
//! only this process sees (bytes received, job durations) is counted here.

use std::fmt::Write as _;
use std::sync::Mutex;

/// Upper bounds of the job-duration histogram, seconds.
const DURATION_BUCKETS_S: [f64; 11] = [
    0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0, 1800.0,
];

#[derive(Debug, Default)]
struct Inner {
    upload_bytes: u64,
    uploads: [u64; 3],
    /// Per outcome (succeeded, failed, cancelled): bucket counts, sum, count.
    durations: [([u64; DURATION_BUCKETS_S.len()], f64, u64); 3],
    /// Writes of a finished job's product refused by a full disk (each
    /// retried).
    storage_full_retries: u64,
}

/// How an upload ended.
#[derive(Clone, Copy, Debug)]
pub enum UploadOutcome {
    Accepted = 0,
    Duplicate = 1,
    Refused = 2,
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
        let (buckets, sum, count) = &mut inner.durations[outcome as usize];
        for (b, le) in buckets.iter_mut().zip(DURATION_BUCKETS_S) {
            if seconds <= le {
                *b += 1;
            }
        }
        *sum += seconds;
        *count += 1;
    }

    /// The Prometheus text exposition (format 0.0.4), with the database's
    /// job counts.
    pub fn render(&self, job_counts: &std::collections::BTreeMap<String, i64>) -> String {
        let inner = self.inner.lock().expect("metrics lock");
        let mut s = String::new();
        let queued = job_counts.get("queued").copied().unwrap_or(0);
        let _ = writeln!(s, "# HELP sinscal_queue_depth Jobs waiting for a worker.");
        let _ = writeln!(s, "# TYPE sinscal_queue_depth gauge");
        let _ = writeln!(s, "sinscal_queue_depth {queued}");
        let _ = writeln!(s, "# HELP sinscal_jobs Jobs by state.");
        let _ = writeln!(s, "# TYPE sinscal_jobs gauge");
        for (state, n) in job_counts {
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
        for (name, (buckets, sum, count)) in ["succeeded", "failed", "cancelled"]
            .iter()
            .zip(&inner.durations)
        {
            for (le, b) in DURATION_BUCKETS_S.iter().zip(buckets) {
                let _ = writeln!(
                    s,
                    "sinscal_job_duration_seconds_bucket{{outcome=\"{name}\",le=\"{le}\"}} {b}"
                );
            }
            let _ = writeln!(
                s,
                "sinscal_job_duration_seconds_bucket{{outcome=\"{name}\",le=\"+Inf\"}} {count}"
            );
            let _ = writeln!(
                s,
                "sinscal_job_duration_seconds_sum{{outcome=\"{name}\"}} {sum}"
            );
            let _ = writeln!(
                s,
                "sinscal_job_duration_seconds_count{{outcome=\"{name}\"}} {count}"
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
