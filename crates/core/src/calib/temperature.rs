//! The unit's temperature through a run as the estimator uses it (SPEC
//! §3a): ΔT = T − 25 °C and the rate Ṫ at any instant, from the run's
//! temperature column decimated to about one point a second (16 bytes a
//! second of run, never the records).
//!
//! The rate is a central difference over [`RATE_HALF_WIDTH_S`] on either
//! side, not between neighbouring points: a column read to 0.01 °C
//! changes in steps, and one-second differences of it would be mostly
//! quantisation. A central difference is the derivative of the
//! temperature's moving average, so where the gyro bias follows k Ṫ the
//! angle it adds over any stretch longer than the window is k times the
//! change of that average, which is what the records hold; only the
//! shape within a minute of a corner (a ramp that stops) is smoothed.

use super::result::RunTemperature;
use crate::model::thermal::REFERENCE_C;

/// Half the span of the rate's central difference, s.
pub const RATE_HALF_WIDTH_S: f64 = 30.0;

/// A temperature span (°C) over which a run's parameters move enough to
/// matter: a navigation-grade gyro's bias moves by about 0.001 deg/h per
/// °C and its scale factor by tenths of a ppm, so three degrees move them
/// by a large fraction of the run's own σ.
pub const THERMAL_SPAN_C: f64 = 3.0;

/// The temperature history of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct TemperatureCurve {
    /// (t, T): record time s, °C; times strictly increasing.
    points: Vec<(f64, f64)>,
    summary: RunTemperature,
}

impl TemperatureCurve {
    /// From decimated points and the summary taken over every record.
    /// `None` without points. Points out of time order are dropped.
    pub fn new(points: Vec<(f64, f64)>, summary: RunTemperature) -> Option<Self> {
        let mut kept: Vec<(f64, f64)> = Vec::with_capacity(points.len());
        for p in points {
            let later = kept.last().map(|q| q.0 < p.0).unwrap_or(true);
            if p.0.is_finite() && p.1.is_finite() && later {
                kept.push(p);
            }
        }
        (!kept.is_empty()).then_some(TemperatureCurve {
            points: kept,
            summary,
        })
    }

    /// From decimated points alone: the summary from the points, the rate
    /// over one-minute differences.
    pub fn from_points(points: Vec<(f64, f64)>) -> Option<Self> {
        let provisional = RunTemperature::soaked(0.0);
        let mut curve = Self::new(points, provisional)?;
        let n = curve.points.len() as f64;
        let temps = || curve.points.iter().map(|p| p.1);
        let mean_c = temps().sum::<f64>() / n;
        let min_c = temps().fold(f64::INFINITY, f64::min);
        let max_c = temps().fold(f64::NEG_INFINITY, f64::max);
        let (t0, t1) = curve.time_range();
        let mut max_rate = 0.0f64;
        let mut t = t0;
        while t + 60.0 <= t1 {
            max_rate = max_rate.max((curve.temperature_c(t + 60.0) - curve.temperature_c(t)).abs());
            t += 60.0;
        }
        curve.summary = RunTemperature {
            mean_c,
            min_c,
            max_c,
            max_rate_c_per_min: max_rate,
        };
        Some(curve)
    }

    pub fn summary(&self) -> RunTemperature {
        self.summary
    }

    /// Highest less lowest temperature over the run, °C.
    pub fn span_c(&self) -> f64 {
        self.summary.max_c - self.summary.min_c
    }

    fn time_range(&self) -> (f64, f64) {
        (self.points[0].0, self.points[self.points.len() - 1].0)
    }

    /// T at record time `t`, °C: linear between points, held outside them.
    pub fn temperature_c(&self, t: f64) -> f64 {
        let p = &self.points;
        let after = p.partition_point(|q| q.0 <= t);
        if after == 0 {
            return p[0].1;
        }
        if after == p.len() {
            return p[p.len() - 1].1;
        }
        let (a, b) = (p[after - 1], p[after]);
        a.1 + (b.1 - a.1) * (t - a.0) / (b.0 - a.0)
    }

    /// ΔT = T − 25 °C at `t`.
    pub fn delta_c(&self, t: f64) -> f64 {
        self.temperature_c(t) - REFERENCE_C
    }

    /// Ṫ at `t`, °C/s: the central difference over ±30 s, shortened to
    /// the history at its ends.
    pub fn rate_c_per_s(&self, t: f64) -> f64 {
        let (t0, t1) = self.time_range();
        let (a, b) = (
            (t - RATE_HALF_WIDTH_S).max(t0),
            (t + RATE_HALF_WIDTH_S).min(t1),
        );
        if b <= a {
            return 0.0;
        }
        (self.temperature_c(b) - self.temperature_c(a)) / (b - a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp_then_hold() -> TemperatureCurve {
        // 10 °C rising 0.5 °C/min for 80 min, then 50 °C; one point a
        // second, read to 0.01 °C.
        let points = (0..8000)
            .map(|s| {
                let t = s as f64 + 0.5;
                let c = (10.0 + 0.5 * t / 60.0).min(50.0);
                (t, (c * 100.0).round() / 100.0)
            })
            .collect();
        TemperatureCurve::from_points(points).unwrap()
    }

    #[test]
    fn temperature_and_rate_follow_a_ramp_and_its_hold() {
        let c = ramp_then_hold();
        assert!((c.temperature_c(1200.0) - 20.0).abs() < 0.01);
        assert!((c.delta_c(9000.0) - 25.0).abs() < 1e-12);
        assert!((c.rate_c_per_s(1200.0) * 60.0 - 0.5).abs() < 0.01);
        assert!(c.rate_c_per_s(6000.0).abs() < 1e-12);
        let s = c.summary();
        assert_eq!((s.min_c, s.max_c), (10.0, 50.0));
        assert!((s.max_rate_c_per_min - 0.5).abs() < 0.01);
        assert!((c.span_c() - 40.0).abs() < 1e-12);
    }

    /// Over any stretch whose ends are a half-width from the corner, ∫Ṫ dt
    /// is the change of T: what makes k Ṫ's angle right.
    #[test]
    fn the_rate_integrates_to_the_change() {
        let c = ramp_then_hold();
        let (a, b) = (1000.0, 7000.0);
        let n = 60_000;
        let h = (b - a) / n as f64;
        let integral: f64 = (0..n)
            .map(|k| c.rate_c_per_s(a + (k as f64 + 0.5) * h) * h)
            .sum();
        let change = c.temperature_c(b) - c.temperature_c(a);
        // Within the column's 0.01 °C steps.
        assert!((integral - change).abs() < 0.01, "{integral} {change}");
    }

    #[test]
    fn no_points_no_curve() {
        assert!(TemperatureCurve::from_points(Vec::new()).is_none());
        let one = TemperatureCurve::from_points(vec![(3.0, 21.0)]).unwrap();
        assert_eq!(one.rate_c_per_s(3.0), 0.0);
        assert_eq!(one.temperature_c(100.0), 21.0);
    }
}
