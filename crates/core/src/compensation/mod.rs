//! What a calibration delivers to the unit (CONTRACT §5a): the compensation
//! file a navigation computer loads — the 24 parameters as K_g, K_a, biases
//! and quadratic terms in SI, with σ, provenance and the convention stated
//! in the file — its JSON and CSV forms, and the streaming application of
//! the model's exact inversion to a run's records.
//!
//! - `file`: [`CompensationFile`] (from a result or bare parameters, JSON
//!   written and read back, validated);
//! - `table`: its CSV form;
//! - `convention`: the words the file states about its numbers;
//! - `thermal`: the file's thermal terms (SPEC §3a), from a run's in-run
//!   states or a unit's model across runs;
//! - `apply`: [`Compensated`], records in, compensated records out.

pub mod apply;
pub mod convention;
pub mod file;
mod layout;
pub mod table;
pub mod thermal;

pub use apply::Compensated;
pub use convention::Convention;
pub use file::{
    CompensationError, CompensationFile, Provenance, VerdictOverride, FORMAT_TAG, FORMAT_VERSION,
};

#[cfg(test)]
mod tests;
