//! Run files: streaming readers and writers for the data (CSV, gzip CSV,
//! f64le) and the JSON documents beside them (SPEC §5), and logs of other
//! formats imported as runs (`psins`, `imu_tk`, `mcap`).

pub mod data;
pub mod imu_tk;
pub mod mcap;
pub mod meta;
pub mod psins;
pub mod run;
pub mod serial;
mod text_lines;

pub use meta::{RunMetadata, Truth};
pub use serial::UnitSerial;
