//! Streaming readers and writers for run data (SPEC §5).
//!
//! - [`RecordReader`] turns a CSV (plain or gzip, detected by its magic
//!   bytes) or f64le stream into checked [`Record`](crate::Record)s one at a
//!   time; rate files are converted to increments.
//! - [`CsvWriter`], [`F64leWriter`] and [`RecordWriter`] write records so that
//!   reading them back is bit-exact.
//! - [`DataError`] says what is wrong and where: the line of a CSV file or the
//!   record of an f64le file.
//!
//! Neither side ever holds a whole run: memory is a fixed window of the file.
//!
//! ```
//! use sinscal_core::io::data::{CsvWriter, DataFormat, ReadLimits, RecordReader, WriteOptions};
//! use sinscal_core::Record;
//!
//! let mut writer = CsvWriter::new(Vec::new(), &WriteOptions::default());
//! for k in 1..=3 {
//!     let t = k as f64 * 0.01;
//!     writer.write_record(&Record { t, dtheta: [1e-6; 3], dv: [0.0, 0.0, 0.098] })?;
//! }
//! let bytes = writer.finish()?;
//! let reader = RecordReader::new(&bytes[..], DataFormat::Csv, 100.0, ReadLimits::default())?;
//! let records = reader.collect::<Result<Vec<_>, _>>()?;
//! assert_eq!(records.len(), 3);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod binary;
mod buffer;
mod check;
mod counts;
mod csv;
mod error;
mod format;
mod layout;
mod reader;
mod source;
mod temperature;
mod writer;

pub use binary::{RECORD_BYTES, RECORD_BYTES_WITH_TEMPERATURE};
pub use counts::{CountedKind, CountsConversion, TriadConversion};
pub use error::{Column, DataError, Position};
pub use format::{DataFormat, ReadLimits, UnknownFormat};
pub use layout::STEP_TOLERANCE;
pub use reader::RecordReader;
pub use temperature::{TemperaturePoint, TemperatureSummary, HISTORY_STEP_S, RATE_WINDOW_S};
pub use writer::{CsvWriter, F64leWriter, RecordWriter, WriteOptions};
