//! A chart's layout and the order of its layers: background, gridlines,
//! bands, series, then frame, ticks and text on top, so that data never
//! hides an axis and a band never hides data.

use std::borrow::Cow;

use super::legend::{text_width, Item, Legend, Swatch};
use super::range::{ranges, x_scale, Ranges};
use super::scale::{linear_ticks, log_ticks, Axis, Extent, Ticks};
use super::series::{draw, zone, Plot};
use super::svg::{attr, escape_into, num, text};
use super::time::time_ticks;
use super::{Chart, Scale, XAxis};

const TITLE_FONT: f64 = 14.0;
const LABEL_FONT: f64 = 12.0;
const TICK_FONT: f64 = 11.0;
const TICK_LEN: f64 = 5.0;
/// Around the drawing, px.
const MARGIN: f64 = 8.0;
/// Between a tick and its label, px.
const TICK_GAP: f64 = 3.0;
/// The plot is never made lower than this to fit the legend: the drawing
/// grows instead.
const MIN_PLOT_H: f64 = 60.0;
/// Horizontal room between two x labels, px.
const LABEL_ROOM: f64 = 10.0;
/// Log gridlines at 2…9 are drawn only when a decade is at least this
/// tall or wide, px: closer, they would grey the plot over.
const MINOR_DECADE_PX: f64 = 40.0;

const AXIS_COLOUR: &str = "#555";
const TEXT_COLOUR: &str = "#222";
const MAJOR_GRID: &str = "#ddd";
const MINOR_GRID: &str = "#eee";

/// The plot area, px.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Frame {
    pub left: f64,
    pub top: f64,
    pub right: f64,
    pub bottom: f64,
}

struct Axes {
    x: Axis,
    y: Axis,
    x_ticks: Ticks,
    y_ticks: Ticks,
}

pub(super) struct Layout<'a> {
    pub width: f64,
    pub height: f64,
    pub frame: Frame,
    /// None when there is nothing to draw.
    axes: Option<Axes>,
    /// Per band: off the y range, so not drawn.
    off_scale: Vec<bool>,
    legend: Legend<'a>,
}

fn sane(v: f64, default: f64, min: f64) -> f64 {
    if v.is_finite() {
        v.clamp(min, 10_000.0)
    } else {
        default
    }
}

fn ticks(scale: Scale, time: bool, e: Extent, target: usize) -> Ticks {
    if time {
        return Ticks {
            major: time_ticks(e.lo, e.hi, target),
            minor: Vec::new(),
        };
    }
    match scale {
        Scale::Linear => Ticks {
            major: linear_ticks(e.lo, e.hi, target),
            minor: Vec::new(),
        },
        Scale::Log10 => log_ticks(e.lo, e.hi, target),
    }
}

fn longest_label(t: &Ticks) -> f64 {
    let chars = t.major.iter().map(|t| t.label.chars().count()).max();
    text_width(chars.unwrap_or(0), TICK_FONT)
}

/// Drops a log axis' 2…9 gridlines when decades are too close.
fn thin_minor(t: &mut Ticks, axis: &Axis) {
    if axis.scale == Scale::Log10 && (axis.at(1.0) - axis.at(0.0)).abs() < MINOR_DECADE_PX {
        t.minor.clear();
    }
}

/// The legend: every series, then every band (one drawn off scale says
/// so in its name).
fn legend_of<'a>(chart: &'a Chart, off_scale: &[bool], width: f64) -> Legend<'a> {
    let series = chart.series.iter().enumerate().map(|(i, s)| Item {
        name: Cow::Borrowed(s.name.as_str()),
        colour: chart.series_colour(i),
        swatch: Swatch::Series(s.style),
    });
    let bands = chart.bands.iter().enumerate().map(|(i, b)| {
        let (name, swatch) = if off_scale[i] {
            let name = format!("{} (off scale)", b.name);
            (Cow::Owned(name), Swatch::BandOffScale)
        } else {
            (Cow::Borrowed(b.name.as_str()), Swatch::Band)
        };
        Item {
            name,
            colour: chart.band_colour(i),
            swatch,
        }
    });
    Legend::layout(series.chain(bands).collect(), width - 2.0 * MARGIN)
}

/// The x axis from `left` to the chart's right margin, with fewer ticks
/// until their labels stand apart; the right end leaves room for half the
/// last label.
fn x_axis_fitted(xs: Scale, time: bool, xe: Extent, left: f64, width: f64) -> (Axis, Ticks) {
    let right = width - MARGIN - 12.0;
    let guess = if time { 72.0 } else { 36.0 };
    let mut target = ((right - left) / (guess + 2.0 * LABEL_ROOM)).clamp(2.0, 10.0) as usize;
    let mut x = Axis {
        scale: xs,
        lo: xe.lo,
        hi: xe.hi,
        px_lo: left,
        px_hi: right,
    };
    let mut x_ticks = ticks(xs, time, xe, target);
    while target > 2 {
        let need = longest_label(&x_ticks) + LABEL_ROOM;
        let crowded = x_ticks
            .major
            .windows(2)
            .any(|w| x.at(w[1].at) - x.at(w[0].at) < need);
        if !crowded {
            break;
        }
        target -= 1;
        x_ticks = ticks(xs, time, xe, target);
    }
    x.px_hi = width - MARGIN.max(longest_label(&x_ticks) / 2.0 + 2.0);
    thin_minor(&mut x_ticks, &x);
    (x, x_ticks)
}

impl<'a> Layout<'a> {
    pub fn of(chart: &'a Chart) -> Layout<'a> {
        let width = sane(chart.width, Chart::DEFAULT_WIDTH, 160.0);
        let mut height = sane(chart.height, Chart::DEFAULT_HEIGHT, 120.0);
        let time = chart.x_axis == XAxis::TimeMs;
        let xs = x_scale(chart);
        let ranges = ranges(chart);
        let off_scale = ranges
            .as_ref()
            .map_or_else(|| vec![false; chart.bands.len()], |r| r.off_scale.clone());

        let legend = legend_of(chart, &off_scale, width);

        let top = MARGIN
            + 6.0
            + if chart.title.is_empty() {
                0.0
            } else {
                TITLE_FONT + 8.0
            };
        let x_title = if chart.x_label.is_empty() {
            0.0
        } else {
            8.0 + LABEL_FONT
        };
        let legend_h = if legend.height() > 0.0 {
            10.0 + legend.height()
        } else {
            0.0
        };
        let below = TICK_LEN + TICK_GAP + TICK_FONT + x_title + legend_h + MARGIN;
        let plot_h = (height - top - below).max(MIN_PLOT_H);
        height = height.max(top + plot_h + below);
        let bottom = top + plot_h;
        let y_title = if chart.y_label.is_empty() {
            0.0
        } else {
            LABEL_FONT + 8.0
        };

        let Some(Ranges { x: xe, y: ye, .. }) = ranges else {
            let frame = Frame {
                left: MARGIN + y_title + 10.0,
                top,
                right: width - MARGIN,
                bottom,
            };
            return Layout {
                width,
                height,
                frame,
                axes: None,
                off_scale,
                legend,
            };
        };

        let y_target = (plot_h / 35.0).round().clamp(2.0, 8.0) as usize;
        let mut y_ticks = ticks(chart.y_scale, false, ye, y_target);
        let left = MARGIN + y_title + longest_label(&y_ticks) + 4.0 + TICK_LEN;
        let y = Axis {
            scale: chart.y_scale,
            lo: ye.lo,
            hi: ye.hi,
            px_lo: bottom,
            px_hi: top,
        };
        thin_minor(&mut y_ticks, &y);

        let (x, x_ticks) = x_axis_fitted(xs, time, xe, left, width);
        let right = x.px_hi;

        Layout {
            width,
            height,
            frame: Frame {
                left,
                top,
                right,
                bottom,
            },
            axes: Some(Axes {
                x,
                y,
                x_ticks,
                y_ticks,
            }),
            off_scale,
            legend,
        }
    }
}

/// Appends the chart's `<svg>` element.
pub(super) fn write(chart: &Chart, out: &mut String) {
    let points: usize = chart.series.iter().map(|s| s.points.len()).sum();
    out.reserve(3000 + 26 * points);
    let layout = Layout::of(chart);
    let Layout {
        width,
        height,
        frame: f,
        ..
    } = layout;

    out.push_str("<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 ");
    num(out, width);
    out.push(' ');
    num(out, height);
    out.push('"');
    attr(out, "width", width);
    attr(out, "height", height);
    out.push_str(" role=\"img\" font-family=\"sans-serif\">\n<title>");
    let name = [&chart.title, &chart.y_label, &chart.x_label]
        .into_iter()
        .find(|s| !s.is_empty());
    escape_into(out, name.map_or("chart", |s| s.as_str()));
    out.push_str("</title>\n<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n");

    match &layout.axes {
        Some(axes) => data_layers(out, chart, &f, axes, &layout.off_scale),
        None => {
            frame_rect(out, &f);
            text(
                out,
                (f.left + f.right) / 2.0,
                (f.top + f.bottom) / 2.0 + 4.0,
                " font-size=\"12\" fill=\"#777\" text-anchor=\"middle\"",
                "no data",
            );
        }
    }

    let mut below = f.bottom + TICK_LEN + TICK_GAP + TICK_FONT;
    if !chart.x_label.is_empty() {
        below += 8.0 + LABEL_FONT;
        text(
            out,
            (f.left + f.right) / 2.0,
            below - 0.2 * LABEL_FONT,
            " font-size=\"12\" fill=\"#222\" text-anchor=\"middle\"",
            &chart.x_label,
        );
    }
    if !chart.y_label.is_empty() {
        let (x, y) = (MARGIN + 0.8 * LABEL_FONT, (f.top + f.bottom) / 2.0);
        out.push_str("<text");
        attr(out, "x", x);
        attr(out, "y", y);
        out.push_str(" transform=\"rotate(-90 ");
        num(out, x);
        out.push(' ');
        num(out, y);
        out.push_str(")\" font-size=\"12\" fill=\"#222\" text-anchor=\"middle\">");
        escape_into(out, &chart.y_label);
        out.push_str("</text>\n");
    }
    if !chart.title.is_empty() {
        text(
            out,
            (f.left + f.right) / 2.0,
            MARGIN + 0.8 * TITLE_FONT,
            " font-size=\"14\" font-weight=\"bold\" fill=\"#222\" text-anchor=\"middle\"",
            &chart.title,
        );
    }
    layout.legend.write(out, MARGIN, below + 10.0);
    out.push_str("</svg>\n");
}

fn frame_rect(out: &mut String, f: &Frame) {
    out.push_str("<rect");
    attr(out, "x", f.left);
    attr(out, "y", f.top);
    attr(out, "width", f.right - f.left);
    attr(out, "height", f.bottom - f.top);
    out.push_str(" fill=\"none\" stroke=\"");
    out.push_str(AXIS_COLOUR);
    out.push_str("\" stroke-width=\"1\"/>\n");
}

/// One `<path>` of gridlines: vertical ones at `xs`, horizontal at `ys`
/// (pixels), in `colour`.
fn grid<X, Y>(out: &mut String, f: &Frame, xs: X, ys: Y, colour: &str)
where
    X: Iterator<Item = f64>,
    Y: Iterator<Item = f64>,
{
    let mut started = false;
    let mut start = |out: &mut String| {
        if !started {
            out.push_str("<path d=\"");
            started = true;
        }
    };
    for x in xs {
        start(out);
        out.push('M');
        num(out, x);
        out.push(' ');
        num(out, f.top);
        out.push('V');
        num(out, f.bottom);
    }
    for y in ys {
        start(out);
        out.push('M');
        num(out, f.left);
        out.push(' ');
        num(out, y);
        out.push('H');
        num(out, f.right);
    }
    if started {
        out.push_str("\" fill=\"none\" stroke=\"");
        out.push_str(colour);
        out.push_str("\" stroke-width=\"1\"/>\n");
    }
}

fn data_layers(out: &mut String, chart: &Chart, f: &Frame, a: &Axes, off_scale: &[bool]) {
    grid(
        out,
        f,
        a.x_ticks.minor.iter().map(|&s| a.x.at(s)),
        a.y_ticks.minor.iter().map(|&s| a.y.at(s)),
        MINOR_GRID,
    );
    grid(
        out,
        f,
        a.x_ticks.major.iter().map(|t| a.x.at(t.at)),
        a.y_ticks.major.iter().map(|t| a.y.at(t.at)),
        MAJOR_GRID,
    );
    let plot = Plot { x: &a.x, y: &a.y };
    for (i, b) in chart.bands.iter().enumerate() {
        if !b.lo.is_nan() && !b.hi.is_nan() && !off_scale[i] {
            zone(out, &plot, b, chart.band_colour(i));
        }
    }
    for (i, s) in chart.series.iter().enumerate() {
        draw(out, &plot, s, chart.series_colour(i));
    }
    frame_rect(out, f);

    out.push_str("<path d=\"");
    for t in &a.x_ticks.major {
        out.push('M');
        num(out, a.x.at(t.at));
        out.push(' ');
        num(out, f.bottom);
        out.push('v');
        num(out, TICK_LEN);
    }
    for t in &a.y_ticks.major {
        out.push('M');
        num(out, f.left);
        out.push(' ');
        num(out, a.y.at(t.at));
        out.push('h');
        num(out, -TICK_LEN);
    }
    out.push_str("\" stroke=\"");
    out.push_str(AXIS_COLOUR);
    out.push_str("\" stroke-width=\"1\"/>\n");

    out.push_str("<g font-size=\"11\" fill=\"");
    out.push_str(TEXT_COLOUR);
    out.push_str("\" text-anchor=\"middle\">\n");
    let y = f.bottom + TICK_LEN + TICK_GAP + 0.8 * TICK_FONT;
    for t in &a.x_ticks.major {
        text(out, a.x.at(t.at), y, "", &t.label);
    }
    out.push_str("</g>\n<g font-size=\"11\" fill=\"");
    out.push_str(TEXT_COLOUR);
    out.push_str("\" text-anchor=\"end\">\n");
    let x = f.left - TICK_LEN - 4.0;
    for t in &a.y_ticks.major {
        text(out, x, a.y.at(t.at) + 0.35 * TICK_FONT, "", &t.label);
    }
    out.push_str("</g>\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::{Point, Series, Style};

    /// A σ falling from 1 to 2e-4 on a log axis: a major tick at every
    /// decade, labelled, a decade's height apart, the data where its
    /// value says.
    #[test]
    fn log_y_ticks_sit_at_decades_a_decade_apart() {
        let mut c = Chart::new("σ", "time (min)", "1σ (deg/h)");
        c.y_scale = Scale::Log10;
        c.series.push(Series::new(
            "s",
            Style::Line,
            vec![Point::new(0.0, 1.0), Point::new(10.0, 2e-4)],
        ));
        let layout = Layout::of(&c);
        let a = layout.axes.as_ref().unwrap();
        let labels: Vec<&str> = a.y_ticks.major.iter().map(|t| t.label.as_str()).collect();
        assert_eq!(labels, ["1e-3", "0.01", "0.1", "1"]);
        let px: Vec<f64> = a.y_ticks.major.iter().map(|t| a.y.at(t.at)).collect();
        let decade = px[0] - px[1];
        assert!(decade > 30.0, "{px:?}");
        for w in px.windows(2) {
            assert!((w[0] - w[1] - decade).abs() < 1e-9, "{px:?}");
        }
        // 2e-4 lies log10(5) of a decade below the 1e-3 tick, 1 on its tick.
        let below = a.y.px(2e-4) - px[0];
        assert!((below - 5f64.log10() * decade).abs() < 1e-9);
        assert!((a.y.px(1.0) - px[3]).abs() < 1e-9);
        // The 2…9 gridlines of each decade, and the data inside the frame.
        assert!(a.y_ticks.minor.len() >= 3 * 8, "{:?}", a.y_ticks.minor);
        let f = layout.frame;
        assert!(a.y.px(2e-4) < f.bottom && a.y.px(1.0) > f.top);
    }
}
