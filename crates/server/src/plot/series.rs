//! Drawing a series' points. Each layer of a series is one element (a
//! `<path>` whose subpaths break at the gaps) wherever SVG allows, so a
//! page of long series stays a short document; nothing is allocated per
//! point.

use super::clip::Rect;
use super::scale::Axis;
use super::svg::{attr, attr_str, num, pair, rect_open};
use super::{Band, Point, Series, Style};

/// Marker radius, px.
const MARKER_R: f64 = 2.5;
/// Line width, px.
const LINE_W: f64 = 1.5;
/// The band's opacity: enough to see, light enough to see the grid and
/// other series through.
pub(super) const BAND_OPACITY: &str = "0.2";
pub(super) const DASHES: &str = "6 4";
/// A guide's pattern: dots, so it reads as a reference, not as data.
pub(super) const DOTS: &str = "2 3";

/// How a line is stroked: width (px) and dash pattern.
#[derive(Clone, Copy)]
struct Stroke {
    width: f64,
    dashes: Option<&'static str>,
}

const SOLID: Stroke = Stroke {
    width: LINE_W,
    dashes: None,
};
const DASHED: Stroke = Stroke {
    width: LINE_W,
    dashes: Some(DASHES),
};
const DOTTED: Stroke = Stroke {
    width: 1.2,
    dashes: Some(DOTS),
};
/// A [`Band`]'s opacity: it lies behind everything, so it can be a little
/// stronger than a series' band.
pub(super) const ZONE_OPACITY: &str = "0.25";

/// The pixels of a series on a plot.
pub(super) struct Plot<'a> {
    pub x: &'a Axis,
    pub y: &'a Axis,
}

impl Plot<'_> {
    fn drawable(&self, p: &Point) -> bool {
        self.x.scale.admits(p.x) && self.y.scale.admits(p.y)
    }

    /// The sigma a point is drawn with, if any.
    fn sigma(&self, p: &Point) -> Option<f64> {
        p.sigma
            .filter(|s| s.is_finite() && *s >= 0.0 && self.drawable(p))
    }

    /// The pixel of y + d (d may be negative), held to the plot.
    fn y_offset(&self, p: &Point, d: f64) -> f64 {
        self.y.px_clamped(p.y + d)
    }

    /// The plot's rectangle, what lines and markers are held to.
    fn rect(&self) -> Rect {
        Rect::spanning((self.x.px_lo, self.x.px_hi), (self.y.px_lo, self.y.px_hi))
    }

    /// The pixel of a drawable point, if it lies on the plot.
    fn on_plot(&self, p: &Point) -> Option<(f64, f64)> {
        let q = (self.x.px(p.x), self.y.px(p.y));
        (self.drawable(p) && self.rect().contains(q)).then_some(q)
    }
}

/// Appends the elements of `s`, drawn in `colour`.
pub(super) fn draw(out: &mut String, plot: &Plot, s: &Series, colour: &str) {
    match s.style {
        Style::Line => line(out, plot, &s.points, colour, SOLID),
        Style::Dashed => line(out, plot, &s.points, colour, DASHED),
        Style::Guide => line(out, plot, &s.points, colour, DOTTED),
        Style::LineWithBand => {
            band(out, plot, &s.points, colour);
            line(out, plot, &s.points, colour, SOLID);
        }
        Style::Markers => markers(out, plot, &s.points, colour),
        Style::MarkersWithErrorBars => {
            error_bars(out, plot, &s.points, colour);
            markers(out, plot, &s.points, colour);
        }
    }
}

/// A horizontal band across the plot, and a line along each of its edges
/// that lies on the plot: where a limit ends must be seen, not guessed
/// from where a light fill fades. The caller has checked that its edges
/// are not NaN.
pub(super) fn zone(out: &mut String, plot: &Plot, b: &Band, colour: &str) {
    let (left, right) = (
        plot.x.px_lo.min(plot.x.px_hi),
        plot.x.px_lo.max(plot.x.px_hi),
    );
    let (a, c) = (plot.y.px_clamped(b.lo), plot.y.px_clamped(b.hi));
    let (top, bottom) = (a.min(c), a.max(c));
    rect_open(out, left, top, right - left, bottom - top);
    attr_str(out, "fill", colour);
    attr_str(out, "fill-opacity", ZONE_OPACITY);
    out.push_str("/>\n");
    let on_plot =
        |v: f64| plot.y.scale.admits(v) && (plot.y.lo..=plot.y.hi).contains(&plot.y.scale.space(v));
    let mut started = false;
    for v in [b.lo, b.hi].into_iter().filter(|&v| on_plot(v)) {
        out.push_str(if started { "M" } else { "<path d=\"M" });
        started = true;
        pair(out, left, plot.y.px(v), ' ');
        out.push('H');
        num(out, right);
    }
    if started {
        out.push('"');
        attr_str(out, "stroke", colour);
        out.push_str(" stroke-width=\"1\"/>\n");
    }
}

/// One `<path>` through the drawable points, a new subpath after each
/// point that is not: a line must not bridge missing data. A point alone
/// between gaps becomes a zero-length subpath, which the round cap draws
/// as a dot. Segments are cut where they leave the plot.
fn line(out: &mut String, plot: &Plot, points: &[Point], colour: &str, stroke: Stroke) {
    let rect = plot.rect();
    let mut path = Subpaths::new(out);
    let mut prev: Option<(f64, f64)> = None;
    for p in points {
        if !plot.drawable(p) {
            path.break_off();
            prev = None;
            continue;
        }
        let q = (plot.x.px(p.x), plot.y.px(p.y));
        match prev {
            None if rect.contains(q) => path.move_to(q),
            None => {}
            Some(a) => match rect.clip(a, q) {
                Some(k) => {
                    if !(k.from_is_start && path.continues()) {
                        path.move_to(k.from);
                    }
                    path.line_to(k.to, k.to_is_end);
                }
                None => path.break_off(),
            },
        }
        prev = Some(q);
    }
    if !path.finish() {
        return;
    }
    out.push_str("\" fill=\"none\"");
    attr_str(out, "stroke", colour);
    attr(out, "stroke-width", stroke.width);
    out.push_str(" stroke-linejoin=\"round\" stroke-linecap=\"round\"");
    if let Some(dashes) = stroke.dashes {
        attr_str(out, "stroke-dasharray", dashes);
    }
    out.push_str("/>\n");
}

/// The `d` of a line's `<path>`, written as it goes: the element is opened
/// at the first point, a lone point closed as a dot.
struct Subpaths<'a> {
    out: &'a mut String,
    started: bool,
    /// The current subpath is only its first point.
    lone: bool,
    /// The current subpath ends at its last point (not at a cut), so the
    /// next segment from there continues it.
    open: bool,
}

impl<'a> Subpaths<'a> {
    fn new(out: &'a mut String) -> Self {
        Subpaths {
            out,
            started: false,
            lone: false,
            open: false,
        }
    }

    fn continues(&self) -> bool {
        self.open
    }

    fn move_to(&mut self, at: (f64, f64)) {
        self.break_off();
        self.out
            .push_str(if self.started { "M" } else { "<path d=\"M" });
        self.started = true;
        pair(self.out, at.0, at.1, ' ');
        (self.lone, self.open) = (true, true);
    }

    fn line_to(&mut self, at: (f64, f64), at_end: bool) {
        self.out.push(' ');
        pair(self.out, at.0, at.1, ' ');
        (self.lone, self.open) = (false, at_end);
    }

    fn break_off(&mut self) {
        if self.lone {
            self.out.push_str("h0");
        }
        (self.lone, self.open) = (false, false);
    }

    /// Ends the `d` text; false when nothing was written.
    fn finish(mut self) -> bool {
        self.break_off();
        self.started
    }
}

/// The band y ± sigma: one `<polygon>` per run of points that have a
/// sigma, along y + sigma forwards and back along y − sigma.
fn band(out: &mut String, plot: &Plot, points: &[Point], colour: &str) {
    let mut start = None;
    for i in 0..=points.len() {
        let has = i < points.len() && plot.sigma(&points[i]).is_some();
        match (has, start) {
            (true, None) => start = Some(i),
            (false, Some(a)) => {
                band_run(out, plot, &points[a..i], colour);
                start = None;
            }
            _ => {}
        }
    }
}

fn band_run(out: &mut String, plot: &Plot, run: &[Point], colour: &str) {
    if run.len() < 2 {
        return;
    }
    out.push_str("<polygon points=\"");
    for (i, p) in run.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        let s = plot.sigma(p).unwrap_or(0.0);
        pair(out, plot.x.px(p.x), plot.y_offset(p, s), ',');
    }
    for p in run.iter().rev() {
        out.push(' ');
        let s = plot.sigma(p).unwrap_or(0.0);
        pair(out, plot.x.px(p.x), plot.y_offset(p, -s), ',');
    }
    out.push('"');
    attr_str(out, "fill", colour);
    attr_str(out, "fill-opacity", BAND_OPACITY);
    out.push_str(" stroke=\"none\"/>\n");
}

/// A vertical bar y ± sigma per point that has one, all in one `<path>`,
/// held to the plot; a bar wholly off it (or of no length) is left out.
fn error_bars(out: &mut String, plot: &Plot, points: &[Point], colour: &str) {
    let rect = plot.rect();
    let mut started = false;
    for p in points {
        let Some(s) = plot.sigma(p) else { continue };
        let x = plot.x.px(p.x);
        let (top, bottom) = (plot.y_offset(p, s), plot.y_offset(p, -s));
        if top == bottom || !(rect.left..=rect.right).contains(&x) {
            continue;
        }
        if !started {
            out.push_str("<path d=\"");
            started = true;
        }
        out.push('M');
        pair(out, x, top, ' ');
        out.push('V');
        num(out, bottom);
    }
    if started {
        out.push('"');
        attr_str(out, "stroke", colour);
        out.push_str(" stroke-width=\"1\" fill=\"none\"/>\n");
    }
}

/// A circle per drawable point on the plot, in one group that carries the
/// paint.
fn markers(out: &mut String, plot: &Plot, points: &[Point], colour: &str) {
    let mut started = false;
    for (cx, cy) in points.iter().filter_map(|p| plot.on_plot(p)) {
        if !started {
            out.push_str("<g");
            attr_str(out, "fill", colour);
            out.push_str(" stroke=\"#fff\" stroke-width=\"0.5\">\n");
            started = true;
        }
        out.push_str("<circle");
        attr(out, "cx", cx);
        attr(out, "cy", cy);
        attr(out, "r", MARKER_R);
        out.push_str("/>\n");
    }
    if started {
        out.push_str("</g>\n");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::Scale;

    fn axes(y_scale: Scale) -> (Axis, Axis) {
        // x: 0..10 onto 0..100 px; y: 0..10 (or 1..100 on a log axis) onto
        // 100..0 px.
        let x = Axis {
            scale: Scale::Linear,
            lo: 0.0,
            hi: 10.0,
            px_lo: 0.0,
            px_hi: 100.0,
        };
        let (lo, hi) = match y_scale {
            Scale::Linear => (0.0, 10.0),
            Scale::Log10 => (0.0, 2.0),
        };
        let y = Axis {
            scale: y_scale,
            lo,
            hi,
            px_lo: 100.0,
            px_hi: 0.0,
        };
        (x, y)
    }

    fn drawn(style: Style, points: Vec<Point>, y_scale: Scale) -> String {
        let (x, y) = axes(y_scale);
        let mut out = String::new();
        let s = Series::new("s", style, points);
        draw(&mut out, &Plot { x: &x, y: &y }, &s, "#123456");
        out
    }

    #[test]
    fn a_line_breaks_at_points_that_cannot_be_drawn() {
        let pts = vec![
            Point::new(1.0, 1.0),
            Point::new(2.0, 2.0),
            Point::new(3.0, f64::NAN),
            Point::new(4.0, 4.0),
            Point::new(f64::INFINITY, 5.0),
            Point::new(6.0, 6.5),
            Point::new(7.0, 7.0),
        ];
        let out = drawn(Style::Line, pts, Scale::Linear);
        assert_eq!(
            out,
            "<path d=\"M10 90 20 80M40 60h0M60 35 70 30\" fill=\"none\" stroke=\"#123456\" \
             stroke-width=\"1.5\" stroke-linejoin=\"round\" stroke-linecap=\"round\"/>\n"
        );
    }

    #[test]
    fn a_series_with_nothing_drawable_writes_nothing() {
        let pts = vec![Point::new(f64::NAN, 1.0), Point::new(1.0, -1.0)];
        assert_eq!(drawn(Style::Line, pts.clone(), Scale::Log10), "");
        assert_eq!(drawn(Style::Markers, pts, Scale::Log10), "");
    }

    #[test]
    fn a_band_runs_along_the_upper_edge_and_back_along_the_lower() {
        let pts = vec![
            Point::with_sigma(1.0, 5.0, 1.0),
            Point::with_sigma(2.0, 5.0, 2.0),
            Point::new(3.0, 5.0),
            Point::with_sigma(4.0, 5.0, 1.0),
        ];
        let out = drawn(Style::LineWithBand, pts, Scale::Linear);
        assert!(
            out.starts_with(
                "<polygon points=\"10,40 20,30 20,70 10,60\" fill=\"#123456\" \
                 fill-opacity=\"0.2\" stroke=\"none\"/>\n<path d=\"M10 50 20 50 30 50 40 50\""
            ),
            "{out}"
        );
        // The lone point with a sigma after the gap makes no polygon.
        assert_eq!(out.matches("<polygon").count(), 1);
    }

    #[test]
    fn error_bars_below_zero_on_a_log_axis_end_at_the_axis() {
        let pts = vec![Point::with_sigma(5.0, 10.0, 20.0)];
        let out = drawn(Style::MarkersWithErrorBars, pts, Scale::Log10);
        assert!(out.starts_with("<path d=\"M50 26.1V100\""), "{out}");
        assert!(
            out.contains("<circle cx=\"50\" cy=\"50\" r=\"2.5\"/>"),
            "{out}"
        );
    }

    #[test]
    fn lines_and_markers_are_held_to_the_plot() {
        // From far above the plot (y 0..10 onto 100..0 px) down into it:
        // the line enters at the top edge, the marker above is left out.
        let pts = vec![
            Point::new(0.0, 1000.0),
            Point::new(1.0, 5.0),
            Point::new(2.0, 6.0),
            Point::new(3.0, -50.0),
            Point::new(4.0, -60.0),
            Point::new(5.0, 5.0),
        ];
        let out = drawn(Style::Line, pts.clone(), Scale::Linear);
        assert!(
            out.starts_with("<path d=\"M9.9 -0.5 10 50 20 40 21.1 100.5M49.2 100.5 50 50\""),
            "{out}"
        );
        let out = drawn(Style::Markers, pts, Scale::Linear);
        assert_eq!(out.matches("<circle").count(), 3, "{out}");
    }

    #[test]
    fn dashed_lines_carry_the_dash_pattern() {
        let pts = vec![Point::new(0.0, 0.0), Point::new(10.0, 10.0)];
        let out = drawn(Style::Dashed, pts, Scale::Linear);
        assert!(out.contains("d=\"M0 100 100 0\""), "{out}");
        assert!(out.contains("stroke-dasharray=\"6 4\""), "{out}");
    }
}
