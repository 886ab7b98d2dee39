//! Charts as SVG text, for the server's HTML pages.
//!
//! The pages are rendered on the server and carry no JavaScript, so a chart
//! is a self-contained `<svg>` element placed inline in the page. It uses
//! presentation attributes only (no `style=`, no `<style>`, no script), so
//! a page served under a strict Content-Security-Policy still draws it, and
//! it needs no ids, so dozens of charts can share one page without clashing.
//!
//! The module knows nothing of calibration: callers turn their results into
//! [`Series`] of [`Point`]s and get text back. It does no I/O.
//!
//! Files: `range` (which values set the axes' ranges, and which bands
//! lie off scale), `clip` (lines and markers held to the plot), `scale`
//! (extents, linear and log ticks, mapping to pixels), `format` (tick
//! labels), `time` (date ticks), `svg` (escaping and the number writer),
//! `series` (drawing the data), `legend`, `render` (the layout and the
//! order of the layers).

mod clip;
mod format;
mod legend;
mod range;
mod render;
mod scale;
mod series;
mod svg;
mod time;

/// How values are placed along an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    /// Decades equally spaced: for quantities spanning orders of magnitude
    /// (Allan deviations, covariances). Values ≤ 0 cannot be placed and are
    /// skipped.
    Log10,
}

/// What the x values mean, which decides how their ticks are labelled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum XAxis {
    Number,
    /// x values are Unix milliseconds, ticks labelled as dates (UTC,
    /// "2026-12-02", or "12-02 14:00" when the span is under 2 days, or
    /// "14:00:05" when the ticks are less than a minute apart). A time axis
    /// is always linear: `Chart::x_scale` is not consulted.
    TimeMs,
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// A line through the points, broken where a point cannot be drawn.
    Line,
    /// A small circle per point.
    Markers,
    /// A line, plus a translucent band y ± sigma behind it: a Kalman
    /// filter's estimate and its 1σ against time. The band breaks where a
    /// point has no sigma.
    LineWithBand,
    /// A circle per point with a vertical ±sigma bar.
    MarkersWithErrorBars,
    /// A dashed line, for fitted slopes drawn over measurements.
    Dashed,
    /// A thin dotted line for a reference drawn over the data (one term of
    /// a fitted model, an asymptote): it is drawn where it crosses the
    /// range the other series set and never widens an axis, so a line
    /// running on for decades does not squash the data into a corner.
    Guide,
}

impl Style {
    /// Whether this style draws `Point::sigma` (and so whether the y range
    /// has to make room for it).
    fn draws_sigma(self) -> bool {
        matches!(self, Style::LineWithBand | Style::MarkersWithErrorBars)
    }

    /// Whether the series' points count in the axes' ranges.
    fn sets_range(self) -> bool {
        self != Style::Guide
    }
}

/// One datum. Points that cannot be drawn (a non-finite coordinate, or one
/// ≤ 0 on a log axis) are skipped rather than refused, because charts are
/// drawn from stored results that a page must show whatever they hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    /// One standard deviation of y, drawn by the styles that show it.
    pub sigma: Option<f64>,
}

impl Point {
    pub fn new(x: f64, y: f64) -> Point {
        Point { x, y, sigma: None }
    }

    pub fn with_sigma(x: f64, y: f64, sigma: f64) -> Point {
        Point {
            x,
            y,
            sigma: Some(sigma),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    pub style: Style,
    /// Any SVG paint (`#4e79a7`, `teal`); `None` takes the next colour of
    /// [`PALETTE`] by the series' position.
    pub colour: Option<String>,
    pub points: Vec<Point>,
}

impl Series {
    pub fn new(name: impl Into<String>, style: Style, points: Vec<Point>) -> Series {
        Series {
            name: name.into(),
            style,
            colour: None,
            points,
        }
    }
}

/// A horizontal band drawn behind the data, e.g. a tolerance ±limit, its
/// finite edges drawn as lines. An infinite edge reaches the edge of the
/// plot ("below 5" is `lo: -inf, hi: 5`); a NaN edge leaves the band out.
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    pub name: String,
    pub lo: f64,
    pub hi: f64,
    /// Any SVG paint; `None` takes a colour from the end of [`PALETTE`]
    /// by the band's position.
    pub colour: Option<String>,
}

impl Band {
    pub fn new(name: impl Into<String>, lo: f64, hi: f64) -> Band {
        Band {
            name: name.into(),
            lo,
            hi,
            colour: None,
        }
    }
}

/// What the y axis is scaled to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum YRange {
    /// Every series (with the σ it draws) and every band's edges.
    All,
    /// The series and their σ: a band's edge is brought into view only
    /// while the data still fill a third of the axis, so a tolerance a
    /// hundred times wider than the scatter does not flatten it into one
    /// row. Bands are held to the range; a band none of whose finite
    /// edges is in view is not drawn, and its legend entry ends in
    /// "(off scale)".
    Data,
    /// The span lo..hi taken as the data (padded, ticked the same way):
    /// what lies outside is cut at the frame, bands as under `Data`.
    /// For a history whose first swings would dwarf where it settles.
    Fixed { lo: f64, hi: f64 },
}

/// The Tableau 10 colours, in their own order: it was chosen so that
/// neighbours stay apart for the common forms of colour blindness, and
/// series are coloured in that order. Bands take it from the end (grey
/// first), so a band rarely shares the colour of the first series.
pub const PALETTE: [&str; 10] = [
    "#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7",
    "#9c755f", "#bab0ac",
];

#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    pub title: String,
    /// Includes the unit, e.g. "time (s)".
    pub x_label: String,
    /// Includes the unit, e.g. "gyro bias (deg/h)".
    pub y_label: String,
    pub x_axis: XAxis,
    pub x_scale: Scale,
    pub y_scale: Scale,
    /// SVG user units (px). The element scales through its `viewBox`; the
    /// size sets the proportions and how large the text is relative to the
    /// plot. Non-finite sizes fall back to the defaults, and sizes are kept
    /// within 160–10 000 (width) and 120–10 000 (height). The drawn height
    /// grows when the legend would leave the plot less than 60 px.
    pub width: f64,
    pub height: f64,
    pub series: Vec<Series>,
    pub bands: Vec<Band>,
    pub y_range: YRange,
}

impl Chart {
    pub const DEFAULT_WIDTH: f64 = 640.0;
    pub const DEFAULT_HEIGHT: f64 = 300.0;

    /// A linear chart of numbers, 640 × 300, with no series yet.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Chart {
        Chart {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_axis: XAxis::Number,
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            width: Chart::DEFAULT_WIDTH,
            height: Chart::DEFAULT_HEIGHT,
            series: Vec::new(),
            bands: Vec::new(),
            y_range: YRange::All,
        }
    }

    /// The y values at the bottom and top of the plot as drawn (padding
    /// included), or None when nothing can be drawn: what a caller checks
    /// its scaling against.
    pub fn shown_y_range(&self) -> Option<(f64, f64)> {
        let y = range::ranges(self)?.y;
        Some(match self.y_scale {
            Scale::Linear => (y.lo, y.hi),
            Scale::Log10 => (10f64.powf(y.lo), 10f64.powf(y.hi)),
        })
    }

    /// A complete `<svg>` element, to be placed inline in an HTML page.
    pub fn to_svg(&self) -> String {
        let mut out = String::new();
        self.write_svg(&mut out);
        out
    }

    /// [`Chart::to_svg`] appended to `out`: a page embedding dozens of
    /// charts writes them all into one buffer.
    pub fn write_svg(&self, out: &mut String) {
        render::write(self, out);
    }

    /// The colour series `i` is drawn in.
    fn series_colour(&self, i: usize) -> &str {
        match &self.series[i].colour {
            Some(c) => c,
            None => PALETTE[i % PALETTE.len()],
        }
    }

    /// The colour band `i` is drawn in.
    fn band_colour(&self, i: usize) -> &str {
        match &self.bands[i].colour {
            Some(c) => c,
            None => PALETTE[PALETTE.len() - 1 - i % PALETTE.len()],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::render::{Frame, Layout};
    use super::*;

    fn line(name: &str, style: Style, pts: &[(f64, f64)]) -> Series {
        Series::new(
            name,
            style,
            pts.iter().map(|&(x, y)| Point::new(x, y)).collect(),
        )
    }

    #[test]
    fn known_points_map_where_expected() {
        let mut c = Chart::new("t", "x (s)", "y (m)");
        c.series.push(line(
            "s",
            Style::Line,
            &[(0.0, 0.0), (5.0, 5.0), (10.0, 10.0)],
        ));
        // Margins: 8 + 20 (y title) + "10" (13.2) + 4 + 5 on the left, half
        // of "10" + 2 on the right; title 36 on top; ticks, x title and one
        // legend row 73 below.
        let f = Layout::of(&c).frame;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(
            close(f.left, 50.2)
                && close(f.top, 36.0)
                && close(f.right, 631.4)
                && close(f.bottom, 227.0),
            "{f:?}"
        );
        // The data spans 0..10 on both axes, padded by 4 %: 0 is 0.4/10.8 of
        // the plot in from its edge, 5 is in its middle.
        let svg = c.to_svg();
        assert!(
            svg.contains("<path d=\"M71.7 219.9 340.8 131.5 609.9 43.1\""),
            "{svg}"
        );
    }

    #[test]
    fn bad_values_never_reach_the_text() {
        let mut c = Chart::new("bad", "x", "y");
        c.series.push(Series::new(
            "s",
            Style::LineWithBand,
            vec![
                Point::with_sigma(f64::NAN, 1.0, 0.1),
                Point::with_sigma(1.0, f64::INFINITY, 0.1),
                Point::with_sigma(2.0, 1.0, f64::NAN),
                Point::with_sigma(3.0, 2.0, f64::INFINITY),
                Point::with_sigma(f64::NEG_INFINITY, 2.0, 0.5),
                Point::with_sigma(4.0, 1.5, 0.2),
            ],
        ));
        c.series.push(Series::new(
            "e",
            Style::MarkersWithErrorBars,
            vec![Point::with_sigma(5.0, -1.0, -3.0)],
        ));
        c.bands.push(Band::new("below", f64::NEG_INFINITY, 1.0));
        c.bands.push(Band::new("undefined", f64::NAN, 1.0));
        c.width = f64::NAN;
        c.height = f64::INFINITY;
        let check = |c: &Chart| {
            let svg = c.to_svg();
            for bad in ["NaN", "nan", "inf", "Inf"] {
                assert!(!svg.contains(bad), "{bad} in {svg}");
            }
            svg
        };
        let svg = check(&c);
        assert!(svg.contains("viewBox=\"0 0 640 300\""), "{svg}");

        c.y_scale = Scale::Log10;
        c.x_scale = Scale::Log10;
        check(&c);

        let mut huge = Chart::new("huge", "x", "y");
        huge.series.push(line(
            "h",
            Style::Markers,
            &[(-f64::MAX, -f64::MAX), (f64::MAX, f64::MAX), (0.0, 1e-300)],
        ));
        check(&huge);
        huge.y_scale = Scale::Log10;
        check(&huge);
    }

    #[test]
    fn a_band_series_draws_a_polygon_and_the_legend_names_everything() {
        let mut c = Chart::new("gyro bias", "time (s)", "bias (deg/h)");
        c.series.push(Series::new(
            "estimate ±1σ",
            Style::LineWithBand,
            (0..50)
                .map(|i| Point::with_sigma(f64::from(i), 0.01 * f64::from(i), 0.1))
                .collect(),
        ));
        c.series
            .push(line("measured", Style::Markers, &[(1.0, 0.5), (2.0, 0.4)]));
        c.series
            .push(line("slope", Style::Dashed, &[(0.0, 0.0), (49.0, 0.49)]));
        c.bands.push(Band::new("tolerance", -0.05, 0.05));
        let svg = c.to_svg();
        assert_eq!(svg.matches("<polygon").count(), 1, "{svg}");
        for name in ["estimate ±1σ", "measured", "slope", "tolerance"] {
            assert!(svg.contains(&format!(">{name}</text>")), "{name} in {svg}");
        }
        // Default colours in palette order; the band from the palette's end.
        assert!(
            svg.contains("fill=\"#4e79a7\" fill-opacity=\"0.2\""),
            "{svg}"
        );
        assert!(svg.contains("<g fill=\"#f28e2b\""), "{svg}");
        assert!(svg.contains("stroke=\"#e15759\""), "{svg}");
        assert!(
            svg.contains("fill=\"#bab0ac\" fill-opacity=\"0.25\""),
            "{svg}"
        );
    }

    #[test]
    fn a_chart_without_drawable_points_says_no_data() {
        let mut c = Chart::new("empty", "x", "y");
        let empty = c.to_svg();
        c.series.push(line(
            "nothing",
            Style::Line,
            &[(f64::NAN, 1.0), (1.0, f64::NAN)],
        ));
        c.bands.push(Band::new("limit", -1.0, 1.0));
        let nothing = c.to_svg();
        for svg in [&empty, &nothing] {
            assert!(svg.contains(">no data</text>"), "{svg}");
            assert!(svg.contains("fill=\"none\" stroke=\"#555\""), "{svg}");
            assert!(!svg.contains("text-anchor=\"end\""), "{svg}");
        }
        assert!(nothing.contains(">nothing</text>"), "{nothing}");
        // No series line, no tick: only the legend's swatch is a path.
        assert_eq!(nothing.matches("<path").count(), 1, "{nothing}");
    }

    #[test]
    fn a_single_point_gets_an_axis_around_it() {
        let mut c = Chart::new("one", "x", "y");
        c.series.push(line("p", Style::Markers, &[(3.0, 7.0)]));
        let Frame {
            left,
            top,
            right,
            bottom,
        } = Layout::of(&c).frame;
        let svg = c.to_svg();
        // 7 ± 10 %, padded: ticks 6.4 … 7.6 by 0.2.
        assert!(
            svg.contains(">6.4</text>") && svg.contains(">7.6</text>"),
            "{svg}"
        );
        let mut circle = String::from("<circle");
        svg::attr(&mut circle, "cx", (left + right) / 2.0);
        svg::attr(&mut circle, "cy", (top + bottom) / 2.0);
        assert!(svg.contains(&circle), "{circle} in {svg}");

        let mut log = Chart::new("equal", "x", "y");
        log.y_scale = Scale::Log10;
        log.series
            .push(line("p", Style::Line, &[(1.0, 1e-3), (2.0, 1e-3)]));
        let svg = log.to_svg();
        assert!(svg.contains(">1e-3</text>"), "{svg}");
    }

    #[test]
    fn text_is_escaped_and_nothing_a_strict_csp_refuses_is_written() {
        let mut c = Chart::new("<script>alert('x')</script>", "a & b", "\"y\"");
        let mut s = line("</text><script>", Style::Line, &[(0.0, 1.0), (1.0, 2.0)]);
        s.colour = Some("red\" onload=\"x".to_string());
        c.series.push(s);
        let svg = c.to_svg();
        assert!(!svg.contains("<script"), "{svg}");
        assert!(!svg.contains("style="), "{svg}");
        assert!(!svg.contains("onload=\""), "{svg}");
        assert!(svg.contains("<title>&lt;script&gt;alert(&apos;x&apos;)&lt;/script&gt;</title>"));
        assert!(svg.contains(">a &amp; b</text>"), "{svg}");
        assert!(svg.contains(">&quot;y&quot;</text>"), "{svg}");
        assert!(svg.contains("stroke=\"red&quot; onload=&quot;x\""), "{svg}");
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 640 300\" width=\"640\" height=\"300\" role=\"img\" font-family=\"sans-serif\">\n<title>"));
        assert!(svg.ends_with("</svg>\n"));
    }

    #[test]
    fn log_axes_have_decade_labels_and_minor_gridlines() {
        let mut c = Chart::new("Allan deviation", "tau (s)", "sigma (deg/h)");
        c.x_scale = Scale::Log10;
        c.y_scale = Scale::Log10;
        c.height = 400.0;
        c.series.push(line(
            "x",
            Style::Markers,
            &[(0.1, 0.01), (1.0, 0.003), (10.0, 0.001), (100.0, 0.0006)],
        ));
        let svg = c.to_svg();
        for label in [
            ">0.1</text>",
            ">1</text>",
            ">10</text>",
            ">100</text>",
            ">1e-3</text>",
            ">0.01</text>",
        ] {
            assert!(svg.contains(label), "{label} in {svg}");
        }
        assert!(svg.contains("stroke=\"#eee\""), "{svg}");
    }

    #[test]
    fn a_time_axis_is_labelled_with_dates() {
        // 2026-12-02T00:00Z and three days on.
        let t0 = 1_796_169_600_000.0;
        let mut c = Chart::new("history", "date", "bias (deg/h)");
        c.x_axis = XAxis::TimeMs;
        c.x_scale = Scale::Log10; // not consulted on a time axis
        c.series.push(line(
            "unit 7",
            Style::Markers,
            &[(t0, 0.01), (t0 + 3.0 * 86_400_000.0, 0.012)],
        ));
        let svg = c.to_svg();
        assert!(svg.contains(">2026-12-03</text>"), "{svg}");
        assert!(svg.contains(">2026-12-05</text>"), "{svg}");
    }

    #[test]
    fn x_labels_do_not_overlap_on_a_narrow_chart() {
        let mut c = Chart::new("", "", "");
        c.width = 200.0;
        c.x_axis = XAxis::TimeMs;
        c.series.push(line(
            "s",
            Style::Line,
            &[(0.0, 0.0), (30.0 * 86_400_000.0, 1.0)],
        ));
        let svg = c.to_svg();
        let dates = svg.matches(">1970-").count();
        assert!((1..=2).contains(&dates), "{svg}");
        assert!(svg.contains("<title>chart</title>"), "{svg}");
    }

    #[test]
    fn a_crowded_legend_makes_the_drawing_taller() {
        let mut c = Chart::new("many", "x", "y");
        c.width = 300.0;
        c.height = 150.0;
        for i in 0..12 {
            let name = format!("series number {i}");
            c.series
                .push(line(&name, Style::Line, &[(0.0, 0.0), (1.0, f64::from(i))]));
        }
        let layout = Layout::of(&c);
        assert!(layout.frame.bottom - layout.frame.top >= 60.0);
        assert!(layout.height > 150.0);
        let svg = c.to_svg();
        let mut height = String::new();
        svg::attr(&mut height, "height", layout.height);
        assert!(svg.contains(&height), "{height} in {svg}");
        for i in 0..12 {
            assert!(svg.contains(&format!(">series number {i}</text>")));
        }
    }

    #[test]
    fn write_svg_appends_what_to_svg_returns() {
        let mut c = Chart::new("a", "b", "c");
        c.series
            .push(line("s", Style::Line, &[(0.0, 1.0), (1.0, 3.0)]));
        let mut page = String::from("<p>before</p>");
        c.write_svg(&mut page);
        assert_eq!(page, format!("<p>before</p>{}", c.to_svg()));
    }
}
