//! A run's verdict as its page shows it to every role that reads the run
//! (a station its own uploads): the verdict in words, what it was judged
//! against, the limits failed and why it needs review; before the run has
//! a result, what the verdict waits for.

use maud::{html, Markup};

use super::format;
use crate::store::{RunRow, StoredVerdict};

pub(super) fn verdict_block(v: Option<&StoredVerdict>) -> Markup {
    let (word, class) = format::verdict(v.map(|v| v.status()));
    html! {
        section #verdict {
            h2 { "Verdict: " span class={ "badge " (class) } { (word) } }
            @if let Some(v) = v {
                p.muted { "Judged " (format::time(v.judged_at))
                    @if let Some(p) = &v.product { " against product type " strong { (p) } @if let Some(r) = v.revision { " (revision " (r) ")" } }
                    @else { " without a product type (no limits)" } }
                @if !v.verdict.failed().is_empty() {
                    h3 { "Limits failed" }
                    table.failed {
                        tr { th { "Parameter" } th { "Limit" } th.num { "Bound" } th.num { "Actual" } th { "Unit" } }
                        @for f in v.verdict.failed() {
                            tr.fail { td { (f.parameter) } td { (f.limit.as_str()) } td.num { (format::sig(f.max, 4)) } td.num { (format::sig(f.actual, 4)) } td { (f.unit) } }
                        }
                    }
                }
                @if !v.verdict.reasons().is_empty() {
                    h3 { "Why it needs review" }
                    ul { @for r in v.verdict.reasons() { li { (r.describe()) } } }
                }
            }
        }
    }
}

/// The verdict's place before the run has a result: what it waits for
/// (every role reads it, so a station sees where its upload stands).
pub(super) fn pending_verdict(run: &RunRow) -> Markup {
    let (word, class) = format::run_outcome(false, run.job_state, None);
    html! {
        section #verdict {
            h2 { "Verdict: " span class={ "badge " (class) } { (word) } }
            p.muted { "The run is judged once its calibration succeeds." }
        }
    }
}
