//! The server's database, on SQLite (the embedded default) or PostgreSQL:
//! the pools, the migrations and every SQL statement of the project. Nothing outside this module writes SQL; the
//! public methods of [`Store`] are the one storage interface (the seam a
//! second database backend would implement).
//!
//! Files, by what they own (each a leaf or using only its siblings, never
//! this file):
//! - `error`: [`StoreError`] and which errors mean a full disk;
//! - `dialect`: where SQLite and PostgreSQL differ ([`Backend`]);
//! - `ids`: run and job ids as types ([`RunId`], [`JobId`]);
//! - `kinds`: the TEXT vocabularies as types ([`Role`], [`JobKind`],
//!   [`JobState`]);
//! - `hints`: queued-job notifications to other processes' workers
//!   ([`JobHints`], PostgreSQL);
//! - `db`: [`Store`] itself: pools, opening with migrations, the write
//!   transaction, the readiness probes;
//! - `tokens`: bearer tokens;
//! - `sessions`: the pages' browser sessions, each acting for a live token;
//! - `runs`: a run's row with its calibration job, reads, deletion;
//! - `jobs`: job rows: reads, counts, cancel, queueing a diagnosis,
//!   queueing a calibration again, adopting a model for a run;
//! - `versions`: a run's results over time: the current one superseded
//!   (kept) when the run is calibrated again, earlier ones read back;
//! - `queue`: what a worker does to the job it holds (claim, heartbeat,
//!   complete, fail, cancel, release), every write behind one fence;
//! - `designs`: design jobs (no run): queueing one with its request, its
//!   answer stored under the fence, both read back;
//! - `results`: results, diagnoses, units, history, repeatability;
//! - `spread`: the per-result value blob and its statistics;
//! - `verdicts`: each result's verdict (`accept::judge`) kept up to date
//!   in its row and the unit's (on any connection: a leaf but for
//!   `spread`, `error`);
//! - `noise_models`: the noise model held for a unit, which its runs'
//!   calibration claims carry;
//! - `products`: product types, their revisions, and the verdicts judged
//!   again when one changes;
//! - `certificates`: calibration certificates, one per approved result,
//!   numbered in the order they were issued.

mod certificates;
mod db;
mod designs;
mod dialect;
mod document;
mod error;
mod hints;
mod ids;
mod jobs;
mod kinds;
mod noise_models;
mod products;
mod queue;
mod results;
mod runs;
mod sessions;
mod spread;
mod tokens;
mod verdicts;
mod versions;

pub use certificates::{certificate_number, Approval, Approver, CertificateRow};
pub use db::{now_ms, DatabaseUrl, Store};
pub use designs::{DesignQueued, DesignRow};
pub use dialect::{Backend, JOBS_CHANNEL};
pub use document::Stored;
pub use error::{is_storage_full_io, StoreError};
pub use hints::JobHints;
pub use ids::{JobId, RunId};
pub use jobs::{Adoption, CalibrationRequeued, DiagnoseQueued, JobCounts, JobRow};
pub use kinds::{JobKind, JobState, Role};
pub use noise_models::HeldNoiseRow;
pub use products::{ProductTypeChange, ProductTypeRow};
pub use queue::{Claim, Fence, OnInadequate, RunClaim, Subject};
pub use results::{HistoryRow, SpreadRun, ThermalRow, UnitFilter, UnitSpread, UnitSummary};
pub use runs::{InsertOutcome, NewRun, Review, RunDeletion, RunFile, RunRow};
pub use spread::ParamSpread;
pub use tokens::TokenRow;
pub use verdicts::StoredVerdict;
pub use versions::ResultVersion;
