//! What the MCAP importer writes and measures as it goes: a rates CSV
//! (SPEC §5 `t,wx,wy,wz,fx,fy,fz`) one sample at a time, and the sample
//! rate from the median step of the stamps in bounded memory.
//!
//! The data module's writers write increments only; an Imu message is a
//! rate sample, and turning it into an increment here would fix an
//! interval the reader already derives from the stamps (SPEC §2a: a rate
//! sample is taken at its stamp).

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// The rates header of SPEC §5.
const RATES_HEADER: &str = "t,wx,wy,wz,fx,fy,fz";

/// A rates CSV file written sample by sample. Numbers are written in the
/// shortest form that reads back to the same f64 (ryu), as the data
/// module's writers do, so the run holds the message's doubles exactly.
pub struct RatesWriter {
    out: BufWriter<File>,
    number: ryu::Buffer,
    line: Vec<u8>,
}

impl RatesWriter {
    /// Creates `path` with `comments` (without their `#`) and the header.
    pub fn create(path: &Path, comments: &[String]) -> io::Result<Self> {
        let mut out = BufWriter::with_capacity(64 * 1024, File::create(path)?);
        for c in comments.iter().flat_map(|c| c.lines()) {
            writeln!(out, "# {c}")?;
        }
        writeln!(out, "{RATES_HEADER}")?;
        Ok(RatesWriter {
            out,
            number: ryu::Buffer::new(),
            line: Vec::with_capacity(256),
        })
    }

    /// Appends the sample at `t` s: rate rad/s, specific force m/s². The
    /// caller has checked the values are finite (ryu would print `NaN`).
    pub fn write(&mut self, t: f64, w: &[f64; 3], f: &[f64; 3]) -> io::Result<()> {
        self.line.clear();
        for (k, v) in std::iter::once(t).chain(*w).chain(*f).enumerate() {
            if k > 0 {
                self.line.push(b',');
            }
            self.line
                .extend_from_slice(self.number.format_finite(v).as_bytes());
        }
        self.line.push(b'\n');
        self.out.write_all(&self.line)
    }

    /// Writes what is buffered; the file closes when dropped.
    pub fn finish(mut self) -> io::Result<()> {
        self.out.flush()
    }
}

/// Most steps kept for the median: 64 KiB, whatever the run's length.
const STEPS_KEPT: usize = 8192;

/// An even sample of a run's time steps (ns): every step until the buffer
/// is full, then every second of those kept and every second step after,
/// and so on, so the kept steps stay spread over the whole run.
#[derive(Debug, Default)]
pub struct StepSample {
    kept: Vec<u64>,
    /// Keep one step in `stride`.
    stride: u64,
    seen: u64,
}

impl StepSample {
    pub fn new() -> Self {
        StepSample {
            kept: Vec::with_capacity(STEPS_KEPT),
            stride: 1,
            seen: 0,
        }
    }

    pub fn push(&mut self, step_ns: u64) {
        if self.seen % self.stride == 0 {
            if self.kept.len() == STEPS_KEPT {
                let mut k = 0;
                self.kept.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
            if self.seen % self.stride == 0 {
                self.kept.push(step_ns);
            }
        }
        self.seen += 1;
    }

    /// The median of the kept steps, ns (the mean of the middle two of an
    /// even count); `None` without steps.
    pub fn median_ns(&mut self) -> Option<f64> {
        let n = self.kept.len();
        if n == 0 {
            return None;
        }
        self.kept.sort_unstable();
        let k = &self.kept;
        Some(if n % 2 == 1 {
            k[n / 2] as f64
        } else {
            (k[n / 2 - 1] as f64 + k[n / 2] as f64) / 2.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_with_gaps_and_jitter_has_the_median_step() {
        let mut s = StepSample::new();
        for k in 0..100_000u64 {
            // 10 ms ± 0.2 ms, with a lost record every 97
            let step = 10_000_000 + (k % 5) * 100_000 - 200_000;
            s.push(if k % 97 == 0 { 2 * step } else { step });
        }
        assert!(s.kept.len() <= STEPS_KEPT);
        assert_eq!(s.median_ns(), Some(10_000_000.0));
    }

    #[test]
    fn the_kept_steps_span_the_run() {
        let mut s = StepSample::new();
        for k in 0..3 * STEPS_KEPT as u64 {
            s.push(k);
        }
        assert_eq!(s.stride, 4);
        assert_eq!(s.kept[..3], [0, 4, 8]);
        assert!(*s.kept.last().unwrap() >= 3 * STEPS_KEPT as u64 - 4);
    }
}
