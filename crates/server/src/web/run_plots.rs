//! The run page's plots: the convergence of every parameter (estimate ± σ
//! against time, one chart per family, the seed paper's Fig. 3) and the
//! post-fit velocity residual of every dwell.

use maud::{html, Markup, PreEscaped};

use crate::plot::{Chart, Point, Series, Style};
use sinscal_core::calib::CalibrationResult;
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

/// One series per named column of the convergence history, time in
/// minutes.
fn series_of(r: &CalibrationResult, name: &str) -> Option<Series> {
    let c = &r.convergence;
    let j = c.names.iter().position(|n| n == name)?;
    let step = c.t.len().div_ceil(MAX_POINTS).max(1);
    let points = (0..c.t.len())
        .step_by(step)
        .filter_map(|i| {
            let v = *c.value.get(i)?.get(j)?;
            let s = *c.sigma.get(i)?.get(j)?;
            Some(Point {
                x: c.t[i] / 60.0,
                y: f64::from(v),
                sigma: Some(f64::from(s)),
            })
        })
        .collect();
    Some(Series {
        name: name.to_string(),
        style: Style::LineWithBand,
        colour: None,
        points,
    })
}

pub fn convergence_charts(r: &CalibrationResult) -> Markup {
    if r.convergence.t.is_empty() {
        return html! { p.muted { "This result has no convergence history." } };
    }
    let mut svg = String::new();
    for g in Group::ALL {
        let unit = PARAMETERS[g.first()].unit;
        let mut chart = Chart::new(family_title(g), "time (min)", format!("estimate ({unit})"));
        chart.series = g
            .range()
            .filter_map(|i| series_of(r, PARAMETERS[i].name))
            .collect();
        svg.push_str("<figure>");
        chart.write_svg(&mut svg);
        svg.push_str("</figure>");
    }
    // Effect parameters, one chart each (their units differ).
    for (name, e) in &r.effects {
        if let Some(s) = series_of(r, name) {
            let mut chart = Chart::new(name, "time (min)", format!("estimate ({})", e.unit));
            chart.series.push(s);
            svg.push_str("<figure>");
            chart.write_svg(&mut svg);
            svg.push_str("</figure>");
        }
    }
    html! { div.charts #convergence { (PreEscaped(svg)) } }
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
