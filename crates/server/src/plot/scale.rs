//! Ranges, ticks and the mapping from values to pixels.
//!
//! Everything here works in an axis' *space*: the value itself on a linear
//! axis, its log10 on a log axis, so that ticks and pixels are evenly
//! spaced in it.

use super::format;
use super::Scale;

impl Scale {
    /// Whether `v` can be placed on this scale.
    pub(super) fn admits(self, v: f64) -> bool {
        v.is_finite() && (self == Scale::Linear || v > 0.0)
    }

    /// `v` in the axis' space.
    pub(super) fn space(self, v: f64) -> f64 {
        match self {
            Scale::Linear => v,
            Scale::Log10 => v.log10(),
        }
    }
}

/// The smallest interval holding the values seen, in an axis' space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Extent {
    pub lo: f64,
    pub hi: f64,
}

/// Padding on each side of the data, as a fraction of its span: enough that
/// a point on the edge is not drawn over the frame.
pub(super) const PAD: f64 = 0.04;

impl Extent {
    pub fn empty() -> Extent {
        Extent {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lo > self.hi
    }

    pub fn add(&mut self, s: f64) {
        if s.is_finite() {
            self.lo = self.lo.min(s);
            self.hi = self.hi.max(s);
        }
    }

    /// The drawn range: the extent widened by `PAD` on each side. An
    /// extent of a single value (or of values equal to 1e-9 of their size,
    /// which no tick could tell apart) is first widened so that a single
    /// point still gets an axis: to ± `half_width` when given (a decade
    /// of a log axis, a minute of a time axis), else to ± 10 % of the value
    /// (± 1 at zero), which keeps its scale: a bias of 1e-7 rad/s alone
    /// gets an axis of 1e-7s, not one from -1 to 1.
    pub fn padded(self, half_width: Option<f64>) -> Extent {
        let (mut lo, mut hi) = (self.lo, self.hi);
        let mid = lo / 2.0 + hi / 2.0;
        if hi - lo <= mid.abs() * 1e-9 {
            let h = match half_width {
                Some(h) => h,
                None if mid == 0.0 => 1.0,
                None => mid.abs() * 0.1,
            };
            lo = mid - h;
            hi = mid + h;
        }
        let span = (hi - lo).min(f64::MAX);
        Extent {
            lo: (lo - PAD * span).max(-f64::MAX),
            hi: (hi + PAD * span).min(f64::MAX),
        }
    }
}

/// Maps an axis' space onto pixels.
#[derive(Clone, Copy, Debug)]
pub(super) struct Axis {
    pub scale: Scale,
    pub lo: f64,
    pub hi: f64,
    /// The pixels of `lo` and `hi` (for a y axis, `lo` is at the bottom, the
    /// larger pixel).
    pub px_lo: f64,
    pub px_hi: f64,
}

impl Axis {
    /// The pixel of `s`, a point of the axis' space. The halves keep the
    /// arithmetic finite for ranges as wide as f64 allows.
    pub fn at(&self, s: f64) -> f64 {
        let t = (s * 0.5 - self.lo * 0.5) / (self.hi * 0.5 - self.lo * 0.5);
        self.px_lo + t * (self.px_hi - self.px_lo)
    }

    /// The pixel of the value `v`; the caller has checked
    /// `scale.admits(v)`.
    pub fn px(&self, v: f64) -> f64 {
        self.at(self.scale.space(v))
    }

    /// The pixel of `v`, held to the axis' ends: for band edges, which may
    /// be infinite or (on a log axis) ≤ 0.
    pub fn px_clamped(&self, v: f64) -> f64 {
        let (a, b) = if self.px_lo <= self.px_hi {
            (self.px_lo, self.px_hi)
        } else {
            (self.px_hi, self.px_lo)
        };
        if self.scale == Scale::Log10 && v <= 0.0 {
            return self.px_lo;
        }
        if v == f64::INFINITY {
            return self.px_hi;
        }
        if v == f64::NEG_INFINITY {
            return self.px_lo;
        }
        self.px(v).clamp(a, b)
    }
}

/// A labelled tick, at a point of the axis' space.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Tick {
    pub at: f64,
    pub label: String,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Ticks {
    pub major: Vec<Tick>,
    /// Unlabelled gridlines (the 2…9 of each decade of a log axis).
    pub minor: Vec<f64>,
}

/// n × 10^k as the nearest f64: exact powers up to 10^22 make the one
/// rounding the division's or the multiplication's.
pub(super) fn value(n: i64, k: i32) -> f64 {
    if k >= 0 {
        n as f64 * 10f64.powi(k)
    } else {
        n as f64 / 10f64.powi(-k)
    }
}

/// The step m × 10^k (m in 1, 2, 5) that divides `span` into the number
/// of intervals nearest to `target` (by ratio: the thresholds between the
/// steps are their geometric means).
fn nice_step(span: f64, target: usize) -> Option<(i64, i32)> {
    let raw = span / target.max(1) as f64;
    if !(raw.is_finite() && raw > 0.0) {
        return None;
    }
    let mut k = raw.log10().floor() as i32;
    let f = raw / value(1, k);
    let m = if f < std::f64::consts::SQRT_2 {
        1
    } else if f < 10f64.sqrt() {
        2
    } else if f < 50f64.sqrt() {
        5
    } else {
        k += 1;
        1
    };
    Some((m, k))
}

/// Ticks of a linear axis over [lo, hi]: every multiple of a 1-2-5 step,
/// about `target` intervals apart. A range no step fits (wider than f64's
/// or narrower than its precision) gets its two ends.
pub(super) fn linear_ticks(lo: f64, hi: f64, target: usize) -> Vec<Tick> {
    if let Some((m, k)) = nice_step(hi - lo, target) {
        let step = value(m, k);
        let first = (lo / step - 1e-9).ceil();
        let last = (hi / step + 1e-9).floor();
        // Indices stay well inside i64 and exact in f64; a step of 10^309
        // is infinite.
        let fits = step.is_finite() && first.abs() < 1e15 && last.abs() < 1e15;
        if fits && last >= first && last - first <= 100.0 {
            let ns: Vec<i64> = (first as i64..=last as i64).map(|i| i * m).collect();
            let labels = format::linear_labels(&ns, k);
            return ns
                .iter()
                .zip(labels)
                .map(|(&n, label)| Tick {
                    at: value(n, k),
                    label,
                })
                .collect();
        }
    }
    [lo, hi]
        .iter()
        .map(|&v| Tick {
            at: v,
            label: format::general(v),
        })
        .collect()
}

/// Ticks of a log axis over [lo, hi] (log10 space). Decades when three or
/// more fall in the range (every n-th one when there are more than
/// `target`, with the 2…9 gridlines between them when every decade is
/// shown); with fewer, 1, 2 and 5 of each decade, two decade labels
/// alone leaving a value hard to read off, unless they would crowd the
/// axis; else, for a range within a factor of about 2, the linear ticks of
/// the values.
pub(super) fn log_ticks(lo: f64, hi: f64, target: usize) -> Ticks {
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Ticks::default();
    }
    let k0 = (lo - 1e-9).ceil() as i32;
    let k1 = (hi + 1e-9).floor() as i32;
    if k1 > k0 {
        if k1 - k0 < 2 {
            let t = one_two_five(lo, hi);
            if t.major.len() <= target + 2 {
                return t;
            }
        }
        return decade_ticks(lo, hi, (k0, k1), target);
    }
    let t = one_two_five(lo, hi);
    if t.major.len() >= 2 {
        return t;
    }
    let (a, b) = (10f64.powf(lo), 10f64.powf(hi));
    let major = linear_ticks(a, b, target)
        .into_iter()
        .filter(|t| t.at > 0.0)
        .map(|t| Tick {
            at: t.at.log10(),
            label: t.label,
        })
        .collect();
    Ticks {
        major,
        minor: Vec::new(),
    }
}

fn inside(lo: f64, hi: f64, s: f64) -> bool {
    s >= lo - 1e-9 && s <= hi + 1e-9
}

/// The decades k0..=k1 in [lo, hi], every n-th one when there are more
/// than `target`.
fn decade_ticks(lo: f64, hi: f64, (k0, k1): (i32, i32), target: usize) -> Ticks {
    let decades = (k1 - k0 + 1) as usize;
    let stride = decades.div_ceil(target.max(1)).max(1) as i32;
    // Multiples of the stride, so that the labels are round
    // ("1e-6, 1e-3, 1, 1e3"), unless that leaves fewer than two.
    let aligned = (k0..=k1).filter(|k| k.rem_euclid(stride) == 0).count();
    let start = if aligned >= 2 {
        k0 + (-k0).rem_euclid(stride)
    } else {
        k0
    };
    let major = (start..=k1)
        .step_by(stride as usize)
        .map(|k| Tick {
            at: f64::from(k),
            label: format::log_label(1, k),
        })
        .collect();
    let mut minor = Vec::new();
    if stride == 1 {
        for k in (k0 - 1)..=k1 {
            for m in 2..=9 {
                let s = f64::from(k) + f64::from(m).log10();
                if inside(lo, hi, s) {
                    minor.push(s);
                }
            }
        }
    }
    Ticks { major, minor }
}

/// 1, 2 and 5 of each decade in [lo, hi] labelled, the other digits as
/// gridlines.
fn one_two_five(lo: f64, hi: f64) -> Ticks {
    let mut major = Vec::new();
    let mut minor = Vec::new();
    for k in (lo.floor() as i32)..=(hi.ceil() as i32) {
        for m in 1..=9 {
            let s = f64::from(k) + f64::from(m).log10();
            if !inside(lo, hi, s) {
                continue;
            }
            if matches!(m, 1 | 2 | 5) {
                major.push(Tick {
                    at: s,
                    label: format::log_label(i64::from(m), k),
                });
            } else {
                minor.push(s);
            }
        }
    }
    Ticks { major, minor }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(ticks: &[Tick]) -> Vec<&str> {
        ticks.iter().map(|t| t.label.as_str()).collect()
    }

    fn ats(ticks: &[Tick]) -> Vec<f64> {
        ticks.iter().map(|t| t.at).collect()
    }

    #[test]
    fn linear_ticks_are_multiples_of_a_nice_step() {
        let t = linear_ticks(-0.3, 10.4, 5);
        assert_eq!(ats(&t), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(labels(&t), ["0", "2", "4", "6", "8", "10"]);

        let t = linear_ticks(-0.13, 0.92, 5);
        assert_eq!(labels(&t), ["0", "0.2", "0.4", "0.6", "0.8"]);
        assert_eq!(t[3].at, 0.6);

        let t = linear_ticks(0.00098, 0.00202, 4);
        assert_eq!(
            labels(&t),
            ["0.0010", "0.0012", "0.0014", "0.0016", "0.0018", "0.0020"]
        );

        let t = linear_ticks(-1.0e-6, 4.1e-5, 4);
        assert_eq!(labels(&t), ["0", "1e-5", "2e-5", "3e-5", "4e-5"]);

        let t = linear_ticks(90.0, 260.0, 4);
        assert_eq!(labels(&t), ["100", "150", "200", "250"]);

        let t = linear_ticks(-3.2e6, 1.1e6, 4);
        assert_eq!(labels(&t), ["-3e6", "-2e6", "-1e6", "0", "1e6"]);
    }

    #[test]
    fn a_range_no_step_fits_gets_its_ends() {
        let t = linear_ticks(-f64::MAX, f64::MAX, 5);
        assert_eq!(t.len(), 2);
        assert_eq!(t[0].label, "-1.798e308");
        assert!(t.iter().all(|t| t.at.is_finite()));
    }

    #[test]
    fn log_ticks_are_decades_labelled_in_the_shorter_form() {
        let t = log_ticks(-3.1, 3.2, 8);
        assert_eq!(ats(&t.major), [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]);
        assert_eq!(
            labels(&t.major),
            ["1e-3", "0.01", "0.1", "1", "10", "100", "1e3"]
        );
        // 2…9 of each of the six whole decades, and 8e-4, 9e-4 below.
        assert_eq!(t.minor.len(), 6 * 8 + 2);
        assert!((t.minor[0] - 8f64.log10() + 4.0).abs() < 1e-12);
        assert!((t.minor[2] - 2f64.log10() + 3.0).abs() < 1e-12);
    }

    #[test]
    fn under_three_decades_1_2_and_5_are_labelled() {
        // A filter's σ from 0.2 down to 0.007 deg/h.
        let t = log_ticks(0.007f64.log10(), 0.2f64.log10(), 5);
        assert_eq!(labels(&t.major), ["0.01", "0.02", "0.05", "0.1", "0.2"]);
        assert!((t.major[2].at - 0.05f64.log10()).abs() < 1e-12);
        // Too many for a short axis: decades only.
        let t = log_ticks(0.0011f64.log10(), 0.95f64.log10(), 2);
        assert_eq!(labels(&t.major), ["0.01", "0.1"]);
    }

    #[test]
    fn many_decades_are_thinned_to_round_ones() {
        let t = log_ticks(-12.2, 6.3, 6);
        assert_eq!(labels(&t.major), ["1e-12", "1e-8", "1e-4", "1", "1e4"]);
        assert!(t.minor.is_empty());
    }

    #[test]
    fn a_log_range_within_a_decade_gets_1_2_5_or_linear_ticks() {
        let t = log_ticks(0.2f64.log10(), 6f64.log10(), 6);
        assert_eq!(labels(&t.major), ["0.2", "0.5", "1", "2", "5"]);
        assert_eq!(t.minor.len(), 9);

        let t = log_ticks(3f64.log10(), 4.5f64.log10(), 4);
        assert_eq!(labels(&t.major), ["3.0", "3.5", "4.0", "4.5"]);
        assert!((t.major[1].at - 3.5f64.log10()).abs() < 1e-12);
    }

    #[test]
    fn degenerate_extents_get_a_finite_nonzero_range() {
        let one = |v: f64| {
            let mut e = Extent::empty();
            e.add(v);
            e.padded(None)
        };
        let e = one(0.0);
        assert!((e.lo + 1.08).abs() < 1e-12 && (e.hi - 1.08).abs() < 1e-12);
        let e = one(50.0);
        assert!((e.lo - 44.6).abs() < 1e-9 && (e.hi - 55.4).abs() < 1e-9);
        let e = one(1e-7);
        assert!((e.lo - 0.892e-7).abs() < 1e-20 && (e.hi - 1.108e-7).abs() < 1e-20);
        let mut e = Extent::empty();
        e.add(2.0);
        let e = e.padded(Some(0.5));
        assert!((e.lo - 1.46).abs() < 1e-12 && (e.hi - 2.54).abs() < 1e-12);
        let e = one(f64::MAX);
        assert!(e.lo.is_finite() && e.hi.is_finite() && e.hi > e.lo);

        let mut e = Extent::empty();
        e.add(f64::NAN);
        e.add(f64::INFINITY);
        assert!(e.is_empty());
        e.add(-f64::MAX);
        e.add(f64::MAX);
        let p = e.padded(None);
        assert_eq!((p.lo, p.hi), (-f64::MAX, f64::MAX));
    }

    #[test]
    fn values_map_to_pixels_linearly_in_the_axis_space() {
        let y = Axis {
            scale: Scale::Linear,
            lo: -1.0,
            hi: 3.0,
            px_lo: 200.0,
            px_hi: 40.0,
        };
        assert_eq!(y.px(-1.0), 200.0);
        assert_eq!(y.px(1.0), 120.0);
        assert_eq!(y.px(3.0), 40.0);
        assert_eq!(y.px_clamped(f64::INFINITY), 40.0);
        assert_eq!(y.px_clamped(-10.0), 200.0);

        let x = Axis {
            scale: Scale::Log10,
            lo: -2.0,
            hi: 2.0,
            px_lo: 50.0,
            px_hi: 450.0,
        };
        assert_eq!(x.px(1.0), 250.0);
        assert_eq!(x.px(100.0), 450.0);
        assert_eq!(x.px_clamped(0.0), 50.0);

        let wide = Axis {
            scale: Scale::Linear,
            lo: -f64::MAX,
            hi: f64::MAX,
            px_lo: 0.0,
            px_hi: 100.0,
        };
        assert_eq!(wide.px(0.0), 50.0);
        assert_eq!(wide.px(f64::MAX), 100.0);
    }
}
