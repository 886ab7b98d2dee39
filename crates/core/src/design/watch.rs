//! What a running design reports and obeys besides its time limit: its
//! progress (a server's design job shows it) and a cancel flag (the job's
//! cancel, or the server handing its jobs back at shutdown).
//!
//! The search does not know how many schemes it will score, so progress is
//! the phase (a fixed fraction each) and, within it, the count of schemes
//! scored so far: the stage moves even while the fraction does not.

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};

/// How often (in schemes scored) the count is reported: a score takes a
/// few milliseconds, so a report every ~0.1–0.5 s.
const REPORT_EVERY: usize = 50;

/// What a watch reports to: the fraction done (0–1) and the stage in words.
pub type Report<'a> = &'a dyn Fn(f64, &str);

/// A design's observer. [`Watch::quiet`] reports nothing and never stops
/// (the command line, the synchronous API).
pub struct Watch<'a> {
    report: Option<Report<'a>>,
    cancel: Option<&'a AtomicBool>,
    /// The current phase: its fraction of the whole and its name.
    phase: Cell<(f64, &'static str)>,
}

impl Watch<'static> {
    pub fn quiet() -> Watch<'static> {
        Watch {
            report: None,
            cancel: None,
            phase: Cell::new((0.0, "starting")),
        }
    }
}

impl<'a> Watch<'a> {
    /// Reports to `report` (fraction 0–1, stage in words); stops with
    /// `DesignError::Cancelled` once `cancel` is set.
    pub fn new(report: Report<'a>, cancel: &'a AtomicBool) -> Watch<'a> {
        Watch {
            report: Some(report),
            cancel: Some(cancel),
            phase: Cell::new((0.0, "starting")),
        }
    }

    /// Whether the cancel flag is set.
    pub fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }

    /// A new phase begins.
    pub(crate) fn phase(&self, fraction: f64, stage: &'static str) {
        self.phase.set((fraction, stage));
        if let Some(report) = self.report {
            report(fraction, stage);
        }
    }

    /// `evaluations` schemes have been scored so far.
    pub(crate) fn scored(&self, evaluations: usize) {
        if evaluations % REPORT_EVERY != 0 {
            return;
        }
        if let Some(report) = self.report {
            let (fraction, stage) = self.phase.get();
            report(fraction, &format!("{stage}: {evaluations} schemes scored"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;

    /// Phases report at once, counts only every `REPORT_EVERY` schemes and
    /// under the current phase's name; the flag is read as set.
    #[test]
    fn a_watch_reports_phases_and_counts_and_sees_its_flag() {
        let seen = RefCell::new(Vec::new());
        let report = |f: f64, s: &str| seen.borrow_mut().push((f, s.to_string()));
        let cancel = AtomicBool::new(false);
        let watch = Watch::new(&report, &cancel);
        watch.phase(0.5, "trimming");
        watch.scored(REPORT_EVERY - 1);
        watch.scored(REPORT_EVERY);
        assert!(!watch.cancelled());
        cancel.store(true, Ordering::Relaxed);
        assert!(watch.cancelled());
        assert_eq!(
            *seen.borrow(),
            vec![
                (0.5, "trimming".to_string()),
                (0.5, format!("trimming: {REPORT_EVERY} schemes scored")),
            ]
        );
        assert!(!Watch::quiet().cancelled());
    }
}
