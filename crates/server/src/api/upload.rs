//! `POST /units/{serial}/runs`: a run streamed to disk while it is hashed
//! and validated, acknowledged only once it is durable.
//!
//! The body never sits in memory: chunks go through a bounded channel to a
//! blocking thread that writes them to a local temp file, hashes
//! them and feeds them to [`RecordReader`], which checks every record. On
//! any refusal the temp file is removed. On success the file is committed
//! (made whole in the run store, see `crate::runstore`), then the run and
//! job rows are written in one transaction, then 202.

use std::io::{self, BufWriter, Read, Write};

use axum::body::Bytes;
use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{FromRequest, Multipart, Path, Query, Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::Response;
use bytes::Buf;
use futures_util::{Stream, StreamExt, TryStreamExt};
use serde::Deserialize;
use sha2::{Digest, Sha256};

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::upload_guard::{find_cause, paced, Budgeted, CpuBudget, CpuBudgetExceeded, Stalled};
use super::upload_store::{check_span, store_run, Ingested, StoredRun};
pub use super::upload_store::{queue_full, UploadAnswer};
use super::{refuse_while_stopping, AppState};
use crate::metrics::UploadOutcome;
use sinscal_core::io::data::{CountsConversion, DataError, DataFormat, ReadLimits, RecordReader};
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::UnitSerial;

/// Header carrying the metadata JSON of a raw (non-multipart) upload.
pub const METADATA_HEADER: &str = "x-sinscal-metadata";
/// Largest metadata document accepted.
const MAX_METADATA_BYTES: usize = 256 * 1024;
/// After the data is refused, read at most this much more of the body so
/// the client sees the answer rather than a reset connection; a hostile
/// client cannot make the server read its whole body. Draining costs no
/// decompression, only the network, and is paced like the body; 16 MiB
/// covers a refused 10 MB upload whole.
const MAX_DRAIN_BYTES: u64 = 16 << 20;

#[derive(Debug, Deserialize)]
pub struct UploadQuery {
    metadata: Option<String>,
}

#[derive(Debug, thiserror::Error)]
enum SinkError {
    #[error(transparent)]
    Data(#[from] DataError),
    #[error("writing the upload: {0}")]
    Io(#[from] io::Error),
}

impl From<SinkError> for ApiError {
    fn from(e: SinkError) -> Self {
        if let Some(c) = find_cause::<CpuBudgetExceeded>(&e) {
            return ApiError::PayloadTooLarge(c.to_string());
        }
        match e {
            SinkError::Data(d) => ApiError::InvalidData(d),
            SinkError::Io(e) => ApiError::from(e),
        }
    }
}

/// The part of an upload form that was at fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UploadPart {
    /// The run's metadata (`run.json`).
    Metadata,
    /// The run's data file.
    Data,
}

impl UploadPart {
    /// `error`, blamed on this part.
    fn blame(self, error: ApiError) -> RefusedUpload {
        RefusedUpload {
            part: Some(self),
            error,
        }
    }
}

/// A refused upload: the API's answer and, when one part of the form was
/// at fault, which (the upload page names it).
#[derive(Debug)]
pub struct RefusedUpload {
    pub part: Option<UploadPart>,
    pub error: ApiError,
}

/// A refusal of the upload as a whole (the server's state, the form's
/// shape, a run already stored).
impl From<ApiError> for RefusedUpload {
    fn from(error: ApiError) -> Self {
        RefusedUpload { part: None, error }
    }
}

/// The reading end of the body channel: every chunk read is first written
/// to the temp file and hashed, so what is validated is what is stored.
struct Tee {
    rx: tokio::sync::mpsc::Receiver<Bytes>,
    current: Bytes,
    file: BufWriter<std::fs::File>,
    hasher: Sha256,
    written: u64,
    /// A failure of our disk, kept apart so that it is not reported to the
    /// client as a fault of its data.
    write_error: Option<io::Error>,
    /// The validator pulls every chunk through here: its CPU is charged.
    budget: CpuBudget,
}

impl Tee {
    fn next_chunk(&mut self) -> io::Result<bool> {
        self.budget.check()?;
        match self.rx.blocking_recv() {
            Some(chunk) => {
                self.hasher.update(&chunk);
                self.written += chunk.len() as u64;
                if let Err(e) = self.file.write_all(&chunk) {
                    let msg = e.to_string();
                    self.write_error = Some(e);
                    return Err(io::Error::other(msg));
                }
                self.current = chunk;
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

impl Read for Tee {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        while self.current.is_empty() {
            if !self.next_chunk()? {
                return Ok(0);
            }
        }
        let n = buf.len().min(self.current.len());
        buf[..n].copy_from_slice(&self.current[..n]);
        self.current.advance(n);
        Ok(n)
    }
}

/// sha256 (hex), bytes written, and (records, gzip) when validated.
type Sunk = (String, u64, Option<(u64, bool)>);

/// The blocking half of an upload: write, hash, and validate if `check`
/// says how.
fn sink(
    rx: tokio::sync::mpsc::Receiver<Bytes>,
    file: std::fs::File,
    check: Option<DataCheck>,
    max_cpu: std::time::Duration,
) -> Result<Sunk, SinkError> {
    let mut tee = Tee {
        budget: CpuBudget::start(max_cpu),
        rx,
        current: Bytes::new(),
        file: BufWriter::with_capacity(1 << 20, file),
        hasher: Sha256::new(),
        written: 0,
        write_error: None,
    };
    let checked = match check {
        Some(check) => {
            let outcome = count_records(&mut tee, &check);
            if let Some(e) = tee.write_error.take() {
                return Err(SinkError::Io(e));
            }
            Some(outcome?)
        }
        None => None,
    };
    // Anything the reader did not consume (nothing for a valid file, whose
    // reader reads to the end) is still part of the stored bytes. (The
    // fsync is the commit's, see `crate::runfiles`.)
    while tee.next_chunk()? {}
    tee.file.into_inner().map_err(|e| e.into_error())?;
    Ok((hex::encode(tee.hasher.finalize()), tee.written, checked))
}

/// How an upload's data is read to check it: as its metadata describes
/// it, within the server's limits.
struct DataCheck {
    format: DataFormat,
    sample_rate_hz: f64,
    limits: ReadLimits,
    temperature_column: bool,
    counts: Option<CountsConversion>,
}

impl DataCheck {
    fn of(meta: &RunMetadata, limits: ReadLimits) -> Self {
        DataCheck {
            format: meta.format,
            sample_rate_hz: meta.sample_rate_hz,
            limits,
            temperature_column: meta.temperature_column,
            counts: meta.counts,
        }
    }
}

fn count_records(reader: impl Read, check: &DataCheck) -> Result<(u64, bool), DataError> {
    let mut records = RecordReader::new(reader, check.format, check.sample_rate_hz, check.limits)?
        .with_temperature_column(check.temperature_column)
        .with_counts(check.counts);
    let mut n = 0;
    for r in records.by_ref() {
        r?;
        n += 1;
    }
    Ok((n, records.is_gzip()))
}

fn read_limits(st: &AppState) -> ReadLimits {
    ReadLimits {
        max_decompressed_bytes: Some(st.config.max_decompressed_bytes),
        max_skipped_lines: Some(st.config.max_comment_lines),
        max_expansion_ratio: Some(st.config.max_expansion_ratio),
        ..ReadLimits::default()
    }
}

/// Streams a body into a temp file, validating it against `meta` if given.
async fn ingest<S>(
    st: &AppState,
    mut body: S,
    meta: Option<&RunMetadata>,
) -> Result<Ingested, ApiError>
where
    S: Stream<Item = Result<Bytes, ApiError>> + Unpin,
{
    let (pending, file) = st.run_store.create_temp()?;
    let (tx, rx) = tokio::sync::mpsc::channel::<Bytes>(16);
    let check = meta.map(|m| DataCheck::of(m, read_limits(st)));
    let max_cpu = st.config.upload_max_cpu;
    let task = tokio::task::spawn_blocking(move || sink(rx, file, check, max_cpu));
    let mut received = 0u64;
    let mut drained: Option<u64> = None;
    let mut body_error = None;
    while let Some(chunk) = body.next().await {
        let chunk = match chunk {
            Ok(c) => c,
            Err(e) => {
                body_error = Some(e);
                break;
            }
        };
        received += chunk.len() as u64;
        match &mut drained {
            None => {
                if tx.send(chunk).await.is_err() {
                    // The validator refused the data; its error is the answer.
                    drained = Some(0);
                }
            }
            Some(d) => {
                *d += chunk.len() as u64;
                if *d > MAX_DRAIN_BYTES {
                    break;
                }
            }
        }
    }
    drop(tx);
    st.metrics.add_upload_bytes(received);
    let sunk = task
        .await
        .map_err(|e| ApiError::Internal(format!("upload task: {e}")))?;
    if let Some(e) = body_error {
        return Err(e);
    }
    let (sha256, size, checked) = sunk?;
    Ok(Ingested {
        file: pending,
        sha256,
        size,
        checked,
    })
}

/// The metadata of an upload, which must name the unit of the path when
/// there is one (`serial`).
fn parse_metadata(text: &[u8], serial: Option<&str>) -> Result<RunMetadata, ApiError> {
    let meta =
        RunMetadata::from_json(text).map_err(|e| ApiError::InvalidMetadata(e.to_string()))?;
    if let Some(serial) = serial.filter(|s| *s != meta.unit_serial) {
        return Err(ApiError::InvalidMetadata(format!(
            "metadata unit_serial {:?} differs from the unit in the path {serial:?}",
            meta.unit_serial
        )));
    }
    meta.recorded_at_ms().map_err(ApiError::InvalidMetadata)?;
    Ok(meta)
}

fn body_error(e: axum::Error, limit: u64) -> ApiError {
    if let Some(s) = find_cause::<Stalled>(&e) {
        return ApiError::RequestTimeout(s.to_string());
    }
    if find_cause::<http_body_util::LengthLimitError>(&e).is_some() {
        return ApiError::PayloadTooLarge(format!(
            "the request body exceeds the limit of {limit} bytes"
        ));
    }
    ApiError::BadRequest(format!("reading the request body failed: {e}"))
}

fn multipart_error(e: axum::extract::multipart::MultipartError) -> ApiError {
    if let Some(s) = find_cause::<Stalled>(&e) {
        return ApiError::RequestTimeout(s.to_string());
    }
    if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
        ApiError::PayloadTooLarge(e.body_text())
    } else {
        ApiError::BadRequest(e.body_text())
    }
}

/// Refuses an upload while the data folder's filesystem is below its
/// free-space floor, before a byte of the body is read.
fn check_free_space(st: &AppState) -> Result<(), ApiError> {
    match st.run_store.available_bytes() {
        Ok(free) if free < st.config.min_free_bytes => {
            tracing::warn!(
                free,
                floor = st.config.min_free_bytes,
                "upload refused: storage below its free-space floor"
            );
            Err(ApiError::storage_full())
        }
        Ok(_) => Ok(()),
        Err(e) => Err(ApiError::from(e)),
    }
}

pub async fn upload(
    State(st): State<AppState>,
    auth: Caller<roles::Upload>,
    path: Result<Path<String>, PathRejection>,
    query: Result<Query<UploadQuery>, QueryRejection>,
    headers: HeaderMap,
    req: Request,
) -> Result<Response, ApiError> {
    let serial: UnitSerial = path?.0.parse().map_err(ApiError::BadRequest)?;
    let Query(query) = query?;
    let _permit = admit(&st).await?;
    let multipart = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|ct| ct.to_ascii_lowercase().starts_with("multipart/form-data"));
    let limit = st.config.max_body_bytes;
    // A stalled or trickling body ends with an error, freeing the slot.
    let (parts, body) = req.into_parts();
    let req = Request::from_parts(
        parts,
        axum::body::Body::from_stream(paced(body, st.config.upload_pace)),
    );
    let outcome = if multipart {
        receive_multipart(&st, Some(serial.as_str()), req)
            .await
            .map_err(|r| r.error)
    } else {
        let text = match (headers.get(METADATA_HEADER), &query.metadata) {
            (Some(h), _) => h.as_bytes().to_vec(),
            (None, Some(q)) => q.as_bytes().to_vec(),
            (None, None) => {
                return Err(ApiError::BadRequest(format!(
                    "no metadata: send multipart/form-data with `metadata` and `data` parts, or the \
                     metadata JSON in the {METADATA_HEADER} header or the `metadata` query parameter"
                )))
            }
        };
        match parse_metadata(&text, Some(serial.as_str())) {
            Ok(meta) => {
                let body = req
                    .into_body()
                    .into_data_stream()
                    .map_err(|e| body_error(e, limit));
                ingest(&st, body, Some(&meta)).await.map(|f| (meta, f))
            }
            Err(e) => Err(e),
        }
    };
    let (meta, ingested) = match outcome {
        Ok(ok) => ok,
        Err(e) => {
            st.metrics.upload(UploadOutcome::Refused);
            return Err(e);
        }
    };
    check_span(&st, &meta, &ingested)?;
    Ok(store_run(&st, &auth, meta, ingested).await?.answer())
}

/// What every upload passes before a byte of its body is read: the server
/// is not stopping, the queue and the disk have room, and an upload slot
/// is free (held by the returned permit).
async fn admit(st: &AppState) -> Result<tokio::sync::OwnedSemaphorePermit, ApiError> {
    refuse_while_stopping(st)?;
    // Checked before reading the body so a full queue or disk costs the
    // station nothing; checked again in the insert transaction.
    if st.store.queue_depth().await? >= st.config.max_queue {
        st.metrics.upload(UploadOutcome::Refused);
        return Err(queue_full());
    }
    if let Err(e) = check_free_space(st) {
        st.metrics.upload(UploadOutcome::Refused);
        return Err(e);
    }
    st.uploads
        .clone()
        .acquire_owned()
        .await
        .map_err(|_| ApiError::Internal("upload semaphore closed".into()))
}

/// An upload from the pages' form: multipart with a `metadata` part and a
/// `data` part, the unit named by the metadata. Everything else is the
/// API's upload: the same checks, limits, pacing and storage (the role
/// among them: only an uploader's [`Caller`] can be passed).
pub(crate) async fn upload_form(
    st: &AppState,
    auth: &Caller<roles::Upload>,
    req: Request,
) -> Result<StoredRun, RefusedUpload> {
    let _permit = admit(st).await?;
    let (parts, body) = req.into_parts();
    let req = Request::from_parts(
        parts,
        axum::body::Body::from_stream(paced(body, st.config.upload_pace)),
    );
    match receive_multipart(st, None, req).await {
        Ok((meta, ingested)) => {
            check_span(st, &meta, &ingested).map_err(|e| UploadPart::Data.blame(e))?;
            Ok(store_run(st, auth, meta, ingested).await?)
        }
        Err(e) => {
            st.metrics.upload(UploadOutcome::Refused);
            Err(e)
        }
    }
}

async fn receive_multipart(
    st: &AppState,
    serial: Option<&str>,
    req: Request,
) -> Result<(RunMetadata, Ingested), RefusedUpload> {
    use UploadPart::{Data, Metadata};
    let mut form = Multipart::from_request(req, st)
        .await
        .map_err(|e| ApiError::BadRequest(e.body_text()))?;
    let mut meta: Option<RunMetadata> = None;
    let mut data: Option<Ingested> = None;
    while let Some(mut field) = form.next_field().await.map_err(multipart_error)? {
        match field.name() {
            Some("metadata") if meta.is_none() => {
                let mut text = Vec::new();
                while let Some(chunk) = field
                    .chunk()
                    .await
                    .map_err(|e| Metadata.blame(multipart_error(e)))?
                {
                    text.extend_from_slice(&chunk);
                    if text.len() > MAX_METADATA_BYTES {
                        return Err(Metadata.blame(ApiError::PayloadTooLarge(format!(
                            "the metadata part exceeds {MAX_METADATA_BYTES} bytes"
                        ))));
                    }
                }
                meta = Some(parse_metadata(&text, serial).map_err(|e| Metadata.blame(e))?);
            }
            Some("data") if data.is_none() => {
                let ingested = ingest(st, field.map_err(multipart_error), meta.as_ref()).await;
                data = Some(ingested.map_err(|e| Data.blame(e))?);
            }
            Some(name @ ("metadata" | "data")) => {
                return Err(
                    ApiError::BadRequest(format!("the `{name}` part is given twice")).into(),
                )
            }
            other => {
                return Err(ApiError::BadRequest(format!(
                    "unexpected part {:?}: the form has a `metadata` part and a `data` part",
                    other.unwrap_or("")
                ))
                .into())
            }
        }
    }
    let meta = meta.ok_or_else(|| {
        Metadata.blame(ApiError::BadRequest(
            "the form has no `metadata` part".into(),
        ))
    })?;
    let mut data =
        data.ok_or_else(|| Data.blame(ApiError::BadRequest("the form has no `data` part".into())))?;
    if data.checked.is_none() {
        // The data came before the metadata: it was spooled unchecked and
        // is validated from the temp file now.
        let (path, check, max_cpu) = (
            data.file.path().to_path_buf(),
            DataCheck::of(&meta, read_limits(st)),
            st.config.upload_max_cpu,
        );
        let checked = tokio::task::spawn_blocking(move || {
            let file = std::fs::File::open(&path).map_err(SinkError::Io)?;
            let budgeted = Budgeted {
                inner: io::BufReader::new(file),
                budget: CpuBudget::start(max_cpu),
            };
            count_records(budgeted, &check).map_err(SinkError::Data)
        })
        .await
        .map_err(|e| ApiError::Internal(format!("validation task: {e}")))?
        .map_err(|e| Data.blame(e.into()))?;
        data.checked = Some(checked);
    }
    Ok((meta, data))
}
