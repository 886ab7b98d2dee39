//! Which values set a chart's ranges, in each axis' space: the series'
//! points (and the σ they draw), band edges as [`YRange`] says, never a
//! [`Style::Guide`]; and which bands lie off the y range drawn.

use super::scale::{Extent, PAD};
use super::{Band, Chart, Scale, XAxis, YRange};

/// The least share of the y axis the data keep under [`YRange::Data`]
/// when band edges are brought into view: below it, the scatter a chart
/// is read for would shrink to a line.
const DATA_SHARE: f64 = 1.0 / 3.0;

/// The padded extents drawn, and per band whether it lies off scale.
pub(super) struct Ranges {
    pub x: Extent,
    pub y: Extent,
    pub off_scale: Vec<bool>,
}

/// The scale of the x axis' space: a time axis is always linear.
pub(super) fn x_scale(chart: &Chart) -> Scale {
    match chart.x_axis {
        XAxis::TimeMs => Scale::Linear,
        XAxis::Number => chart.x_scale,
    }
}

/// The extents of what will be drawn, padded; None when no point of a
/// series that sets the ranges can be drawn.
pub(super) fn ranges(chart: &Chart) -> Option<Ranges> {
    let (xs, ys) = (x_scale(chart), chart.y_scale);
    let (x, data) = data_extents(chart, xs, ys);
    if x.is_empty() {
        return None;
    }
    let y = match chart.y_range {
        YRange::All => {
            let mut y = data;
            chart
                .bands
                .iter()
                .flat_map(|b| edges(b, ys))
                .for_each(|s| y.add(s));
            y
        }
        YRange::Data => with_near_edges(data, chart.bands.iter().flat_map(|b| edges(b, ys))),
        YRange::Fixed { lo, hi } => {
            let mut y = Extent::empty();
            for v in [lo, hi].into_iter().filter(|&v| ys.admits(v)) {
                y.add(ys.space(v));
            }
            if y.is_empty() {
                data
            } else {
                y
            }
        }
    };
    let half = |s: Scale| match s {
        Scale::Linear => None,
        Scale::Log10 => Some(0.5),
    };
    let x_half = match chart.x_axis {
        XAxis::TimeMs => Some(60_000.0),
        XAxis::Number => half(xs),
    };
    let y = y.padded(half(ys));
    let off_scale = chart
        .bands
        .iter()
        .map(|b| chart.y_range != YRange::All && off_scale(b, ys, &y))
        .collect();
    Some(Ranges {
        x: x.padded(x_half),
        y,
        off_scale,
    })
}

/// The x and y extents of the series that set the ranges, σ included
/// where it is drawn.
fn data_extents(chart: &Chart, xs: Scale, ys: Scale) -> (Extent, Extent) {
    let (mut x, mut y) = (Extent::empty(), Extent::empty());
    for s in chart.series.iter().filter(|s| s.style.sets_range()) {
        for p in &s.points {
            if !(xs.admits(p.x) && ys.admits(p.y)) {
                continue;
            }
            x.add(xs.space(p.x));
            y.add(ys.space(p.y));
            let sigma = p.sigma.filter(|s| s.is_finite() && *s > 0.0);
            if let (true, Some(sg)) = (s.style.draws_sigma(), sigma) {
                for v in [p.y + sg, p.y - sg] {
                    if ys.admits(v) {
                        y.add(ys.space(v));
                    }
                }
            }
        }
    }
    (x, y)
}

/// A band's edges that can be placed, in the axis' space; none for a band
/// that is left out (a NaN edge).
fn edges(b: &Band, ys: Scale) -> impl Iterator<Item = f64> {
    let drawn = !b.lo.is_nan() && !b.hi.is_nan();
    [b.lo, b.hi]
        .into_iter()
        .filter(move |&v| drawn && ys.admits(v))
        .map(move |v| ys.space(v))
}

/// `data` widened to the band edges nearest it, nearest first, each only
/// if the data still fill [`DATA_SHARE`] of the padded axis with it.
fn with_near_edges(data: Extent, edges: impl Iterator<Item = f64>) -> Extent {
    let distance = |s: f64| (data.lo - s).max(s - data.hi);
    let mut outside: Vec<f64> = edges.filter(|&s| distance(s) > 0.0).collect();
    outside.sort_by(|a, b| distance(*a).total_cmp(&distance(*b)));
    let data_span = data.hi - data.lo;
    let mut y = data;
    for s in outside {
        let mut wider = y;
        wider.add(s);
        if data_span >= DATA_SHARE * (1.0 + 2.0 * PAD) * (wider.hi - wider.lo) {
            y = wider;
        }
    }
    y
}

/// A band with a finite edge, none of which lies in the range `y`: drawn,
/// it would either be nowhere or cover the whole plot without saying where
/// it ends.
fn off_scale(b: &Band, ys: Scale, y: &Extent) -> bool {
    let mut finite = edges(b, ys).peekable();
    finite.peek().is_some() && !finite.any(|s| (y.lo..=y.hi).contains(&s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::{Point, Series, Style};

    /// A unit's trend: runs scattered ±0.001 around 0.0005 deg/h with σ
    /// 0.0002, under a ±0.1 deg/h product limit.
    fn scatter_under_a_wide_limit() -> Chart {
        let mut c = Chart::new("gyro_bias_x", "run date", "estimate (deg/h)");
        c.series.push(Series::new(
            "estimate ± 1σ (deg/h)",
            Style::MarkersWithErrorBars,
            [0.0015, -0.0005, 0.001, 0.0]
                .iter()
                .enumerate()
                .map(|(i, &v)| Point::with_sigma(i as f64, v, 0.0002))
                .collect(),
        ));
        c.bands.push(Band::new("limit ±0.1 deg/h", -0.1, 0.1));
        c
    }

    fn data_share(c: &Chart, lo: f64, hi: f64) -> f64 {
        let (a, b) = c.shown_y_range().unwrap();
        (hi - lo) / (b - a)
    }

    #[test]
    fn under_data_a_wide_limit_is_off_scale_and_the_scatter_fills_the_axis() {
        let mut c = scatter_under_a_wide_limit();
        assert!(
            data_share(&c, -0.0007, 0.0017) < 0.05,
            "the limit sets the range"
        );
        c.y_range = YRange::Data;
        assert!(data_share(&c, -0.0007, 0.0017) >= 1.0 / 3.0);
        let r = ranges(&c).unwrap();
        assert_eq!(r.off_scale, [true]);
        let svg = c.to_svg();
        assert!(
            svg.contains(">limit ±0.1 deg/h (off scale)</text>"),
            "{svg}"
        );
        // Not drawn: the band's colour is only the legend's outline.
        assert_eq!(svg.matches("#bab0ac").count(), 1, "{svg}");
        assert!(svg.contains("fill=\"none\" stroke=\"#bab0ac\""), "{svg}");
    }

    #[test]
    fn a_near_edge_is_brought_into_view_and_a_far_one_is_not() {
        let mut c = scatter_under_a_wide_limit();
        c.y_range = YRange::Data;
        c.bands[0] = Band::new("limit", -0.006, 0.002);
        let (lo, hi) = c.shown_y_range().unwrap();
        // 0.002 keeps the data over a third of the axis; with −0.006 too
        // they would fill 2.4/7.7 of it, less than a third.
        assert!(hi > 0.002 && lo > -0.006, "{lo} {hi}");
        assert_eq!(ranges(&c).unwrap().off_scale, [false]);
        assert!(data_share(&c, -0.0007, 0.0017) >= 1.0 / 3.0);
        let svg = c.to_svg();
        assert!(svg.contains(">limit</text>"), "{svg}");
    }

    #[test]
    fn a_fixed_range_clips_the_data_and_guides_never_widen_an_axis() {
        let mut c = Chart::new("", "", "");
        c.series.push(Series::new(
            "estimate",
            Style::Line,
            vec![
                Point::new(0.0, 50.0),
                Point::new(1.0, 1.0),
                Point::new(2.0, 1.1),
            ],
        ));
        c.series.push(Series::new(
            "asymptote",
            Style::Guide,
            vec![Point::new(-10.0, -100.0), Point::new(10.0, 100.0)],
        ));
        c.y_range = YRange::Fixed { lo: 0.9, hi: 1.2 };
        let r = ranges(&c).unwrap();
        assert!((r.y.lo - 0.888).abs() < 1e-9 && (r.y.hi - 1.212).abs() < 1e-9);
        assert!((r.x.lo + 0.08).abs() < 1e-9 && (r.x.hi - 2.08).abs() < 1e-9);
        // One chart is one <svg>: what runs off the plot is cut, not
        // hidden by a nested viewport.
        assert_eq!(c.to_svg().matches("<svg").count(), 1);

        c.series.remove(0);
        assert!(ranges(&c).is_none(), "a guide alone is no data");
    }
}
