//! How numbers and times read on a page: enough digits for a parameter
//! known to a few ppm, no more, and times in UTC as the API gives them.

use crate::store::JobState;
use sinscal_core::accept::VerdictStatus;
use sinscal_core::calib::ErrorModel;

/// A value with `digits` significant digits as the certificate writes it
/// (`certificate_sheet::sig`), a missing one as a dash of the page's.
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "—".into();
    }
    crate::api::certificate_sheet::sig(v, digits)
}

/// `v` to the second significant digit of `resolution` (its σ, or the
/// scatter it is read against): the digits that mean something, at least
/// two, at most nine.
pub fn sig_to(v: f64, resolution: f64) -> String {
    if !(v.is_finite() && v != 0.0 && resolution.is_finite() && resolution > 0.0) {
        return sig(v, 3);
    }
    let digits = (v.abs().log10().floor() - resolution.log10().floor()) as i64 + 2;
    sig(v, digits.clamp(2, 9) as usize)
}

/// Unix ms as `2026-12-02 14:05 UTC`.
pub fn time(ms: i64) -> String {
    chrono::DateTime::from_timestamp_millis(ms)
        .map(|t| t.format("%Y-%m-%d %H:%M UTC").to_string())
        .unwrap_or_else(|| "—".into())
}

/// Unix ms as a date.
pub fn date(ms: i64) -> String {
    chrono::DateTime::from_timestamp_millis(ms)
        .map(|t| t.format("%Y-%m-%d").to_string())
        .unwrap_or_else(|| "—".into())
}

/// A verdict as words and the CSS class that colours it.
pub fn verdict(status: Option<VerdictStatus>) -> (&'static str, &'static str) {
    match status {
        Some(VerdictStatus::Accepted) => ("accepted", "ok"),
        Some(VerdictStatus::Rejected) => ("rejected", "bad"),
        Some(VerdictStatus::NeedsReview) => ("needs review", "warn"),
        None => ("not judged", "none"),
    }
}

/// Where a run stands as words and a CSS class: its verdict once it is
/// calibrated, else how far its calibration job got.
pub fn run_outcome(
    calibrated: bool,
    job: JobState,
    verdict: Option<VerdictStatus>,
) -> (&'static str, &'static str) {
    if calibrated {
        return self::verdict(verdict);
    }
    match job {
        JobState::Queued => ("calibration queued", "none"),
        JobState::Running => ("calibrating", "none"),
        JobState::Failed | JobState::DeadLetter => ("calibration failed", "bad"),
        JobState::Cancelled => ("calibration cancelled", "none"),
        // Succeeded without a result: not a state the store keeps.
        JobState::Succeeded => ("not judged", "none"),
    }
}

/// A result's model as its name (`base-24+accel_delay`), a dash when not
/// known.
pub fn model(m: Option<&ErrorModel>) -> String {
    m.map_or_else(|| "—".into(), ErrorModel::to_string)
}

/// The first part of an id, enough to tell runs apart on a page.
pub fn short_id(id: impl std::fmt::Display) -> String {
    let id = id.to_string();
    id.get(..8).unwrap_or(&id).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(sig(0.012345, 3), "0.0123");
        assert_eq!(sig(-512.34, 4), "-512.3");
        assert_eq!(sig(123456.0, 3), "123456");
        assert_eq!(sig(2.5e-7, 2), "2.5e-7");
        assert_eq!(sig(f64::NAN, 3), "—");
    }

    #[test]
    fn a_value_is_shown_to_its_resolution() {
        assert_eq!(sig_to(0.06214, 0.0085), "0.0621");
        assert_eq!(sig_to(499.031, 0.69), "499.03");
        assert_eq!(sig_to(0.0005, 0.00079), "0.00050");
        assert_eq!(sig_to(0.0, 0.1), "0");
        assert_eq!(sig_to(2.5, 0.0), "2.50");
    }

    #[test]
    fn a_run_reads_as_its_verdict_once_calibrated() {
        use VerdictStatus as V;
        let words = |calibrated, job, v| run_outcome(calibrated, job, v).0;
        assert_eq!(
            words(true, JobState::Succeeded, Some(V::Accepted)),
            "accepted"
        );
        assert_eq!(
            words(true, JobState::Running, Some(V::NeedsReview)),
            "needs review"
        );
        assert_eq!(
            words(true, JobState::Succeeded, Some(V::Rejected)),
            "rejected"
        );
        assert_eq!(words(false, JobState::Queued, None), "calibration queued");
        assert_eq!(
            words(false, JobState::DeadLetter, None),
            "calibration failed"
        );
    }

    #[test]
    fn times_are_utc() {
        assert_eq!(time(0), "1970-01-01 00:00 UTC");
        assert_eq!(date(86_400_000), "1970-01-02");
    }
}
