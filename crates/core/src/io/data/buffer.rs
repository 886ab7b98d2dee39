//! A fixed-size window over a byte stream: the only place a reader keeps
//! data, so its memory does not grow with the run.

use std::io::{self, Read};

/// Size of the window; large enough that a `read` call is amortised over
/// thousands of records, small enough to stay in L2 cache.
const WINDOW_BYTES: usize = 256 * 1024;

/// Why the window could not be refilled.
pub(crate) enum FillError {
    Io(io::Error),
    /// The stream holds more than the decompressed-size limit.
    TooLarge(u64),
}

/// Bytes `buf[start..end]` are read but not yet consumed.
pub(crate) struct Window<R> {
    src: R,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    eof: bool,
    /// Bytes taken from `src` and kept (at most the limit).
    total: u64,
    limit: Option<u64>,
    /// `src` had a byte beyond the limit; reported once the bytes within it
    /// are consumed, so that the error names the exact line or record.
    over_limit: bool,
    /// The window may grow to this size to hold one long line.
    max_capacity: usize,
}

impl<R: Read> Window<R> {
    /// `max_pending` is the longest run of unconsumed bytes the caller will
    /// ask to extend (e.g. one line and its terminator).
    pub(crate) fn new(src: R, limit: Option<u64>, max_pending: usize) -> Self {
        let max_capacity = max_pending.saturating_add(1).max(WINDOW_BYTES);
        Window {
            src,
            buf: vec![0; WINDOW_BYTES],
            start: 0,
            end: 0,
            eof: false,
            total: 0,
            limit,
            over_limit: false,
            max_capacity,
        }
    }

    /// The read but not yet consumed bytes.
    #[inline]
    pub(crate) fn pending(&self) -> &[u8] {
        &self.buf[self.start..self.end]
    }

    /// Marks `n` pending bytes as consumed.
    #[inline]
    pub(crate) fn consume(&mut self, n: usize) {
        debug_assert!(n <= self.end - self.start);
        self.start += n;
    }

    /// Bytes taken from the stream so far (after decompression).
    pub(crate) fn total(&self) -> u64 {
        self.total
    }

    pub(crate) fn source(&self) -> &R {
        &self.src
    }

    /// Reads more bytes behind the pending ones, keeping the pending ones.
    /// Returns `Ok(false)` at the end of the stream.
    pub(crate) fn fill(&mut self) -> Result<bool, FillError> {
        if self.over_limit {
            return Err(FillError::TooLarge(self.limit.unwrap_or(0)));
        }
        if self.eof {
            return Ok(false);
        }
        if self.start > 0 {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
        if self.end == self.buf.len() {
            if self.buf.len() >= self.max_capacity {
                // The caller promised not to ask for more than max_pending.
                return Err(FillError::Io(io::Error::other(
                    "internal: read window is full",
                )));
            }
            let grown = self.buf.len().saturating_mul(2).min(self.max_capacity);
            self.buf.resize(grown, 0);
        }
        let mut space = self.buf.len() - self.end;
        if let Some(limit) = self.limit {
            // One byte past the limit is enough to know it is exceeded.
            let allowed = limit.saturating_sub(self.total).saturating_add(1);
            space = space.min(usize::try_from(allowed).unwrap_or(usize::MAX));
        }
        let n = loop {
            match self.src.read(&mut self.buf[self.end..self.end + space]) {
                Ok(n) => break n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(FillError::Io(e)),
            }
        };
        if n == 0 {
            self.eof = true;
            return Ok(false);
        }
        let mut kept = n;
        if let Some(limit) = self.limit {
            let room = limit.saturating_sub(self.total);
            if n as u64 > room {
                kept = room as usize;
                self.over_limit = true;
            }
        }
        self.end += kept;
        self.total += kept as u64;
        if kept == 0 {
            return Err(FillError::TooLarge(self.limit.unwrap_or(0)));
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain(w: &mut Window<&[u8]>) -> Result<Vec<u8>, u64> {
        let mut out = Vec::new();
        loop {
            out.extend_from_slice(w.pending());
            let n = w.pending().len();
            w.consume(n);
            match w.fill() {
                Ok(true) => {}
                Ok(false) => return Ok(out),
                Err(FillError::TooLarge(limit)) => return Err(limit),
                Err(FillError::Io(e)) => panic!("io error {e}"),
            }
        }
    }

    #[test]
    fn data_within_the_limit_passes_and_one_byte_more_fails_after_it() {
        let data = vec![7u8; 1000];
        let mut exact = Window::new(&data[..], Some(1000), 10);
        assert_eq!(drain(&mut exact), Ok(data.clone()));

        let mut over = Window::new(&data[..], Some(999), 10);
        let mut seen = 0;
        let result = loop {
            seen += over.pending().len();
            let n = over.pending().len();
            over.consume(n);
            match over.fill() {
                Ok(true) => {}
                Ok(false) => break None,
                Err(FillError::TooLarge(limit)) => break Some(limit),
                Err(FillError::Io(e)) => panic!("io error {e}"),
            }
        };
        assert_eq!(result, Some(999));
        assert_eq!(seen, 999, "every byte within the limit is served first");
    }

    #[test]
    fn pending_bytes_survive_refills_and_the_window_grows_for_long_runs() {
        let data: Vec<u8> = (0..3 * WINDOW_BYTES).map(|i| (i % 251) as u8).collect();
        let mut w = Window::new(&data[..], None, 2 * WINDOW_BYTES);
        // Never consume: the window must grow to keep everything pending.
        while w.pending().len() < 2 * WINDOW_BYTES {
            assert!(matches!(w.fill(), Ok(true)));
        }
        assert_eq!(w.pending(), &data[..w.pending().len()]);
        assert!(w.buf.len() <= 2 * WINDOW_BYTES + 1);
    }
}
