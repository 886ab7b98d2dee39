//! The unit page's thermal model (SPEC §3a): per parameter the runs'
//! values ± σ against their temperature, the fitted curve and its ±1σ
//! band, and the fit's check.

use maud::{html, Markup, PreEscaped};

use super::format;
use crate::plot::{Chart, Point, Series, Style};
use sinscal_core::model::PARAMETERS;
use sinscal_core::thermal::{SoakedRun, ThermalModel};

/// Points along each fitted curve.
const CURVE_POINTS: usize = 40;

pub fn thermal_section(model: &ThermalModel, runs: &[SoakedRun]) -> Markup {
    let [lo, hi] = model.range_c;
    let mut svg = String::new();
    for p in PARAMETERS.iter() {
        let Some(m) = model.parameters.get(p.name) else {
            continue;
        };
        let curve = (0..CURVE_POINTS)
            .filter_map(|k| {
                let t = lo + (hi - lo) * k as f64 / (CURVE_POINTS - 1) as f64;
                let pr = model.predict(p.name, t, false).ok()?;
                Some(Point::with_sigma(t, pr.value, pr.sigma))
            })
            .collect();
        let measured = runs
            .iter()
            .filter_map(|r| {
                let e = r.parameters.get(p.name)?;
                Some(Point::with_sigma(r.temperature_c, e.value, e.sigma))
            })
            .collect();
        let chart = thermal_chart(p.name, p.unit, m.quadratic.is_some(), curve, measured);
        svg.push_str("<figure>");
        chart.write_svg(&mut svg);
        svg.push_str("</figure>");
    }
    html! {
        p #thermal-check class=(if model.check.adequate { "" } else { "fail" }) {
            "From " (runs.len()) " runs at " (format::sig(lo, 3)) "–" (format::sig(hi, 3)) " °C: " (model.check.summary)
        }
        table #thermal {
            thead { tr { th { "Parameter" } th.num { "At 25 °C" } th.num { "1σ" } th.num { "Per °C" } th.num { "Per °C²" } th { "Unit" } } }
            tbody {
                @for p in PARAMETERS.iter() {
                    @if let Some(m) = model.parameters.get(p.name) {
                        tr {
                            td { (p.name) } td.num { (format::sig(m.value, 6)) } td.num { (format::sig(m.sigma, 2)) }
                            td.num { (m.linear.map_or("—".into(), |t| format!("{} ± {}", format::sig(t.value, 3), format::sig(t.sigma, 2)))) }
                            td.num { (m.quadratic.map_or("—".into(), |t| format!("{} ± {}", format::sig(t.value, 3), format::sig(t.sigma, 2)))) }
                            td { (m.unit) }
                        }
                    }
                }
            }
        }
        div.charts #thermal-charts { (PreEscaped(svg)) }
    }
}

/// One parameter against temperature: the fitted curve with its ±1σ band
/// and the runs with theirs, the axis spanning both.
fn thermal_chart(
    name: &str,
    unit: &str,
    quadratic: bool,
    curve: Vec<Point>,
    runs: Vec<Point>,
) -> Chart {
    let mut chart = Chart::new(name, "temperature (°C)", format!("estimate ({unit})"));
    chart.width = 460.0;
    chart.height = 240.0;
    let order = if quadratic { "quadratic" } else { "linear" };
    chart.series.push(Series::new(
        format!("{order} fit ± 1σ"),
        Style::LineWithBand,
        curve,
    ));
    chart
        .series
        .push(Series::new("runs ± 1σ", Style::MarkersWithErrorBars, runs));
    chart
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thermal_chart_spans_the_runs_and_the_curve() {
        // Three soaks at −20, 25 and 65 °C; the line through them has a
        // σ band far narrower than their scatter.
        let runs = vec![
            Point::with_sigma(-20.0, 0.0100, 0.0004),
            Point::with_sigma(25.0, 0.0130, 0.0004),
            Point::with_sigma(65.0, 0.0158, 0.0004),
        ];
        let curve = (0..CURVE_POINTS)
            .map(|k| {
                let t = -20.0 + 85.0 * k as f64 / (CURVE_POINTS - 1) as f64;
                Point::with_sigma(t, 0.0130 + 6.8e-5 * (t - 25.0), 2e-4)
            })
            .collect();
        let chart = thermal_chart("gyro_bias_x", "deg/h", false, curve, runs);
        let (lo, hi) = chart.shown_y_range().unwrap();
        let (min, max) = (0.0096, 0.0162);
        assert!(lo <= min && hi >= max, "axis {lo} … {hi}");
        assert!(max - min >= (hi - lo) / 3.0, "axis {lo} … {hi}");
        assert!(chart.to_svg().contains(">linear fit ± 1σ</text>"));
    }
}
