//! Ticks of a time axis (Unix milliseconds, UTC), at round clock and
//! calendar times, labelled as dates.
//!
//! The civil-date conversions are Howard Hinnant's `days_from_civil` and
//! `civil_from_days` (proleptic Gregorian calendar), written out here so
//! that the module depends on nothing.

use super::scale::{linear_ticks, Tick};

const SECOND: i64 = 1000;
const MINUTE: i64 = 60 * SECOND;
const HOUR: i64 = 60 * MINUTE;
const DAY: i64 = 24 * HOUR;

/// Steps that are round on a clock, shortest first. Week steps fall on
/// Mondays.
const CLOCK_STEPS: [i64; 29] = [
    1,
    2,
    5,
    10,
    20,
    50,
    100,
    200,
    500,
    SECOND,
    2 * SECOND,
    5 * SECOND,
    10 * SECOND,
    15 * SECOND,
    30 * SECOND,
    MINUTE,
    2 * MINUTE,
    5 * MINUTE,
    10 * MINUTE,
    15 * MINUTE,
    30 * MINUTE,
    HOUR,
    2 * HOUR,
    3 * HOUR,
    6 * HOUR,
    12 * HOUR,
    DAY,
    2 * DAY,
    7 * DAY,
];

/// Steps in months past a week: months, then years by 1, 2, 5 × 10^j.
const MONTH_STEPS: [i64; 22] = [
    1, 2, 3, 6, 12, 24, 60, 120, 240, 600, 1_200, 2_400, 6_000, 12_000, 24_000, 60_000, 120_000,
    240_000, 600_000, 1_200_000, 2_400_000, 6_000_000,
];

/// The mean Gregorian month, only to count how many month ticks a span
/// holds.
const MONTH_MS: f64 = 30.436875 * DAY as f64;

/// Dates are labelled within ±10^8 days of 1970 (the range of JavaScript's
/// `Date`); an axis beyond that is labelled as numbers.
const LIMIT_MS: f64 = 8.64e15;

/// 1970-01-05, the first Monday after the epoch, in days.
const FIRST_MONDAY: i64 = 4;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Step {
    Ms(i64),
    Months(i64),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Form {
    /// "2026-12-02"
    Date,
    /// "12-02 14:00"
    DayTime,
    /// "14:00:05"
    Seconds,
    /// "14:00:05.250"
    Millis,
}

/// Ticks over [lo, hi] ms at most `target` intervals apart. Spans of two
/// days or more are labelled by date alone, and so tick at midnights or
/// coarser, never twice on the same date.
pub(super) fn time_ticks(lo: f64, hi: f64, target: usize) -> Vec<Tick> {
    if !(lo >= -LIMIT_MS && hi <= LIMIT_MS && hi > lo) {
        return linear_ticks(lo, hi, target);
    }
    let span = hi - lo;
    let dates = span >= 2.0 * DAY as f64;
    let target = target.max(1) as f64;
    let step = CLOCK_STEPS
        .iter()
        .filter(|&&s| !dates || s >= DAY)
        .find(|&&s| span / s as f64 <= target)
        .map(|&s| Step::Ms(s))
        .or_else(|| {
            MONTH_STEPS
                .iter()
                .find(|&&n| span / (n as f64 * MONTH_MS) <= target)
                .map(|&n| Step::Months(n))
        })
        .unwrap_or(Step::Months(MONTH_STEPS[MONTH_STEPS.len() - 1]));
    let form = match step {
        _ if dates => Form::Date,
        Step::Ms(s) if s < SECOND => Form::Millis,
        Step::Ms(s) if s < MINUTE => Form::Seconds,
        _ => Form::DayTime,
    };
    let (lo, hi) = (lo.ceil() as i64, hi.floor() as i64);
    let mut ticks = Vec::new();
    let mut push = |t: i64| {
        ticks.push(Tick {
            at: t as f64,
            label: label(t, form),
        })
    };
    match step {
        Step::Ms(s) => {
            let offset = if s == 7 * DAY { FIRST_MONDAY * DAY } else { 0 };
            let mut t = (lo - offset).div_euclid(s) * s + offset;
            if t < lo {
                t += s;
            }
            while t <= hi {
                push(t);
                t += s;
            }
        }
        Step::Months(n) => {
            let (y, m, _) = civil_from_days(lo.div_euclid(DAY));
            let mut index = (y * 12 + i64::from(m) - 1).div_euclid(n) * n;
            loop {
                let (y, m) = (index.div_euclid(12), index.rem_euclid(12) as u32 + 1);
                let t = days_from_civil(y, m, 1) * DAY;
                if t > hi {
                    break;
                }
                if t >= lo {
                    push(t);
                }
                index += n;
            }
        }
    }
    ticks
}

fn label(t: i64, form: Form) -> String {
    let (y, mo, d) = civil_from_days(t.div_euclid(DAY));
    let ms = t.rem_euclid(DAY);
    let (h, mi, s, milli) = (
        ms / HOUR,
        ms % HOUR / MINUTE,
        ms % MINUTE / SECOND,
        ms % SECOND,
    );
    match form {
        Form::Date if y < 0 => format!("-{:04}-{mo:02}-{d:02}", -y),
        Form::Date => format!("{y:04}-{mo:02}-{d:02}"),
        Form::DayTime => format!("{mo:02}-{d:02} {h:02}:{mi:02}"),
        Form::Seconds => format!("{h:02}:{mi:02}:{s:02}"),
        Form::Millis => format!("{h:02}:{mi:02}:{s:02}.{milli:03}"),
    }
}

/// Days since 1970-01-01 of a proleptic Gregorian date.
fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y.rem_euclid(400);
    let mp = i64::from((m + 9) % 12);
    let doy = (153 * mp + 2) / 5 + i64::from(d) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The proleptic Gregorian date (year, month, day) of a day since
/// 1970-01-01.
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2026-12-02T00:00:00Z.
    const DEC_2: i64 = 1_796_169_600_000;

    fn labels(ticks: &[Tick]) -> Vec<&str> {
        ticks.iter().map(|t| t.label.as_str()).collect()
    }

    #[test]
    fn civil_dates_round_trip() {
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        assert_eq!(days_from_civil(2026, 12, 2) * DAY, DEC_2);
        assert_eq!(civil_from_days(DEC_2 / DAY), (2026, 12, 2));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
        assert_eq!(civil_from_days(days_from_civil(2024, 2, 29)), (2024, 2, 29));
        for z in (-800_000..800_000).step_by(997) {
            let (y, m, d) = civil_from_days(z);
            assert_eq!(days_from_civil(y, m, d), z);
        }
    }

    #[test]
    fn a_day_is_ticked_in_hours_with_the_date() {
        let lo = (DEC_2 + 10 * HOUR + 7 * MINUTE) as f64;
        let hi = (DEC_2 + 22 * HOUR + 50 * MINUTE) as f64;
        let t = time_ticks(lo, hi, 6);
        assert_eq!(
            labels(&t),
            ["12-02 12:00", "12-02 15:00", "12-02 18:00", "12-02 21:00"]
        );
        assert_eq!(t[0].at, (DEC_2 + 12 * HOUR) as f64);
    }

    #[test]
    fn a_span_of_days_is_ticked_at_midnights_as_dates() {
        let lo = (DEC_2 - 5 * HOUR) as f64;
        let hi = (DEC_2 + 3 * DAY + 5 * HOUR) as f64;
        let t = time_ticks(lo, hi, 6);
        assert_eq!(
            labels(&t),
            ["2026-12-02", "2026-12-03", "2026-12-04", "2026-12-05"]
        );
        // Just over two days with room for 8 ticks: still one per date.
        let t = time_ticks(DEC_2 as f64, (DEC_2 + 2 * DAY + HOUR) as f64, 8);
        assert_eq!(labels(&t), ["2026-12-02", "2026-12-03", "2026-12-04"]);
    }

    #[test]
    fn weeks_start_on_monday_and_months_on_the_first() {
        // 2026-12-02 is a Wednesday; the next Monday is 12-07.
        let t = time_ticks(DEC_2 as f64, (DEC_2 + 40 * DAY) as f64, 6);
        assert_eq!(
            labels(&t),
            [
                "2026-12-07",
                "2026-12-14",
                "2026-12-21",
                "2026-12-28",
                "2027-01-04",
                "2027-01-11"
            ]
        );
        let t = time_ticks(DEC_2 as f64, (DEC_2 + 400 * DAY) as f64, 6);
        assert_eq!(
            labels(&t),
            [
                "2027-01-01",
                "2027-04-01",
                "2027-07-01",
                "2027-10-01",
                "2028-01-01"
            ]
        );
    }

    #[test]
    fn short_spans_show_seconds() {
        let lo = (DEC_2 + 14 * HOUR) as f64;
        let t = time_ticks(lo, lo + 50_000.0, 5);
        assert_eq!(
            labels(&t),
            ["14:00:00", "14:00:10", "14:00:20", "14:00:30", "14:00:40", "14:00:50"]
        );
        let t = time_ticks(lo, lo + 1_000.0, 4);
        assert_eq!(labels(&t)[1], "14:00:00.500");
    }

    #[test]
    fn times_beyond_the_date_range_are_numbers() {
        let t = time_ticks(0.0, 1e17, 4);
        assert!(!t.is_empty());
        assert!(labels(&t).iter().all(|l| !l.contains('-')));
    }
}
