//! The run page's plots: the convergence of every parameter, a pair of
//! charts per family (estimate ± σ against time, the seed paper's Fig. 3,
//! and σ against time on a log axis) and the post-fit velocity residual of
//! every dwell.

use maud::{html, Markup, PreEscaped};

use super::format;
use crate::plot::{Chart, Point, Scale, Series, Style, YRange};
use sinscal_core::calib::result::Convergence;
use sinscal_core::calib::{CalibrationResult, ParameterEstimate};
use sinscal_core::model::{Group, PARAMETERS};

/// Most points drawn per series: a stored history has up to 500.
const MAX_POINTS: usize = 300;

fn family_title(g: Group) -> &'static str {
    match g {
        Group::GyroBias => "Gyro bias",
        Group::GyroScale => "Gyro scale factor",
        Group::GyroMisalign => "Gyro misalignment",
        Group::AccelBias => "Accelerometer bias",
        Group::AccelScale => "Accelerometer scale factor",
        Group::AccelMisalign => "Accelerometer misalignment",
        Group::AccelQuad => "Accelerometer quadratic term",
    }
}

/// A chart's width, px: two side by side fill a 1280 px window at their
/// drawn size, so their 11 px text is not scaled down (`.charts.pairs`).
const PAIR_WIDTH: f64 = 560.0;
const PAIR_HEIGHT: f64 = 300.0;

/// The estimate chart's y axis covers each history from where its σ has
/// come within this factor of its last: the swings while the filter
/// starts from its prior run off the plot, and the final value ± σ stays
/// readable.
const SETTLED: f64 = 3.0;

/// One column of the convergence history (time in minutes, estimate ± σ)
/// and the result's final figure for it.
struct Column<'a> {
    name: &'a str,
    points: Vec<Point>,
    result: Option<&'a ParameterEstimate>,
}

/// The history of `name`, decimated to [`MAX_POINTS`]; None when the
/// history has no such column.
fn column<'a>(
    c: &Convergence,
    name: &'a str,
    result: Option<&'a ParameterEstimate>,
) -> Option<Column<'a>> {
    let j = c.names.iter().position(|n| n == name)?;
    let step = c.t.len().div_ceil(MAX_POINTS).max(1);
    let points = (0..c.t.len())
        .step_by(step)
        .filter_map(|i| {
            let v = *c.value.get(i)?.get(j)?;
            let s = *c.sigma.get(i)?.get(j)?;
            Some(Point::with_sigma(c.t[i] / 60.0, f64::from(v), f64::from(s)))
        })
        .collect();
    Some(Column {
        name,
        points,
        result,
    })
}

/// The column's points with their σ kept only once it has settled (see
/// [`SETTLED`]): before, the band would cover the plot and hide the lines.
fn settled(c: &Column) -> Vec<Point> {
    let usable = |p: &&Point| p.y.is_finite() && p.sigma.is_some_and(f64::is_finite);
    let last = c.points.iter().rev().find(usable).and_then(|p| p.sigma);
    c.points
        .iter()
        .map(|p| Point {
            sigma: p
                .sigma
                .filter(|&s| last.is_some_and(|l| s.is_finite() && s <= SETTLED * l)),
            ..*p
        })
        .collect()
}

/// The span of the estimates ± σ that have settled; None when none has.
fn settled_span(series: &[Series]) -> Option<(f64, f64)> {
    let ends = series
        .iter()
        .flat_map(|s| &s.points)
        .filter(|p| p.y.is_finite())
        .filter_map(|p| Some((p.y - p.sigma?, p.y + p.sigma?)));
    ends.reduce(|(lo, hi), (a, b)| (lo.min(a), hi.max(b)))
}

/// Each estimate against time, ± σ once settled, its y axis scaled to
/// where they settle; the legend gives the result's value ± σ.
fn estimate_chart(title: &str, unit: &str, columns: &[Column]) -> Chart {
    let mut chart = Chart::new(
        format!("{title}: estimate ± 1σ"),
        "time (min)",
        format!("estimate ({unit})"),
    );
    (chart.width, chart.height) = (PAIR_WIDTH, PAIR_HEIGHT);
    for c in columns {
        let name = match c.result {
            Some(e) => format!(
                "{} = {} ± {} {unit}",
                c.name,
                format::sig_to(e.value, e.sigma),
                format::sig(e.sigma, 2)
            ),
            None => c.name.to_string(),
        };
        chart
            .series
            .push(Series::new(name, Style::LineWithBand, settled(c)));
    }
    if let Some((lo, hi)) = settled_span(&chart.series) {
        chart.y_range = YRange::Fixed { lo, hi };
    }
    chart
}

/// Each σ over the run on a log axis, where the prior's σ and the final
/// one, decades apart, are both read; the legend gives the final σ.
fn sigma_chart(title: &str, unit: &str, columns: &[Column]) -> Chart {
    let mut chart = Chart::new(
        format!("{title}: 1σ"),
        "time (min)",
        format!("1σ ({unit}, log scale)"),
    );
    (chart.width, chart.height) = (PAIR_WIDTH, PAIR_HEIGHT);
    chart.y_scale = Scale::Log10;
    for c in columns {
        let name = match c.result {
            Some(e) => format!("{} final σ {} {unit}", c.name, format::sig(e.sigma, 2)),
            None => c.name.to_string(),
        };
        let points = c
            .points
            .iter()
            .filter_map(|p| Some(Point::new(p.x, p.sigma?)))
            .collect();
        chart.series.push(Series::new(name, Style::Line, points));
    }
    chart
}

/// A family's (or an effect's) two charts, side by side.
fn chart_pair(svg: &mut String, title: &str, unit: &str, columns: &[Column]) {
    svg.push_str("<figure class=\"estimate\">");
    estimate_chart(title, unit, columns).write_svg(svg);
    svg.push_str("</figure><figure class=\"sigma\">");
    sigma_chart(title, unit, columns).write_svg(svg);
    svg.push_str("</figure>");
}

pub fn convergence_charts(r: &CalibrationResult) -> Markup {
    let c = &r.convergence;
    if c.t.is_empty() {
        return html! { p.muted { "This result has no convergence history." } };
    }
    let mut svg = String::new();
    for g in Group::ALL {
        let columns: Vec<Column> = g
            .range()
            .filter_map(|i| {
                let name = PARAMETERS[i].name;
                column(c, name, r.parameters.get(name))
            })
            .collect();
        chart_pair(
            &mut svg,
            family_title(g),
            PARAMETERS[g.first()].unit,
            &columns,
        );
    }
    // Effect parameters, a pair each (their units differ).
    for (name, e) in &r.effects {
        if let Some(col) = column(c, name, Some(e)) {
            chart_pair(&mut svg, name, &e.unit, &[col]);
        }
    }
    html! {
        p.muted {
            "Left: each estimate, with its ± 1σ band from where σ has come within "
            (SETTLED) "× of its final value; the axis is scaled to that stretch (the first swings run off the plot) and the legend gives the result. "
            "Right: σ on a log axis, so the prior and the final σ are both read."
        }
        div.charts.pairs #convergence { (PreEscaped(svg)) }
    }
}

/// RMS of the zero-velocity innovations of each dwell, east, north, up, in
/// mm/s: a dwell standing out is where the model misses something.
pub fn residual_chart(r: &CalibrationResult) -> Markup {
    if r.dwell_residuals.is_empty() {
        return html! { p.muted { "No dwell residuals in this result." } };
    }
    let mut chart = Chart::new(
        "Velocity residual per dwell",
        "dwell",
        "RMS residual (mm/s)",
    );
    chart.width = 900.0;
    for (axis, name) in ["east", "north", "up"].iter().enumerate() {
        chart.series.push(Series {
            name: (*name).to_string(),
            style: Style::Markers,
            colour: None,
            points: r
                .dwell_residuals
                .iter()
                .map(|d| Point {
                    x: d.dwell as f64,
                    y: d.rms_mps[axis] * 1e3,
                    sigma: None,
                })
                .collect(),
        });
    }
    html! { figure #residuals { (PreEscaped(chart.to_svg())) } }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 100 minutes of gyro_bias_x: σ falling from 1 deg/h to a 0.0002
    /// floor, the estimate swinging by ±3σ at first and settling into a
    /// ±0.001 scatter around 0.0005.
    fn history() -> Convergence {
        let sigma = |i: usize| (-(i as f64) / 5.0).exp().max(0.0002);
        let value = |i: usize| {
            let k = i as f64;
            0.0005 + 0.001 * k.sin() + 3.0 * sigma(i) * k.cos()
        };
        Convergence {
            names: vec!["gyro_bias_x".into()],
            t: (0..100).map(|i| i as f64 * 60.0).collect(),
            value: (0..100).map(|i| vec![value(i) as f32]).collect(),
            sigma: (0..100).map(|i| vec![sigma(i) as f32]).collect(),
        }
    }

    fn final_estimate() -> ParameterEstimate {
        ParameterEstimate {
            value: 0.0005,
            sigma: 0.0002,
            unit: "deg/h".into(),
        }
    }

    #[test]
    fn the_estimate_chart_is_scaled_to_where_the_history_settles() {
        let h = history();
        let e = final_estimate();
        let col = column(&h, "gyro_bias_x", Some(&e)).unwrap();
        // The settled stretch: the last 40 minutes, σ at its floor.
        let settled = &col.points[60..];
        let lo = settled
            .iter()
            .map(|p| p.y - 0.0002)
            .fold(f64::MAX, f64::min);
        let hi = settled
            .iter()
            .map(|p| p.y + 0.0002)
            .fold(f64::MIN, f64::max);
        let chart = estimate_chart("Gyro bias", "deg/h", &[col]);
        let (a, b) = chart.shown_y_range().unwrap();
        assert!(hi - lo >= (b - a) / 3.0, "data {lo} … {hi} on {a} … {b}");
        assert!(b < 0.01, "the first swings are off the plot: {b}");
        let svg = chart.to_svg();
        assert!(
            svg.contains(">gyro_bias_x = 0.00050 ± 0.00020 deg/h</text>"),
            "{svg}"
        );
    }

    #[test]
    fn the_sigma_chart_reads_every_decade_to_the_final_sigma() {
        let h = history();
        let e = final_estimate();
        let col = column(&h, "gyro_bias_x", Some(&e)).unwrap();
        let chart = sigma_chart("Gyro bias", "deg/h", &[col]);
        assert_eq!(chart.y_scale, Scale::Log10);
        let (a, b) = chart.shown_y_range().unwrap();
        assert!(a <= 0.0002 && b >= 1.0, "{a} … {b}");
        // σ spans 3.7 decades, the whole axis in log space.
        assert!((1.0f64 / 0.0002).log10() >= (b / a).log10() / 3.0);
        let svg = chart.to_svg();
        for label in [">1e-3</text>", ">0.01</text>", ">0.1</text>", ">1</text>"] {
            assert!(svg.contains(label), "{label} in {svg}");
        }
        assert!(
            svg.contains(">gyro_bias_x final σ 0.00020 deg/h</text>"),
            "{svg}"
        );
    }

    #[test]
    fn every_family_gets_an_estimate_and_a_sigma_chart() {
        let mut h = history();
        h.names = PARAMETERS.iter().map(|p| p.name.to_string()).collect();
        for row in h.value.iter_mut().chain(h.sigma.iter_mut()) {
            *row = vec![row[0]; PARAMETERS.len()];
        }
        let mut columns = 0;
        let mut svg = String::new();
        for g in Group::ALL {
            let cols: Vec<Column> = g
                .range()
                .filter_map(|i| column(&h, PARAMETERS[i].name, None))
                .collect();
            columns += cols.len();
            chart_pair(&mut svg, family_title(g), PARAMETERS[g.first()].unit, &cols);
        }
        assert_eq!(columns, 24);
        assert_eq!(svg.matches("<figure class=\"estimate\"><svg").count(), 7);
        assert_eq!(svg.matches("<figure class=\"sigma\"><svg").count(), 7);
    }
}
