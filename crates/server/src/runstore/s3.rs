//! The object-store backend: runs as objects at `<prefix>/<blob_path>` in
//! an S3-compatible bucket (`object_store`'s client), endpoint, region and
//! credentials from the `AWS_*` environment variables (as
//! `AmazonS3Builder::from_env` reads them).

use std::collections::HashSet;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use futures_util::StreamExt;
use object_store::aws::{AmazonS3, AmazonS3Builder, AmazonS3ConfigKey};
use object_store::path::Path as Key;
use object_store::{
    BackoffConfig, ClientOptions, ObjectStore, PutPayload, RetryConfig, WriteMultipart,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

use super::keys;
use super::{RunStoreError, S3Location};
use crate::metrics::{Metrics, StoreOp};

/// Size of a multipart upload's parts: S3 wants at least 5 MiB but the
/// last, and allows 10 000 parts, so 8 MiB covers runs up to 78 GiB while
/// an upload holds only a few parts in memory.
const PART_BYTES: usize = 8 << 20;
/// Parts of one upload in flight at once (memory: this many parts plus the
/// one being filled).
const PARTS_IN_FLIGHT: usize = 2;
/// How much of the temp file one read takes.
const READ_BYTES: usize = 1 << 20;

/// A bucket and prefix, and the client that reaches them.
#[derive(Debug)]
pub(super) struct S3Store {
    client: AmazonS3,
    location: S3Location,
    /// The endpoint (or AWS with its region), for messages.
    endpoint: String,
    metrics: Arc<Metrics>,
}

/// Which request failed, for the message.
#[derive(Clone, Copy)]
enum Request {
    Put,
    Get,
    Delete,
    List,
}

impl S3Store {
    /// Builds the client from the environment and `location.options`; no
    /// request is sent (see [`S3Store::probe`]).
    pub(super) fn connect(
        location: &S3Location,
        metrics: Arc<Metrics>,
    ) -> Result<S3Store, RunStoreError> {
        // Bounded retries: a server that cannot reach its store says so
        // within seconds (at start, in /readyz, to an upload) rather than
        // after the client's default three minutes.
        let retry = RetryConfig {
            backoff: BackoffConfig::default(),
            max_retries: 4,
            retry_timeout: Duration::from_secs(30),
        };
        let options = ClientOptions::new()
            .with_connect_timeout(Duration::from_secs(5))
            // One part of PART_BYTES or a streamed read must fit in it.
            .with_timeout(Duration::from_secs(120));
        // The client options first: setting them replaces any given
        // before (AWS_ALLOW_HTTP among them). Then the `AWS_*` variables,
        // read as `AmazonS3Builder::from_env` reads them, then the options.
        let mut builder = AmazonS3Builder::new()
            .with_retry(retry)
            .with_client_options(options)
            .with_bucket_name(&location.bucket);
        for (key, value) in std::env::vars_os() {
            if let (Some(key), Some(value)) = (key.to_str(), value.to_str()) {
                if let Some(key) = key
                    .starts_with("AWS_")
                    .then(|| key.to_ascii_lowercase().parse::<AmazonS3ConfigKey>().ok())
                    .flatten()
                {
                    builder = builder.with_config(key, value);
                }
            }
        }
        for (key, value) in &location.options {
            let key: AmazonS3ConfigKey = key.parse().map_err(|e| RunStoreError::Remote {
                store: location.to_string(),
                what: "configuring the client".into(),
                reason: format!("unknown setting {key:?}: {e}"),
            })?;
            builder = builder.with_config(key, value);
        }
        let endpoint = match builder.get_config_value(&AmazonS3ConfigKey::Endpoint) {
            Some(url) => url,
            None => format!(
                "AWS, region {}",
                builder
                    .get_config_value(&AmazonS3ConfigKey::Region)
                    .unwrap_or_else(|| "us-east-1".into())
            ),
        };
        let store = format!("{location} ({endpoint})");
        let client = builder.build().map_err(|e| RunStoreError::Remote {
            store,
            what: "configuring the client".into(),
            reason: e.to_string(),
        })?;
        Ok(S3Store {
            client,
            location: location.clone(),
            endpoint,
            metrics,
        })
    }

    pub(super) fn describe(&self) -> String {
        format!("{} ({})", self.location, self.endpoint)
    }

    pub(super) fn sweep_every(&self) -> Duration {
        self.location.sweep_every
    }

    fn key(&self, blob_path: &str) -> Key {
        Key::from(keys::object_key(&self.location.prefix, blob_path))
    }

    fn error(&self, request: Request, what: String, e: &object_store::Error) -> RunStoreError {
        RunStoreError::Remote {
            store: self.describe(),
            what,
            reason: reason(request, e),
        }
    }

    fn timed(&self, op: StoreOp, started: Instant) {
        self.metrics.store_op(op, started.elapsed().as_secs_f64());
    }

    /// Puts a small object, reads it back and deletes it: the bucket
    /// exists and these credentials may write, read and delete in it. The
    /// probe's key is in the run area, so one a crash leaves is swept.
    pub(super) async fn probe(&self) -> Result<(), RunStoreError> {
        let blob = format!("{}/probe/{}", crate::runfiles::RUNS, uuid::Uuid::new_v4());
        let key = self.key(&blob);
        let body: &'static [u8] = b"sinscal readiness probe";
        self.client
            .put(&key, PutPayload::from(body))
            .await
            .map_err(|e| self.error(Request::Put, format!("writing a probe object {key}"), &e))?;
        let read = async {
            let got = self.client.get(&key).await?.bytes().await?;
            Ok::<_, object_store::Error>(got)
        }
        .await;
        let deleted = self.client.delete(&key).await;
        let got =
            read.map_err(|e| self.error(Request::Get, format!("reading the probe {key}"), &e))?;
        if got.as_ref() != body {
            return Err(RunStoreError::Remote {
                store: self.describe(),
                what: format!("reading the probe {key}"),
                reason: "the object read back differs from the one written".into(),
            });
        }
        deleted.map_err(|e| self.error(Request::Delete, format!("deleting the probe {key}"), &e))
    }

    /// Uploads `file` as the object of `blob_path`: one request for a run
    /// up to a part's size, else a multipart upload streamed from the file
    /// (never more than a few parts in memory). The object exists only
    /// once complete; a failed multipart upload is aborted.
    pub(super) async fn put_file(&self, file: &Path, blob_path: &str) -> Result<(), RunStoreError> {
        let key = self.key(blob_path);
        let what = || format!("uploading {key}");
        let io_err = |e| RunStoreError::io(format!("reading {} for upload", file.display()))(e);
        let mut f = tokio::fs::File::open(file).await.map_err(io_err)?;
        let size = f.metadata().await.map_err(io_err)?.len();
        if size <= PART_BYTES as u64 {
            let mut bytes = Vec::with_capacity(size as usize);
            f.read_to_end(&mut bytes).await.map_err(io_err)?;
            self.client
                .put(&key, PutPayload::from(bytes))
                .await
                .map_err(|e| self.error(Request::Put, what(), &e))?;
            return Ok(());
        }
        let upload = self
            .client
            .put_multipart(&key)
            .await
            .map_err(|e| self.error(Request::Put, what(), &e))?;
        let mut writer = WriteMultipart::new_with_chunk_size(upload, PART_BYTES);
        let mut buf = vec![0u8; READ_BYTES];
        let streamed: Result<(), RunStoreError> = async {
            loop {
                let n = f.read(&mut buf).await.map_err(io_err)?;
                if n == 0 {
                    return Ok(());
                }
                writer
                    .wait_for_capacity(PARTS_IN_FLIGHT)
                    .await
                    .map_err(|e| self.error(Request::Put, what(), &e))?;
                writer.write(&buf[..n]);
            }
        }
        .await;
        if let Err(e) = streamed {
            // Parts already sent would otherwise be kept (and billed) by
            // the store until a lifecycle rule removes them.
            let _ = writer.abort().await;
            return Err(e);
        }
        writer
            .finish()
            .await
            .map_err(|e| self.error(Request::Put, what(), &e))?;
        Ok(())
    }

    /// Streams the object of `blob_path` into `dest` (a new file). A
    /// partial file is the caller's to remove.
    pub(super) async fn get_to_file(
        &self,
        blob_path: &str,
        dest: &Path,
    ) -> Result<(), RunStoreError> {
        let started = Instant::now();
        let key = self.key(blob_path);
        let what = || format!("downloading {key}");
        let io_err = |e| RunStoreError::io(format!("writing {}", dest.display()))(e);
        let fetched: Result<(), RunStoreError> = async {
            let got = self
                .client
                .get(&key)
                .await
                .map_err(|e| self.error(Request::Get, what(), &e))?;
            let mut out = tokio::fs::File::create(dest).await.map_err(io_err)?;
            let mut stream = got.into_stream();
            while let Some(chunk) = stream.next().await {
                let chunk = chunk.map_err(|e| self.error(Request::Get, what(), &e))?;
                out.write_all(&chunk).await.map_err(io_err)?;
            }
            // No fsync: a scratch copy that a crash loses is fetched again.
            out.flush().await.map_err(io_err)
        }
        .await;
        self.timed(StoreOp::Get, started);
        fetched
    }

    /// Deletes the object of `blob_path` (one already gone is no error:
    /// S3 answers a delete of a missing key with success).
    pub(super) async fn delete(&self, blob_path: &str) -> Result<(), RunStoreError> {
        let started = Instant::now();
        let key = self.key(blob_path);
        let deleted = self.client.delete(&key).await;
        self.timed(StoreOp::Delete, started);
        deleted.map_err(|e| self.error(Request::Delete, format!("deleting {key}"), &e))
    }

    /// Lists the run area and deletes each object no row in `known` names
    /// that is older than the grace period; the number deleted. A failed
    /// delete is logged and left to the next sweep.
    pub(super) async fn sweep(&self, known: &HashSet<String>) -> Result<usize, RunStoreError> {
        let prefix = Key::from(keys::runs_prefix(&self.location.prefix));
        let started = Instant::now();
        let mut listing = self.client.list(Some(&prefix));
        let now = chrono::Utc::now();
        let mut orphans = Vec::new();
        while let Some(meta) = listing.next().await {
            let meta =
                meta.map_err(|e| self.error(Request::List, format!("listing {prefix}"), &e))?;
            let Some(blob) = keys::blob_path_of(&self.location.prefix, meta.location.as_ref())
            else {
                continue;
            };
            if keys::is_orphan(
                blob,
                meta.last_modified,
                known,
                now,
                self.location.orphan_grace,
            ) {
                orphans.push(blob.to_string());
            }
        }
        self.timed(StoreOp::List, started);
        let mut deleted = 0;
        for blob in orphans {
            match self.delete(&blob).await {
                Ok(()) => deleted += 1,
                Err(e) => tracing::warn!(error = %e, "an orphan object stays until the next sweep"),
            }
        }
        Ok(deleted)
    }
}

/// An object store error in words: what the status means for this kind of
/// request, or the innermost cause (a refused connection, a DNS failure)
/// rather than the whole chain.
fn reason(request: Request, e: &object_store::Error) -> String {
    use object_store::Error as E;
    match e {
        E::NotFound { .. } => match request {
            // A put or a listing is refused 404 only for the bucket.
            Request::Put | Request::List => "the bucket does not exist (404)".into(),
            Request::Get | Request::Delete => "no such object (404)".into(),
        },
        E::PermissionDenied { .. } | E::Unauthenticated { .. } => {
            "access refused (401/403): check the credentials (AWS_ACCESS_KEY_ID, \
             AWS_SECRET_ACCESS_KEY) and the bucket's policy"
                .into()
        }
        other => {
            let mut root: &dyn std::error::Error = other;
            while let Some(next) = root.source() {
                root = next;
            }
            let root = root.to_string();
            if root.contains("onnection refused") || root.contains("dns error") {
                format!("the endpoint cannot be reached: {root}")
            } else {
                format!("{root} [{other}]")
            }
        }
    }
}
