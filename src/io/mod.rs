//! Run files: streaming readers and writers for the data (CSV, gzip CSV,
//! f64le) and the JSON documents beside them (SPEC §5).

pub mod data;
pub mod meta;
pub mod run;

pub use meta::{RunMetadata, Truth};
