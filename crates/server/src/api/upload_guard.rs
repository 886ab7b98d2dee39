//! What bounds an upload besides its size: a body that stalls or trickles
//! (idle timeout, minimum mean rate) and validation that costs too much CPU.
//! Both free the upload's slot within a bounded time whatever the client
//! sends.

use std::io::{self, Read};
use std::time::Duration;

use axum::body::{Body, Bytes};
use futures_util::{Stream, StreamExt};
use tokio::time::Instant;

use crate::config::BodyPace;

/// The body stalled or trickled; carried inside the body's error.
#[derive(Debug, thiserror::Error)]
pub enum Stalled {
    #[error("the upload stalled: no data for {0:?}")]
    Idle(Duration),
    #[error(
        "the upload is slower than {min_bytes_per_s} bytes/s ({received} bytes in {elapsed:?})"
    )]
    TooSlow {
        min_bytes_per_s: u64,
        received: u64,
        elapsed: Duration,
    },
}

/// The body's chunks, ended by a [`Stalled`] error once the next chunk does
/// not arrive within `pace.idle`, or once the mean rate since the start
/// (after `pace.grace`) would fall below `pace.min_bytes_per_s`.
pub fn paced(body: Body, pace: BodyPace) -> impl Stream<Item = Result<Bytes, axum::Error>> {
    let start = Instant::now();
    let state = (body.into_data_stream(), 0u64, false);
    futures_util::stream::unfold(state, move |(mut stream, received, done)| async move {
        if done {
            return None;
        }
        // The moment the mean rate would drop below the minimum.
        let rate_floor = if pace.min_bytes_per_s == 0 {
            Duration::MAX
        } else {
            Duration::from_secs_f64(received as f64 / pace.min_bytes_per_s as f64)
        };
        let rate_deadline = start
            .checked_add(pace.grace.max(rate_floor))
            .unwrap_or_else(|| start + Duration::from_secs(86_400 * 365));
        let idle_deadline = Instant::now() + pace.idle;
        let deadline = rate_deadline.min(idle_deadline);
        match tokio::time::timeout_at(deadline, stream.next()).await {
            Ok(Some(Ok(chunk))) => {
                let received = received + chunk.len() as u64;
                Some((Ok(chunk), (stream, received, false)))
            }
            Ok(Some(Err(e))) => Some((Err(e), (stream, received, true))),
            Ok(None) => None,
            Err(_) => {
                let why = if deadline == idle_deadline {
                    Stalled::Idle(pace.idle)
                } else {
                    Stalled::TooSlow {
                        min_bytes_per_s: pace.min_bytes_per_s,
                        received,
                        elapsed: start.elapsed(),
                    }
                };
                Some((Err(axum::Error::new(why)), (stream, received, true)))
            }
        }
    })
}

/// The first error of type `T` in `err`'s source chain (itself included).
/// An `io::Error` wrapping an error is looked through: its `source()` skips
/// the wrapped error itself.
pub fn find_cause<'a, T: std::error::Error + 'static>(
    err: &'a (dyn std::error::Error + 'static),
) -> Option<&'a T> {
    let mut source = Some(err);
    while let Some(s) = source {
        if let Some(t) = s.downcast_ref::<T>() {
            return Some(t);
        }
        source = match s.downcast_ref::<io::Error>().and_then(|e| e.get_ref()) {
            Some(inner) => Some(inner as &(dyn std::error::Error + 'static)),
            None => s.source(),
        };
    }
    None
}

/// Validation used more CPU than an upload may.
#[derive(Debug, thiserror::Error)]
#[error("validating the upload took more than {0:?} of CPU time")]
pub struct CpuBudgetExceeded(pub Duration);

/// CPU time of the calling thread.
fn thread_cpu_time() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid out-parameter; CLOCK_THREAD_CPUTIME_ID is
    // always available on Linux.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return Duration::ZERO;
    }
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

/// The CPU time the current thread may still use: checked where the
/// validator pulls bytes, which it does at least every window of
/// decompressed data, so a costly stream is stopped within one window.
pub struct CpuBudget {
    start: Duration,
    limit: Duration,
}

impl CpuBudget {
    /// Starts counting on the calling thread (the one that will validate).
    pub fn start(limit: Duration) -> CpuBudget {
        CpuBudget {
            start: thread_cpu_time(),
            limit,
        }
    }

    pub fn check(&self) -> io::Result<()> {
        if thread_cpu_time().saturating_sub(self.start) > self.limit {
            return Err(io::Error::other(CpuBudgetExceeded(self.limit)));
        }
        Ok(())
    }
}

/// A reader charged against a [`CpuBudget`] (for validating a spooled file).
pub struct Budgeted<R> {
    pub inner: R,
    pub budget: CpuBudget,
}

impl<R: Read> Read for Budgeted<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.budget.check()?;
        self.inner.read(buf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spinning_thread_exceeds_a_small_budget() {
        let budget = CpuBudget::start(Duration::from_millis(20));
        assert!(budget.check().is_ok());
        let t0 = std::time::Instant::now();
        let mut x = 0u64;
        while t0.elapsed() < Duration::from_millis(200) {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let e = budget.check().unwrap_err();
        assert!(find_cause::<CpuBudgetExceeded>(&e).is_some());
    }
}
