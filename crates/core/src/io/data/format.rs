//! The data formats of SPEC §5 and the limits a reader enforces.

use std::fmt;
use std::str::FromStr;

/// How a run's data file is encoded (the metadata's `"format"`).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum DataFormat {
    /// UTF-8 CSV with a header naming the kind of data; may be
    /// gzip-compressed, which readers detect by the magic bytes `1f 8b`,
    /// never by the file's name.
    #[default]
    Csv,
    /// Raw little-endian IEEE-754 f64, 7 values a record in the order
    /// `t,dthx,dthy,dthz,dvx,dvy,dvz`, no header, never compressed.
    F64le,
}

impl DataFormat {
    /// The name used in metadata and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            DataFormat::Csv => "csv",
            DataFormat::F64le => "f64le",
        }
    }
}

impl fmt::Display for DataFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An unknown data format name.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown data format `{0}`: expected `csv` or `f64le`")]
pub struct UnknownFormat(pub String);

impl FromStr for DataFormat {
    type Err = UnknownFormat;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "csv" => Ok(DataFormat::Csv),
            "f64le" => Ok(DataFormat::F64le),
            other => Err(UnknownFormat(other.to_owned())),
        }
    }
}

/// How a stored run's format column reads back.
impl TryFrom<String> for DataFormat {
    type Error = UnknownFormat;

    fn try_from(name: String) -> Result<Self, UnknownFormat> {
        name.parse()
    }
}

/// Bounds on what a reader will take in, so that a hostile or broken upload
/// is refused with an error instead of exhausting memory.
///
/// The reader's memory is bounded by its chunk buffer whatever these are;
/// `max_line_bytes` bounds how far that buffer may grow to hold one line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct ReadLimits {
    /// Most bytes of data the reader accepts after decompression (for an
    /// uncompressed file: its length). `None`: no limit. A server should set
    /// one, since a small gzip file can expand a thousandfold.
    pub max_decompressed_bytes: Option<u64>,
    /// Longest CSV line accepted, in bytes without its line end (`\n` or
    /// `\r\n`). Applies to comments and the header as well.
    pub max_line_bytes: usize,
    /// Most comment and blank lines a CSV file may hold. `None`: no limit.
    /// They cost decompression and scanning but carry no data, so a server
    /// bounds them: a stream of comments is the cheapest way to make a
    /// small gzip file expensive.
    pub max_skipped_lines: Option<u64>,
    /// Most decompressed bytes per compressed byte of a gzip stream,
    /// checked once more than 16 MiB have been decompressed. `None`: no
    /// limit. CSV of sensor data compresses a few-fold; a bomb, a
    /// thousandfold.
    pub max_expansion_ratio: Option<u64>,
}

impl ReadLimits {
    /// Default longest line: a record is about 150 bytes; a long comment
    /// still fits.
    pub const DEFAULT_MAX_LINE_BYTES: usize = 4096;
}

impl Default for ReadLimits {
    fn default() -> Self {
        ReadLimits {
            max_decompressed_bytes: None,
            max_line_bytes: Self::DEFAULT_MAX_LINE_BYTES,
            max_skipped_lines: None,
            max_expansion_ratio: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_names_round_trip_through_serde_and_from_str() {
        for (format, name) in [(DataFormat::Csv, "csv"), (DataFormat::F64le, "f64le")] {
            let json = serde_json::to_string(&format).expect("serialize");
            assert_eq!(json, format!("\"{name}\""));
            let back: DataFormat = serde_json::from_str(&json).expect("deserialize");
            assert_eq!(back, format);
            assert_eq!(name.parse::<DataFormat>(), Ok(format));
            assert_eq!(format.to_string(), name);
        }
        assert!("CSV".parse::<DataFormat>().is_err());
        assert!(serde_json::from_str::<DataFormat>("\"binary\"").is_err());
        assert_eq!(DataFormat::default(), DataFormat::Csv);
    }
}
