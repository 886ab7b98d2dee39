//! The streaming record reader: bytes → lines or 56-byte records → checked
//! [`Record`]s, one at a time.

use std::fs::File;
use std::io::{self, Read};
use std::iter::FusedIterator;
use std::path::Path;

use crate::record::{DataKind, Interval, Record};

use super::binary::{self, RECORD_BYTES, RECORD_BYTES_WITH_TEMPERATURE};
use super::buffer::{FillError, Window};
use super::check::{column, first_non_finite, to_record, Timing};
use super::counts::CountsConversion;
use super::csv::{self, FieldError, HeaderError};
use super::error::{excerpt, DataError, Position};
use super::format::{DataFormat, ReadLimits};
use super::layout::MAX_COLUMNS;
use super::source::{ExpansionExceeded, Source, TrailingGarbage};
use super::temperature::{is_plausible, TemperaturePoint, TemperatureSummary, TemperatureTrack};

/// Reads a run's records from a CSV (plain or gzip) or f64le stream,
/// checking each one, without ever holding more than a fixed-size window of
/// the file in memory.
///
/// What is checked (SPEC §5): the CSV header names the kind of data; each
/// record has 7 finite numbers; time strictly increases, and every step is
/// at least the nominal step `Δt = 1/sample_rate_hz` less
/// [`STEP_TOLERANCE`](super::STEP_TOLERANCE) (relative). A step longer
/// than the tolerance allows is a gap (SPEC §2a: records lost): it is
/// passed on, not refused, and the record after it says so
/// ([`interval`](Self::interval); [`gaps`](Self::gaps) counts them), as
/// [`Intervals`](crate::record::Intervals) tells every consumer from the
/// stamps alone. The normal steps' mean must be nominal (gaps left out),
/// and gaps must stay fewer than normal steps. Comments (`#…`) and blank lines may
/// appear before the header and between records; CRLF line ends and blanks
/// around numbers are accepted, as is a UTF-8 byte-order mark.
///
/// Rate files (`t,wx,wy,wz,fx,fy,fz`) are converted as they are read: each
/// sample becomes an increment over its record's interval, `dtheta = w·Δt`,
/// `dv = f·Δt` with `Δt = t_k − t_{k−1}` (one nominal step for the first
/// record and the record after a gap), so every record means the same
/// thing downstream. [`kind`](Self::kind) still tells what the file held.
///
/// The unit's temperature (SPEC §3a), when the file has it (a CSV header
/// ending in `temp_c`; an f64le file opened
/// [`with_temperature_column`](Self::with_temperature_column)), is checked
/// (finite, within −100..200 °C) and kept beside the records, not in them:
/// [`temperature_c`](Self::temperature_c) of the last record,
/// [`temperature_summary`](Self::temperature_summary) and the 1 s
/// [`temperature_history`](Self::temperature_history) so far.
///
/// The iterator yields `Err` once, at the first problem, and then ends: a
/// run with a bad record is refused, not patched. A file with a header but
/// no records is an error too, reported by the first `next`.
pub struct RecordReader<R: Read> {
    window: Window<Source<R>>,
    format: DataFormat,
    kind: DataKind,
    /// Whether each record carries `temp_c`.
    temperature: bool,
    /// The metadata's conversion of a counts file's records.
    counts: Option<CountsConversion>,
    /// f64le: bytes a record.
    record_bytes: usize,
    last_temperature_c: Option<f64>,
    track: TemperatureTrack,
    max_line_bytes: usize,
    timing: Timing,
    /// The last record's interval.
    interval: Interval,
    sample_rate_hz: f64,
    /// CSV: physical lines consumed so far.
    lines: u64,
    header_line: u64,
    /// Records yielded so far.
    records: u64,
    /// CSV: comment and blank lines seen, and their limit.
    skipped: u64,
    max_skipped: Option<u64>,
    done: bool,
}

impl RecordReader<File> {
    /// Opens a data file with the default [`ReadLimits`] and reads its
    /// header.
    pub fn open(
        path: impl AsRef<Path>,
        format: DataFormat,
        sample_rate_hz: f64,
    ) -> Result<Self, DataError> {
        Self::open_with_limits(path, format, sample_rate_hz, ReadLimits::default())
    }

    /// Opens a data file and reads its header.
    pub fn open_with_limits(
        path: impl AsRef<Path>,
        format: DataFormat,
        sample_rate_hz: f64,
        limits: ReadLimits,
    ) -> Result<Self, DataError> {
        // Checked before touching the file so that a bad rate is reported
        // as such even when the path is also wrong.
        Timing::new(sample_rate_hz)?;
        let path = path.as_ref();
        let file = File::open(path).map_err(|source| DataError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        Self::new(file, format, sample_rate_hz, limits)
    }
}

impl<R: Read> RecordReader<R> {
    /// Wraps a byte stream (a file, an upload body, …) and, for CSV, reads
    /// up to and including the header. A CSV stream that starts with the
    /// gzip magic bytes is decompressed (all members, if concatenated).
    pub fn new(
        reader: R,
        format: DataFormat,
        sample_rate_hz: f64,
        limits: ReadLimits,
    ) -> Result<Self, DataError> {
        let timing = Timing::new(sample_rate_hz)?;
        let csv = format == DataFormat::Csv;
        let source = Source::new(reader, csv, limits.max_expansion_ratio).map_err(|source| {
            DataError::Io {
                at: if csv {
                    Position::Line(1)
                } else {
                    Position::Record {
                        number: 1,
                        byte_offset: 0,
                    }
                },
                source,
            }
        })?;
        let max_pending = if csv {
            // A line, its `\r\n`, and one byte to see that it is too long.
            limits.max_line_bytes.saturating_add(2)
        } else {
            RECORD_BYTES_WITH_TEMPERATURE
        };
        let window = Window::new(source, limits.max_decompressed_bytes, max_pending);
        let mut reader = RecordReader {
            window,
            format,
            kind: DataKind::Increments,
            temperature: false,
            counts: None,
            record_bytes: RECORD_BYTES,
            last_temperature_c: None,
            track: TemperatureTrack::default(),
            max_line_bytes: limits.max_line_bytes,
            interval: Interval {
                dt: 1.0 / sample_rate_hz,
                gap: None,
                from_stamps: false,
            },
            timing,
            sample_rate_hz,
            lines: 0,
            header_line: 0,
            records: 0,
            skipped: 0,
            max_skipped: limits.max_skipped_lines,
            done: false,
        };
        if csv {
            (reader.kind, reader.temperature) = reader.read_header()?;
        }
        Ok(reader)
    }

    /// For f64le: whether each record has an 8th value, `temp_c` (the
    /// metadata's `"temperature_column"`). A CSV header says for itself,
    /// so for CSV this changes nothing. Call before reading a record.
    pub fn with_temperature_column(mut self, present: bool) -> Self {
        if self.format == DataFormat::F64le && self.records == 0 {
            self.temperature = present;
            self.record_bytes = if present {
                RECORD_BYTES_WITH_TEMPERATURE
            } else {
                RECORD_BYTES
            };
        }
        self
    }

    /// The run's nominal conversion of raw counts (the metadata's
    /// `counts`): what a `counts` header's records are read through. A
    /// file of another kind ignores it.
    pub fn with_counts(mut self, counts: Option<CountsConversion>) -> Self {
        self.counts = counts;
        self
    }

    /// Whether the records carry the unit's temperature.
    pub fn has_temperature(&self) -> bool {
        self.temperature
    }

    /// The temperature of the last record read, °C.
    pub fn temperature_c(&self) -> Option<f64> {
        self.last_temperature_c
    }

    /// Mean, range and largest rate of the temperature over the records
    /// read so far; `None` without a temperature column.
    pub fn temperature_summary(&self) -> Option<TemperatureSummary> {
        self.track.summary()
    }

    /// The temperature of the records read so far, one point a second
    /// (each the mean of that second's records); empty without a column.
    pub fn temperature_history(&self) -> Vec<TemperaturePoint> {
        self.track.history()
    }

    /// Checks and keeps the temperature of a record whose other values
    /// passed their checks.
    #[inline]
    fn accept_temperature(
        &mut self,
        t: f64,
        values: &[f64; MAX_COLUMNS],
        at: impl FnOnce() -> Position,
    ) -> Result<(), DataError> {
        if !self.temperature {
            return Ok(());
        }
        let value = values[MAX_COLUMNS - 1];
        if !is_plausible(value) {
            return Err(DataError::Temperature {
                at: at(),
                column: column(self.kind, MAX_COLUMNS - 1),
                value,
            });
        }
        self.track.push(t, value);
        self.last_temperature_c = Some(value);
        Ok(())
    }

    /// What the file's columns hold. Always [`DataKind::Increments`] for
    /// f64le. Records are increments either way.
    pub fn kind(&self) -> DataKind {
        self.kind
    }

    /// The format the reader was opened with.
    pub fn format(&self) -> DataFormat {
        self.format
    }

    /// Whether the stream was gzip-compressed.
    pub fn is_gzip(&self) -> bool {
        self.window.source().is_gzip()
    }

    /// The sample rate the time steps are checked against, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// Records yielded so far.
    pub fn records_read(&self) -> u64 {
        self.records
    }

    /// The interval of the last record read: its length, and the gap
    /// before it when records were lost there.
    pub fn interval(&self) -> Interval {
        self.interval
    }

    /// Gaps passed so far (steps longer than the tolerance allows).
    pub fn gaps(&self) -> u64 {
        self.timing.gaps()
    }

    /// Bytes taken from the (decompressed) stream so far, including the
    /// read-ahead window: a measure of progress.
    pub fn bytes_read(&self) -> u64 {
        self.window.total()
    }

    /// Finds the next line; returns its length without `\n` and the bytes
    /// to consume after it. The line is at the start of the pending bytes.
    #[inline]
    fn next_line(&mut self) -> Result<Option<(usize, usize)>, DataError> {
        let max = self.max_line_bytes;
        loop {
            let pending = self.window.pending();
            if let Some(end) = memchr::memchr(b'\n', pending) {
                if csv::strip_cr(&pending[..end]).len() > max {
                    return Err(self.line_too_long());
                }
                return Ok(Some((end, end + 1)));
            }
            if pending.len() > max.saturating_add(1) {
                return Err(self.line_too_long());
            }
            match self.window.fill() {
                Ok(true) => {}
                Ok(false) => {
                    // A last line without `\n`.
                    let pending = self.window.pending();
                    if pending.is_empty() {
                        return Ok(None);
                    }
                    if csv::strip_cr(pending).len() > max {
                        return Err(self.line_too_long());
                    }
                    return Ok(Some((pending.len(), pending.len())));
                }
                Err(e) => return Err(csv_fill_error(e, self.lines + 1, self.is_gzip())),
            }
        }
    }

    #[cold]
    fn line_too_long(&self) -> DataError {
        DataError::LineTooLong {
            line: self.lines + 1,
            limit: self.max_line_bytes,
        }
    }

    /// Counts a comment or blank line against the limit.
    #[inline]
    fn skip_line(&mut self, consume: usize) -> Result<(), DataError> {
        self.window.consume(consume);
        self.skipped += 1;
        match self.max_skipped {
            Some(limit) if self.skipped > limit => Err(DataError::TooManySkippedLines {
                line: self.lines,
                limit,
            }),
            _ => Ok(()),
        }
    }

    fn read_header(&mut self) -> Result<(DataKind, bool), DataError> {
        loop {
            let Some((len, consume)) = self.next_line()? else {
                return Err(DataError::NoHeader { lines: self.lines });
            };
            self.lines += 1;
            let mut line = csv::strip_cr(&self.window.pending()[..len]);
            if self.lines == 1 {
                line = line.strip_prefix(csv::UTF8_BOM).unwrap_or(line);
            }
            if csv::is_skippable(line) {
                self.skip_line(consume)?;
                continue;
            }
            let line_no = self.lines;
            let kind = csv::parse_header(line).map_err(|e| match e {
                HeaderError::Missing => DataError::MissingHeader {
                    line: line_no,
                    found: excerpt(line),
                },
                HeaderError::Unknown => DataError::UnknownHeader {
                    line: line_no,
                    found: excerpt(line),
                },
            });
            self.window.consume(consume);
            self.header_line = line_no;
            return kind;
        }
    }

    fn next_csv(&mut self) -> Option<Result<Record, DataError>> {
        loop {
            let (len, consume) = match self.next_line() {
                Ok(Some(found)) => found,
                Ok(None) if self.records == 0 => {
                    return Some(Err(DataError::NoRecords {
                        header_line: self.header_line,
                    }))
                }
                Ok(None) => return None,
                Err(e) => return Some(Err(e)),
            };
            self.lines += 1;
            let line = csv::strip_cr(&self.window.pending()[..len]);
            if csv::is_skippable(line) {
                if let Err(e) = self.skip_line(consume) {
                    return Some(Err(e));
                }
                continue;
            }
            let columns = if self.temperature { 8 } else { 7 };
            let line_no = self.lines;
            let values = csv_values(line, line_no, self.kind, columns, &mut self.timing);
            self.window.consume(consume);
            let record = values.and_then(|(mut v, interval)| {
                self.accept_temperature(v[0], &v, || Position::Line(line_no))?;
                self.interval = interval;
                let kind = self.physical_kind(&mut v)?;
                Ok(to_record(kind, &v, interval.dt))
            });
            if record.is_ok() {
                self.records += 1;
            }
            return Some(record);
        }
    }

    /// The kind of data a record's values are, converting counts to
    /// physical values in place.
    #[inline]
    fn physical_kind(&self, values: &mut [f64; MAX_COLUMNS]) -> Result<DataKind, DataError> {
        if self.kind != DataKind::Counts {
            return Ok(self.kind);
        }
        let conv = self.counts.ok_or(DataError::CountsWithoutConversion {
            line: self.header_line,
        })?;
        conv.convert(values);
        Ok(conv.kind.data_kind())
    }

    fn next_binary(&mut self) -> Option<Result<Record, DataError>> {
        let size = self.record_bytes;
        let at = Position::Record {
            number: self.records + 1,
            byte_offset: self.records * size as u64,
        };
        while self.window.pending().len() < size {
            match self.window.fill() {
                Ok(true) => {}
                Ok(false) => {
                    let left = self.window.pending().len();
                    return match (left, self.records) {
                        (0, 0) => Some(Err(DataError::NoBinaryRecords)),
                        (0, _) => None,
                        (bytes, _) => Some(Err(DataError::TrailingBytes {
                            record: self.records + 1,
                            bytes,
                            record_bytes: size,
                        })),
                    };
                }
                Err(FillError::TooLarge(limit)) => {
                    return Some(Err(DataError::TooLarge { at, limit }))
                }
                Err(FillError::Io(source)) => return Some(Err(DataError::Io { at, source })),
            }
        }
        let values = binary::decode(&self.window.pending()[..size]);
        self.window.consume(size);
        let columns = size / 8;
        if let Some(c) = first_non_finite(&values[..columns]) {
            return Some(Err(DataError::NonFinite {
                at,
                column: column(DataKind::Increments, c),
                text: values[c].to_string(),
            }));
        }
        let interval = match self.timing.accept(values[0], || at) {
            Ok(interval) => interval,
            Err(e) => return Some(Err(e)),
        };
        if let Err(e) = self.accept_temperature(values[0], &values, || at) {
            return Some(Err(e));
        }
        self.records += 1;
        self.interval = interval;
        Some(Ok(to_record(DataKind::Increments, &values, interval.dt)))
    }
}

/// Parses one CSV record line of `columns` values and checks its numbers
/// and time; the record's interval beside them.
#[inline]
fn csv_values(
    line: &[u8],
    line_no: u64,
    kind: DataKind,
    columns: usize,
    timing: &mut Timing,
) -> Result<([f64; MAX_COLUMNS], Interval), DataError> {
    let values = csv::parse_values(line, columns).map_err(|e| match e {
        FieldError::ColumnCount(found) => DataError::ColumnCount {
            line: line_no,
            expected: columns,
            found,
        },
        FieldError::NotNumeric(c) => DataError::NotNumeric {
            line: line_no,
            column: column(kind, c),
            text: excerpt(csv::field(line, c)),
        },
    })?;
    if let Some(c) = first_non_finite(&values[..columns]) {
        return Err(DataError::NonFinite {
            at: Position::Line(line_no),
            column: column(kind, c),
            text: excerpt(csv::field(line, c)),
        });
    }
    let interval = timing.accept(values[0], || Position::Line(line_no))?;
    Ok((values, interval))
}

/// Names a failed refill of a CSV stream by the line it was reading.
/// flate2 reports a cut-off stream as `UnexpectedEof` and bad data or a bad
/// checksum as `InvalidInput`/`InvalidData`; other kinds come from the
/// stream underneath.
#[cold]
fn csv_fill_error(e: FillError, line: u64, gzip: bool) -> DataError {
    match e {
        FillError::TooLarge(limit) => DataError::TooLarge {
            at: Position::Line(line),
            limit,
        },
        FillError::Io(source)
            if gzip && source.get_ref().is_some_and(|e| e.is::<TrailingGarbage>()) =>
        {
            DataError::TrailingGzipGarbage { line }
        }
        FillError::Io(source)
            if gzip
                && source
                    .get_ref()
                    .is_some_and(|e| e.is::<ExpansionExceeded>()) =>
        {
            let limit = source
                .get_ref()
                .and_then(|e| e.downcast_ref::<ExpansionExceeded>())
                .map_or(0, |e| e.limit);
            DataError::ExpansionRatio { line, limit }
        }
        FillError::Io(source) if gzip => match source.kind() {
            io::ErrorKind::UnexpectedEof => DataError::TruncatedGzip { line },
            io::ErrorKind::InvalidInput | io::ErrorKind::InvalidData => {
                DataError::CorruptGzip { line, source }
            }
            _ => DataError::Io {
                at: Position::Line(line),
                source,
            },
        },
        FillError::Io(source) => DataError::Io {
            at: Position::Line(line),
            source,
        },
    }
}

impl<R: Read> Iterator for RecordReader<R> {
    type Item = Result<Record, DataError>;

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let item = match self.format {
            DataFormat::Csv => self.next_csv(),
            DataFormat::F64le => self.next_binary(),
        };
        if !matches!(item, Some(Ok(_))) {
            self.done = true;
        }
        item
    }
}

impl<R: Read> FusedIterator for RecordReader<R> {}

impl<R: Read> std::fmt::Debug for RecordReader<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordReader")
            .field("format", &self.format)
            .field("kind", &self.kind)
            .field("temperature", &self.temperature)
            .field("gzip", &self.is_gzip())
            .field("sample_rate_hz", &self.sample_rate_hz)
            .field("records", &self.records)
            .finish_non_exhaustive()
    }
}
