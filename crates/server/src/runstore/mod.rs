//! Where stored runs' bytes are kept: the data folder's `runs/` (the
//! default, [`crate::runfiles`]) or an S3-compatible object store
//! (`--run-store s3://bucket/prefix`), behind one interface that upload,
//! deletion, the workers, the noise page, readiness and the sweeps use.
//!
//! Either way an upload is first spooled, hashed and validated in a local
//! temp file (`runs/tmp`), then [`RunStore::commit`] makes it whole in the
//! store, and only then are its rows written. So no row names bytes the
//! store does not hold whole; a crash in between leaves bytes no row names,
//! which the sweep removes: at start for the local folder (nothing else
//! writes it), and for an object store at start and every
//! [`SWEEP_EVERY`], only objects older than [`ORPHAN_GRACE`] (another
//! server may be between its put and its commit).
//!
//! Readers get a local file ([`RunStore::local_copy`]): the stored file
//! itself, or a download into `scratch/` removed when the copy is dropped.

pub mod keys;
mod local;
mod s3;
mod scratch;

use std::collections::HashSet;
use std::fmt;
use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::metrics::{Metrics, StoreOp};
use crate::runfiles::{Pending, RunFiles};

use self::s3::S3Store;

/// How long an object no row names is left alone before the sweep deletes
/// it. An upload puts its object and then commits its rows; another API
/// server sharing the bucket may be anywhere between the two when a sweep
/// lists, so only objects older than any plausible put-to-commit time are
/// orphans. An hour covers a multipart upload of a large run on a slow
/// link (an object's time is when its upload started) many times over.
pub const ORPHAN_GRACE: Duration = Duration::from_secs(3600);

/// How often a server sweeps an object store while it runs: crashes of
/// other servers leave orphans that no restart of this one would find.
pub const SWEEP_EVERY: Duration = Duration::from_secs(600);

/// The `--run-store` flag: where runs are kept.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum RunStoreSpec {
    /// `runs/` under the data folder.
    #[default]
    Local,
    /// An S3-compatible object store.
    S3(S3Location),
}

/// A bucket and key prefix (`s3://bucket/prefix`), with the sweep's timing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct S3Location {
    pub bucket: String,
    /// Without leading or trailing `/`; empty for the bucket's root.
    pub prefix: String,
    /// See [`ORPHAN_GRACE`].
    pub orphan_grace: Duration,
    /// See [`SWEEP_EVERY`].
    pub sweep_every: Duration,
    /// Settings applied over the `AWS_*` environment variables, as
    /// `(key, value)` in the object store's names (`aws_endpoint`,
    /// `aws_access_key_id`, `aws_allow_http`, …): how a test points a
    /// server at its own S3 server without changing the process's
    /// environment. Empty from the flag.
    pub options: Vec<(String, String)>,
}

impl S3Location {
    /// `s3://bucket/prefix` with the default timing and no options.
    pub fn new(bucket: &str, prefix: &str) -> S3Location {
        S3Location {
            bucket: bucket.to_string(),
            prefix: prefix.trim_matches('/').to_string(),
            orphan_grace: ORPHAN_GRACE,
            sweep_every: SWEEP_EVERY,
            options: Vec::new(),
        }
    }
}

impl fmt::Display for S3Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "s3://{}/{}", self.bucket, self.prefix)
    }
}

impl FromStr for RunStoreSpec {
    type Err = String;

    /// `local`, or `s3://bucket[/prefix]`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "local" {
            return Ok(RunStoreSpec::Local);
        }
        let rest = s.strip_prefix("s3://").ok_or_else(|| {
            format!("{s:?}: expected `local` or `s3://bucket/prefix` (an S3-compatible store)")
        })?;
        let (bucket, prefix) = rest.split_once('/').unwrap_or((rest, ""));
        let bucket_ok = (3..=63).contains(&bucket.len())
            && bucket
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'.');
        if !bucket_ok {
            return Err(format!(
                "{s:?}: {bucket:?} is not a bucket name (3 to 63 lower-case letters, digits, \
                 `-` and `.`)"
            ));
        }
        let location = S3Location::new(bucket, prefix);
        if !location.prefix.is_empty() {
            object_store::path::Path::parse(&location.prefix)
                .map_err(|e| format!("{s:?}: the key prefix is not a valid object path: {e}"))?;
        }
        Ok(RunStoreSpec::S3(location))
    }
}

/// A failure of the run store. The message names the store and what
/// failed, in words (an object store's raw error is summarised, not
/// dumped).
#[derive(Debug, thiserror::Error)]
pub enum RunStoreError {
    /// Local I/O: the data folder, a temp or scratch file, a local run file.
    #[error("{what}: {source}")]
    Io {
        what: String,
        #[source]
        source: io::Error,
    },
    /// An object store request or its setup.
    #[error("run store {store}: {what} failed: {reason}")]
    Remote {
        /// The location and endpoint.
        store: String,
        what: String,
        reason: String,
    },
}

impl RunStoreError {
    fn io(what: impl Into<String>) -> impl FnOnce(io::Error) -> RunStoreError {
        let what = what.into();
        move |source| RunStoreError::Io { what, source }
    }
}

/// What the start's sweep removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Swept {
    /// Partial uploads in `runs/tmp`.
    pub partial: usize,
    /// Stored bytes no row names (for an object store, older than its
    /// grace period).
    pub orphans: usize,
    /// Downloads for readers in `scratch/`.
    pub scratch: usize,
}

/// The run store of one server.
#[derive(Clone, Debug)]
pub struct RunStore {
    files: RunFiles,
    data_dir: PathBuf,
    remote: Option<Arc<S3Store>>,
    metrics: Arc<Metrics>,
}

/// A run's bytes in the store with no row naming them yet: deleted when
/// dropped, unless [`Stored::keep`] says its rows committed.
#[derive(Debug)]
pub struct Stored {
    inner: StoredInner,
}

#[derive(Debug)]
enum StoredInner {
    /// The local file (its guard removes it).
    Local(Pending),
    /// An object; `None` once kept or discarded.
    Remote(Option<(Arc<S3Store>, String)>),
}

impl Stored {
    /// The rows committed: the bytes stay.
    pub fn keep(self) {
        let mut this = self;
        match std::mem::replace(&mut this.inner, StoredInner::Remote(None)) {
            StoredInner::Local(pending) => pending.keep(),
            StoredInner::Remote(_) => {}
        }
    }

    /// The rows will not be written (a duplicate, a full queue): deletes
    /// the bytes now, rather than in the background as a drop does.
    pub async fn discard(self) {
        let mut this = self;
        if let StoredInner::Remote(Some((store, blob_path))) =
            std::mem::replace(&mut this.inner, StoredInner::Remote(None))
        {
            if let Err(e) = store.delete(&blob_path).await {
                tracing::warn!(blob_path, error = %e, "an unneeded object stays until the sweep");
            }
        }
    }
}

impl Drop for Stored {
    fn drop(&mut self) {
        // An early return (the rows failed to commit): delete the object in
        // the background; if that fails too, the sweep removes it later.
        if let StoredInner::Remote(Some((store, blob_path))) =
            std::mem::replace(&mut self.inner, StoredInner::Remote(None))
        {
            if let Ok(rt) = tokio::runtime::Handle::try_current() {
                rt.spawn(async move {
                    if let Err(e) = store.delete(&blob_path).await {
                        tracing::warn!(blob_path, error = %e, "an orphan object stays until the sweep");
                    }
                });
            }
        }
    }
}

/// A local file with a run's bytes for a reader: the stored file itself,
/// or a scratch download removed when this is dropped.
#[derive(Debug)]
pub struct LocalCopy {
    path: PathBuf,
    scratch: bool,
}

impl LocalCopy {
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for LocalCopy {
    fn drop(&mut self) {
        if self.scratch {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

impl RunStore {
    /// Creates the data folder's run and scratch areas and, for an object
    /// store, checks that the bucket takes a write, a read and a delete:
    /// a missing bucket, refused credentials or an unreachable endpoint
    /// fail here, named, rather than at the first upload.
    pub async fn open(
        spec: &RunStoreSpec,
        data_dir: &Path,
        metrics: Arc<Metrics>,
    ) -> Result<RunStore, RunStoreError> {
        let files = RunFiles::new(data_dir);
        files.create_dirs().map_err(RunStoreError::io(format!(
            "creating {}",
            data_dir.display()
        )))?;
        scratch::create_dir(data_dir)?;
        let remote = match spec {
            RunStoreSpec::Local => None,
            RunStoreSpec::S3(location) => {
                let store = S3Store::connect(location, metrics.clone())?;
                store.probe().await?;
                Some(Arc::new(store))
            }
        };
        Ok(RunStore {
            files,
            data_dir: data_dir.to_path_buf(),
            remote,
            metrics,
        })
    }

    /// Where runs are kept, for the start's log line.
    pub fn describe(&self) -> String {
        match &self.remote {
            None => format!("{}/runs", self.data_dir.display()),
            Some(s3) => s3.describe(),
        }
    }

    /// A new temp file for an upload, and its guard (always local).
    pub fn create_temp(&self) -> io::Result<(Pending, File)> {
        self.files.create_temp()
    }

    /// Free bytes where uploads are spooled (the data folder).
    pub fn available_bytes(&self) -> io::Result<u64> {
        self.files.available_bytes()
    }

    /// Makes an upload's temp file the run's stored bytes at `blob_path`
    /// (from [`RunFiles::blob_path`]), whole, before any row names it.
    pub async fn commit(&self, pending: Pending, blob_path: &str) -> Result<Stored, RunStoreError> {
        let started = Instant::now();
        let stored = match &self.remote {
            None => local::commit(&self.files, pending, blob_path).await,
            Some(s3) => {
                // The temp file goes when `pending` is dropped, after the
                // upload, whatever its outcome.
                s3.put_file(pending.path(), blob_path)
                    .await
                    .map(|()| Stored {
                        inner: StoredInner::Remote(Some((s3.clone(), blob_path.to_string()))),
                    })
            }
        };
        self.metrics
            .store_op(StoreOp::Put, started.elapsed().as_secs_f64());
        stored
    }

    /// Deletes a run's bytes once its rows are gone. Bytes already gone
    /// are not an error; a failure leaves them to the sweep.
    pub async fn remove(&self, blob_path: &str) -> Result<(), RunStoreError> {
        match &self.remote {
            None => {
                let started = Instant::now();
                let removed = local::remove(&self.files, blob_path).await;
                self.metrics
                    .store_op(StoreOp::Delete, started.elapsed().as_secs_f64());
                removed
            }
            Some(s3) => s3.delete(blob_path).await,
        }
    }

    /// A local file with the run's bytes, for a reader that streams it
    /// (several times, for the estimator).
    pub async fn local_copy(&self, blob_path: &str) -> Result<LocalCopy, RunStoreError> {
        match &self.remote {
            None => Ok(LocalCopy {
                path: self.files.path(blob_path),
                scratch: false,
            }),
            Some(s3) => {
                let copy = LocalCopy {
                    path: scratch::new_path(&self.data_dir, blob_path),
                    scratch: true,
                };
                s3.get_to_file(blob_path, copy.path()).await?;
                Ok(copy)
            }
        }
    }

    /// The start's sweep, before uploads and jobs run: partial uploads,
    /// scratch downloads, and stored bytes no row in `known` names (an
    /// object only once older than its grace period; a local file or
    /// partial upload once older than `local_grace`, which is zero for a
    /// process alone on its data folder).
    pub async fn sweep_at_start(
        &self,
        known: &HashSet<String>,
        local_grace: Duration,
    ) -> Result<Swept, RunStoreError> {
        let scratch = scratch::sweep(&self.data_dir)?;
        let (partial, orphans) = match &self.remote {
            None => local::sweep(&self.files, known, local_grace).await?,
            Some(s3) => {
                // Only the temp files: a `runs/` shard left from before
                // the object store was configured is not this store's.
                let partial = self
                    .files
                    .sweep_partial(local_grace)
                    .map_err(RunStoreError::io("sweeping runs/tmp"))?;
                (partial, s3.sweep(known).await?)
            }
        };
        Ok(Swept {
            partial,
            orphans,
            scratch,
        })
    }

    /// How often [`RunStore::sweep_objects`] should run while serving:
    /// only an object store, which other servers write too.
    pub fn sweep_every(&self) -> Option<Duration> {
        self.remote.as_ref().map(|s3| s3.sweep_every())
    }

    /// Deletes objects no row in `known` names and older than the grace
    /// period; the number deleted. Nothing for the local folder.
    pub async fn sweep_objects(&self, known: &HashSet<String>) -> Result<usize, RunStoreError> {
        match &self.remote {
            None => Ok(0),
            Some(s3) => s3.sweep(known).await,
        }
    }

    /// Why the store cannot take an upload to its end, if it cannot: the
    /// data folder below `min_free` bytes or not writable (uploads spool
    /// there either way), or the object store refusing a write, read or
    /// delete.
    pub async fn not_ready(&self, min_free: u64) -> Option<String> {
        let files = self.files.clone();
        let disk = tokio::task::spawn_blocking(move || -> Result<(), String> {
            let free = files
                .available_bytes()
                .map_err(|e| format!("data folder: {e}"))?;
            if free < min_free {
                return Err(format!(
                    "storage low: {free} bytes free in the data folder, below the floor of {min_free}"
                ));
            }
            files
                .probe_write()
                .map_err(|e| format!("data folder not writable: {e}"))
        })
        .await
        .unwrap_or_else(|e| Err(format!("probe task: {e}")));
        if let Err(why) = disk {
            return Some(why);
        }
        match &self.remote {
            None => None,
            Some(s3) => s3.probe().await.err().map(|e| e.to_string()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flag_reads_local_or_a_bucket_and_prefix_and_names_what_is_wrong() {
        assert_eq!("local".parse::<RunStoreSpec>(), Ok(RunStoreSpec::Local));
        let RunStoreSpec::S3(at) = "s3://sinscal-runs/fleet/a/".parse().unwrap() else {
            panic!("not an S3 location");
        };
        assert_eq!(
            (at.bucket.as_str(), at.prefix.as_str()),
            ("sinscal-runs", "fleet/a")
        );
        assert_eq!(at.orphan_grace, ORPHAN_GRACE);
        assert!(at.options.is_empty());
        assert_eq!(at.to_string(), "s3://sinscal-runs/fleet/a");
        let RunStoreSpec::S3(root) = "s3://sinscal-runs".parse().unwrap() else {
            panic!("not an S3 location");
        };
        assert_eq!(root.prefix, "");

        let err = |s: &str| s.parse::<RunStoreSpec>().unwrap_err();
        assert!(err("/srv/runs").contains("expected `local` or `s3://bucket/prefix`"));
        assert!(err("s3://Upper/x").contains("is not a bucket name"));
        assert!(err("s3://ab").contains("is not a bucket name"));
        assert!(err("s3://runs/a//b").contains("key prefix"));
    }
}
