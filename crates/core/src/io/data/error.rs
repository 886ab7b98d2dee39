//! The one error type of the data readers, and the positions it names.

use std::fmt;
use std::io;
use std::path::PathBuf;

use super::layout::{
    COUNT_COLUMNS, INCREMENT_COLUMNS, MEAN_RATE_TOLERANCE, RATE_COLUMNS, STEP_TOLERANCE,
};
use crate::model::thermal::PLAUSIBLE_C;

/// Where in a data file something went wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Position {
    /// A CSV line: 1-based physical line of the (decompressed) text,
    /// counting comments and blank lines.
    Line(u64),
    /// An f64le record: 1-based record number and the byte offset of its
    /// first byte.
    Record {
        /// 1-based record number.
        number: u64,
        /// Offset of the record's first byte in the file.
        byte_offset: u64,
    },
}

impl fmt::Display for Position {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Position::Line(line) => write!(f, "line {line}"),
            Position::Record {
                number,
                byte_offset,
            } => write!(f, "record {number} (byte offset {byte_offset})"),
        }
    }
}

/// A column of a record, named as in the file's header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Column {
    /// 1-based column index.
    pub index: usize,
    /// Header name of the column, e.g. `dthy` or `wy`.
    pub name: &'static str,
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.index, self.name)
    }
}

/// Why a data file was refused. Every variant that concerns the file's
/// content names the line (CSV) or record (f64le) where it was found.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// The file could not be opened.
    #[error("cannot open {}: {source}", path.display())]
    Open {
        /// The path given.
        path: PathBuf,
        /// The operating system's reason.
        source: io::Error,
    },

    /// The sample rate given with the run is not usable.
    #[error("sample rate must be a positive finite number of Hz, got {0}")]
    InvalidSampleRate(f64),

    /// Reading the underlying stream failed.
    #[error("{at}: read error: {source}")]
    Io {
        /// How far reading had come.
        at: Position,
        /// The underlying error.
        source: io::Error,
    },

    /// A CSV file without a header: nothing but comments and blank lines.
    #[error("empty file: no header line (read {lines} lines, all comments or blank)")]
    NoHeader {
        /// Physical lines read.
        lines: u64,
    },

    /// A CSV file whose header is not followed by any record.
    #[error("empty run: no records after the header on line {header_line}")]
    NoRecords {
        /// Line of the header.
        header_line: u64,
    },

    /// A `counts` header in a run whose metadata gives no conversion.
    #[error(
        "line {line}: the header `{}` holds raw counts, and the metadata has no `counts` \
         object giving each channel's offset and weight (SPEC §5)",
        COUNT_COLUMNS.join(",")
    )]
    CountsWithoutConversion {
        /// The header's line.
        line: u64,
    },

    /// An f64le file without any record.
    #[error("empty file: no f64le records (0 bytes)")]
    NoBinaryRecords,

    /// The first line that is not a comment holds data, not a header.
    #[error(
        "line {line}: missing header: expected `{}`, `{}` or `{}` before the data, found \
         `{found}`",
        INCREMENT_COLUMNS.join(","),
        RATE_COLUMNS.join(","),
        COUNT_COLUMNS.join(",")
    )]
    MissingHeader {
        /// The line.
        line: u64,
        /// Its text (shortened if long).
        found: String,
    },

    /// The header does not name a known kind of data.
    #[error(
        "line {line}: unknown header `{found}`: expected `{}`, `{}` or `{}`",
        INCREMENT_COLUMNS.join(","),
        RATE_COLUMNS.join(","),
        COUNT_COLUMNS.join(",")
    )]
    UnknownHeader {
        /// The line.
        line: u64,
        /// Its text (shortened if long).
        found: String,
    },

    /// A CSV record line with other than the header's columns (7, or 8
    /// with `temp_c`).
    #[error("line {line}: expected {expected} columns, found {found}")]
    ColumnCount {
        /// The line.
        line: u64,
        /// Columns the header names.
        expected: usize,
        /// Columns found.
        found: usize,
    },

    /// A CSV field that is not a decimal number.
    #[error("line {line}: column {column} is not a number: `{text}`")]
    NotNumeric {
        /// The line.
        line: u64,
        /// The column.
        column: Column,
        /// The field's text (shortened if long).
        text: String,
    },

    /// A value that is NaN or infinite, including decimal numbers too large
    /// for an f64.
    #[error("{at}: column {column} is not finite: `{text}`")]
    NonFinite {
        /// The line or record.
        at: Position,
        /// The column.
        column: Column,
        /// The value as written in the file (CSV) or as decoded (f64le).
        text: String,
    },

    /// A temperature no unit can have (SPEC §3a): outside
    /// [`PLAUSIBLE_C`](crate::model::thermal::PLAUSIBLE_C).
    #[error(
        "{at}: column {column} is {value} °C, outside the plausible {}..{} °C",
        PLAUSIBLE_C.start(),
        PLAUSIBLE_C.end()
    )]
    Temperature {
        /// The line or record.
        at: Position,
        /// The column (`temp_c`).
        column: Column,
        /// The value read.
        value: f64,
    },

    /// Time does not strictly increase.
    #[error("{at}: time {t} does not increase (previous {previous})")]
    TimeNotIncreasing {
        /// The line or record.
        at: Position,
        /// Its time, s.
        t: f64,
        /// The previous record's time, s.
        previous: f64,
    },

    /// A time step shorter than the nominal one, 1/sample_rate_hz, by more
    /// than the tolerance (a longer step is a gap, passed on).
    #[error(
        "{at}: time step {step} s (from {previous} to {t}) is more than {} % shorter than the nominal step {nominal} s",
        STEP_TOLERANCE * 100.0
    )]
    TimeStep {
        /// The line or record.
        at: Position,
        /// Its time, s.
        t: f64,
        /// The previous record's time, s.
        previous: f64,
        /// `t − previous`, s.
        step: f64,
        /// 1/sample_rate_hz, s.
        nominal: f64,
    },

    /// More of the steps are gaps than normal steps: the records come at
    /// a lower rate than the metadata's, not with a few records lost.
    #[error(
        "{at}: {gaps} of {steps} time steps are more than {} % longer than the nominal step {nominal} s: the data is not at {sample_rate_hz} Hz with records lost, but at a lower rate (wrong sample_rate_hz in the metadata?)",
        STEP_TOLERANCE * 100.0
    )]
    MostlyGaps {
        /// The line or record.
        at: Position,
        /// Steps since the first record.
        steps: u64,
        /// Of them, gaps.
        gaps: u64,
        /// 1/sample_rate_hz, s.
        nominal: f64,
        /// The metadata's rate, Hz.
        sample_rate_hz: f64,
    },

    /// A CSV line longer than [`ReadLimits::max_line_bytes`](super::ReadLimits).
    #[error("line {line}: longer than the limit of {limit} bytes")]
    LineTooLong {
        /// The line.
        line: u64,
        /// The limit, bytes.
        limit: usize,
    },

    /// More (decompressed) data than
    /// [`ReadLimits::max_decompressed_bytes`](super::ReadLimits) allows.
    #[error("{at}: data exceeds the limit of {limit} bytes (decompressed)")]
    TooLarge {
        /// The line or record reached.
        at: Position,
        /// The limit, bytes.
        limit: u64,
    },

    /// More comment and blank lines than
    /// [`ReadLimits::max_skipped_lines`](super::ReadLimits) allows.
    #[error("line {line}: more than {limit} comment or blank lines")]
    TooManySkippedLines {
        /// The line reached.
        line: u64,
        /// The limit, lines.
        limit: u64,
    },

    /// A gzip stream expanding more than
    /// [`ReadLimits::max_expansion_ratio`](super::ReadLimits) allows.
    #[error("line {line}: gzip data expands more than {limit}-fold (a compression bomb?)")]
    ExpansionRatio {
        /// The line reached.
        line: u64,
        /// The limit, decompressed bytes per compressed byte.
        limit: u64,
    },

    /// Bytes after the last complete gzip member that are not gzip data.
    #[error("line {line}: the gzip data is followed by bytes that are not gzip data")]
    TrailingGzipGarbage {
        /// The line reached.
        line: u64,
    },

    /// The normal time steps (gaps left out: how many records a gap lost
    /// is unknown) average away from 1/sample_rate_hz: each step is within
    /// the per-step tolerance, but the run's clock disagrees with the
    /// metadata's rate.
    #[error(
        "{at}: {steps} steps (gaps left out) span {span} s where the sample rate {sample_rate_hz} Hz gives {expected} s: the data's mean rate is {mean_rate_hz:.4} Hz, more than {bound_pct:.3} % off ({} % and five standard errors of the steps' jitter; wrong sample_rate_hz in the metadata?)",
        MEAN_RATE_TOLERANCE * 100.0
    )]
    MeanRate {
        /// The line or record.
        at: Position,
        /// Steps since the first record.
        steps: u64,
        /// Time since the first record, s.
        span: f64,
        /// steps / sample_rate_hz, s.
        expected: f64,
        /// The metadata's rate, Hz.
        sample_rate_hz: f64,
        /// steps / span, Hz.
        mean_rate_hz: f64,
        /// The relative deviation allowed at this many steps, %.
        bound_pct: f64,
    },

    /// The gzip stream ends before its end marker: a cut-off upload or copy.
    #[error("line {line}: gzip data ends unexpectedly (truncated file)")]
    TruncatedGzip {
        /// The line reached.
        line: u64,
    },

    /// The gzip stream is damaged (bad header, bad deflate data, checksum
    /// mismatch).
    #[error("line {line}: corrupt gzip data: {source}")]
    CorruptGzip {
        /// The line reached.
        line: u64,
        /// The decoder's report.
        source: io::Error,
    },

    /// An f64le file whose length is not a whole number of records.
    #[error(
        "record {record}: the file ends with {bytes} trailing bytes, not a whole {record_bytes}-byte record"
    )]
    TrailingBytes {
        /// The record the trailing bytes would have been.
        record: u64,
        /// How many bytes are left over.
        bytes: usize,
        /// Bytes in a record: 56, or 64 with the temperature.
        record_bytes: usize,
    },
}

impl DataError {
    /// The line or record the error names, if it names one.
    pub fn position(&self) -> Option<Position> {
        match self {
            DataError::Open { .. }
            | DataError::InvalidSampleRate(_)
            | DataError::NoHeader { .. }
            | DataError::NoBinaryRecords => None,
            DataError::NoRecords { header_line: line }
            | DataError::MissingHeader { line, .. }
            | DataError::CountsWithoutConversion { line }
            | DataError::UnknownHeader { line, .. }
            | DataError::ColumnCount { line, .. }
            | DataError::NotNumeric { line, .. }
            | DataError::LineTooLong { line, .. }
            | DataError::TruncatedGzip { line }
            | DataError::TooManySkippedLines { line, .. }
            | DataError::ExpansionRatio { line, .. }
            | DataError::TrailingGzipGarbage { line }
            | DataError::CorruptGzip { line, .. } => Some(Position::Line(*line)),
            DataError::Io { at, .. }
            | DataError::NonFinite { at, .. }
            | DataError::Temperature { at, .. }
            | DataError::TimeNotIncreasing { at, .. }
            | DataError::TimeStep { at, .. }
            | DataError::MostlyGaps { at, .. }
            | DataError::MeanRate { at, .. }
            | DataError::TooLarge { at, .. } => Some(*at),
            DataError::TrailingBytes {
                record,
                record_bytes,
                ..
            } => Some(Position::Record {
                number: *record,
                byte_offset: record.saturating_sub(1) * *record_bytes as u64,
            }),
        }
    }
}

/// Keeps file text quoted in messages short: a message is read by a person
/// and may travel in an HTTP response.
pub(crate) fn excerpt(bytes: &[u8]) -> String {
    const MAX: usize = 80;
    let text = String::from_utf8_lossy(bytes);
    if text.chars().count() <= MAX {
        text.into_owned()
    } else {
        let mut short: String = text.chars().take(MAX).collect();
        short.push('…');
        short
    }
}
