//! The unit page's two views of its runs: the repeatability table (each
//! run's model and values, mean, standard deviation, range, largest change between
//! consecutive runs, flags) and one trend chart per parameter (the runs
//! against their dates, their mean and spread, the product's limits).

use std::collections::BTreeMap;

use maud::{html, Markup, PreEscaped};

use super::format;
use crate::plot::{Band, Chart, Point, Series, Style, XAxis, YRange};
use crate::store::{ParamSpread, RunId};
use sinscal_core::accept::{LimitKind, ParameterLimits, ProductLimits, VerdictStatus};
use sinscal_core::calib::{ErrorModel, ParameterEstimate};
use sinscal_core::model::{Group, PARAMETERS};

/// Runs shown as columns unless all are asked for.
const DEFAULT_COLUMNS: usize = 10;

/// One calibrated run as the unit page reads it.
pub struct UnitRun {
    pub run_id: RunId,
    pub run_time: i64,
    pub parameters: BTreeMap<String, ParameterEstimate>,
    /// The model its result was made with (`None`: not known).
    pub model: Option<ErrorModel>,
    pub verdict: Option<VerdictStatus>,
    pub model_adequate: Option<bool>,
}

/// Sample standard deviation (n − 1), as the acceptance rules use.
fn std_dev(s: &ParamSpread) -> Option<f64> {
    (s.n >= 2).then(|| (s.sum_sq / (s.n - 1) as f64).sqrt())
}

pub fn repeatability_table(
    serial: &str,
    runs: &[UnitRun],
    spread: &[ParamSpread],
    limits: Option<&ProductLimits>,
    all_columns: bool,
) -> Markup {
    let shown = if all_columns {
        runs
    } else {
        &runs[runs.len().saturating_sub(DEFAULT_COLUMNS)..]
    };
    let by_name: BTreeMap<&str, &ParamSpread> =
        spread.iter().map(|s| (s.name.as_str(), s)).collect();
    html! {
        @if runs.len() < 2 {
            p.muted { "Repeatability needs two calibrated runs; this unit has " (runs.len()) "." }
        }
        @if shown.len() < runs.len() {
            p.muted {
                "The last " (shown.len()) " of " (runs.len()) " runs are shown as columns; the statistics cover all. "
                a href={ "/units/" (serial) "?columns=all#repeatability" } { "Show every run" }
            }
        }
        div.scroll {
            table #repeatability {
                thead { tr {
                    th { "Parameter" } th { "Unit" }
                    @for r in shown { th.num title=(r.run_id) { (format::date(r.run_time)) } }
                    th.num { "Mean" } th.num { "Std" } th.num { "Range" } th.num { "Largest change" }
                    th.num { "Limit" } th { "Flags" }
                }
                // The model each run's result was made with, under its date.
                tr #run-models {
                    td { "model" } td {}
                    @for r in shown { td.num { (format::model(r.model.as_ref())) } }
                    td colspan="6" { @if mixed_models(runs) { span.unverified { "runs of different models" } } }
                } }
                tbody {
                    @for (i, p) in PARAMETERS.iter().enumerate() {
                        @let s = by_name.get(p.name);
                        @let std = s.and_then(|s| std_dev(s));
                        @let limit = limits.and_then(|l| l.of(i).get(LimitKind::MaxRepeatability));
                        @let over = matches!((std, limit), (Some(sd), Some(l)) if sd > l);
                        tr class=[over.then_some("fail")] {
                            td { (p.name) } td { (p.unit) }
                            @for r in shown {
                                td.num { (r.parameters.get(p.name).map_or("—".into(), |e| format::sig(e.value, 5))) }
                            }
                            td.num { (s.map_or("—".into(), |s| format::sig(s.mean, 5))) }
                            td.num { (std.map_or("—".into(), |v| format::sig(v, 3))) }
                            td.num { (s.map_or("—".into(), |s| format::sig(s.max - s.min, 3))) }
                            td.num { (s.and_then(|s| s.max_change).map_or("—".into(), |v| format::sig(v, 3))) }
                            td.num { (limit.map_or("—".into(), |v| format::sig(v, 3))) }
                            td { @if over { span.fail { "spread over limit" } } }
                        }
                    }
                }
            }
        }
    }
}

/// Whether the runs' results were made with more than one model (a result
/// of an unknown model counts as one of its own).
fn mixed_models(runs: &[UnitRun]) -> bool {
    runs.windows(2).any(|w| w[0].model != w[1].model)
}

/// Paints that keep their meaning on every trend chart: the product's
/// limits warm (red for |value|, orange for repeatability), the runs' own
/// statistics neutral.
const LIMIT_COLOUR: &str = "#e15759";
const REPEATABILITY_LIMIT_COLOUR: &str = "#f28e2b";
const SPREAD_COLOUR: &str = "#bab0ac";
const MEAN_COLOUR: &str = "#555";

/// Per parameter, each run's estimate ± σ against its date, the runs' mean
/// and spread, and the product's limits; grouped by family as SPEC §2
/// lists them. The y axis is scaled to the runs, not to the limits: a
/// tolerance far wider than the scatter is named "off scale" instead of
/// flattening every run into one row.
pub fn trend_charts(
    runs: &[UnitRun],
    spread: &[ParamSpread],
    limits: Option<&ProductLimits>,
) -> Markup {
    let by_name: BTreeMap<&str, &ParamSpread> =
        spread.iter().map(|s| (s.name.as_str(), s)).collect();
    let mut svg = String::with_capacity(runs.len() * 24 * 160);
    for group in Group::ALL {
        for i in group.range() {
            let name = PARAMETERS[i].name;
            let chart = trend_chart(
                i,
                run_points(runs, name),
                by_name.get(name).copied(),
                limits.map(|l| l.of(i)),
            );
            svg.push_str("<figure>");
            chart.write_svg(&mut svg);
            svg.push_str("</figure>");
        }
    }
    html! { div.charts #trends { (PreEscaped(svg)) } }
}

/// Each run's estimate of `name` ± σ at the run's date.
fn run_points(runs: &[UnitRun], name: &str) -> Vec<Point> {
    runs.iter()
        .filter_map(|r| {
            let e = r.parameters.get(name)?;
            Some(Point::with_sigma(r.run_time as f64, e.value, e.sigma))
        })
        .collect()
}

/// Parameter `i`'s trend chart over `points` (date, estimate ± σ).
fn trend_chart(
    i: usize,
    points: Vec<Point>,
    spread: Option<&ParamSpread>,
    limits: Option<&ParameterLimits>,
) -> Chart {
    let p = &PARAMETERS[i];
    let mut chart = Chart::new(p.name, "run date", format!("estimate ({})", p.unit));
    chart.x_axis = XAxis::TimeMs;
    chart.y_range = YRange::Data;
    chart.width = 460.0;
    chart.height = 300.0;
    let dates = date_span(&points);
    chart.series.push(Series::new(
        format!("estimate ± 1σ ({})", p.unit),
        Style::MarkersWithErrorBars,
        points,
    ));
    if let (Some(s), Some((first, last))) = (spread, dates) {
        runs_mean_and_spread(&mut chart, s, p.unit, (first, last));
    }
    if let Some(l) = limits {
        product_limits(&mut chart, l, spread.map(|s| s.mean), p.unit);
    }
    chart
}

/// The first and last date of the points.
fn date_span(points: &[Point]) -> Option<(f64, f64)> {
    let first = points.iter().map(|p| p.x).reduce(f64::min)?;
    let last = points.iter().map(|p| p.x).reduce(f64::max)?;
    Some((first, last))
}

/// The mean of the runs as a line over their dates, and mean ± 1 standard
/// deviation (the repeatability the table states) as a band.
fn runs_mean_and_spread(chart: &mut Chart, s: &ParamSpread, unit: &str, (first, last): (f64, f64)) {
    let Some(sd) = std_dev(s) else { return };
    let mut mean = Series::new(
        format!("mean of runs {} {unit}", format::sig_to(s.mean, sd)),
        Style::Line,
        vec![Point::new(first, s.mean), Point::new(last, s.mean)],
    );
    mean.colour = Some(MEAN_COLOUR.into());
    chart.series.push(mean);
    let mut band = Band::new(
        format!("mean ± 1 std dev ({} {unit})", format::sig(sd, 2)),
        s.mean - sd,
        s.mean + sd,
    );
    band.colour = Some(SPREAD_COLOUR.into());
    chart.bands.push(band);
}

/// The product type's bounds on |value| and, around the runs' mean, on
/// their standard deviation; each named with its unit.
fn product_limits(chart: &mut Chart, l: &ParameterLimits, mean: Option<f64>, unit: &str) {
    if let (Some(r), Some(m)) = (l.get(LimitKind::MaxRepeatability), mean) {
        let mut band = Band::new(
            format!(
                "repeatability limit: std dev ≤ {} {unit}",
                format::sig(r, 3)
            ),
            m - r,
            m + r,
        );
        band.colour = Some(REPEATABILITY_LIMIT_COLOUR.into());
        chart.bands.push(band);
    }
    if let Some(v) = l.get(LimitKind::MaxAbsValue) {
        let mut band = Band::new(format!("limit ±{} {unit}", format::sig(v, 3)), -v, v);
        band.colour = Some(LIMIT_COLOUR.into());
        chart.bands.push(band);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DAY_MS: f64 = 86_400_000.0;

    /// Five runs scattered ±0.001 deg/h around 0.0005 deg/h, σ 0.0002,
    /// and the spread the store would give for them.
    fn scatter() -> (Vec<Point>, ParamSpread) {
        let values = [0.0015, -0.0005, 0.001, 0.0, 0.0005];
        let points: Vec<Point> = values
            .iter()
            .enumerate()
            .map(|(k, &v)| Point::with_sigma(1.8e12 + k as f64 * DAY_MS, v, 0.0002))
            .collect();
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let spread = ParamSpread {
            name: "gyro_bias_x".into(),
            n: values.len() as i64,
            mean,
            sum_sq: values.iter().map(|v| (v - mean).powi(2)).sum(),
            min: -0.0005,
            max: 0.0015,
            max_change: Some(0.002),
        };
        (points, spread)
    }

    fn limits(kind_value: &[(LimitKind, f64)]) -> ProductLimits {
        let mut l = ProductLimits::default();
        for &(kind, v) in kind_value {
            l.set("gyro_bias_x", kind, v).unwrap();
        }
        l
    }

    #[test]
    fn a_trend_is_scaled_to_the_runs_and_names_the_limit_off_scale() {
        let (points, spread) = scatter();
        let l = limits(&[(LimitKind::MaxAbsValue, 0.1)]);
        let chart = trend_chart(0, points, Some(&spread), Some(l.of(0)));
        let (lo, hi) = chart.shown_y_range().unwrap();
        // The runs with their ±σ span −0.0007 … 0.0017.
        assert!(0.0024 >= (hi - lo) / 3.0, "axis {lo} … {hi}");
        assert!(lo <= -0.0007 && hi >= 0.0017, "axis {lo} … {hi}");
        let svg = chart.to_svg();
        for legend in [
            "estimate ± 1σ (deg/h)",
            "mean of runs 0.00050 deg/h",
            "mean ± 1 std dev (0.00079 deg/h)",
            "limit ±0.100 deg/h (off scale)",
        ] {
            assert!(
                svg.contains(&format!(">{legend}</text>")),
                "{legend} in {svg}"
            );
        }
    }

    #[test]
    fn a_limit_near_the_runs_is_drawn_with_its_edge() {
        let (points, spread) = scatter();
        let l = limits(&[
            (LimitKind::MaxAbsValue, 0.002),
            (LimitKind::MaxRepeatability, 0.001),
        ]);
        let chart = trend_chart(0, points, Some(&spread), Some(l.of(0)));
        let (lo, hi) = chart.shown_y_range().unwrap();
        assert!(0.0024 >= (hi - lo) / 3.0, "axis {lo} … {hi}");
        assert!(hi > 0.002, "the upper limit is in view: {hi}");
        let svg = chart.to_svg();
        assert!(svg.contains(">limit ±0.00200 deg/h</text>"), "{svg}");
        assert!(
            svg.contains(">repeatability limit: std dev ≤ 0.00100 deg/h</text>"),
            "{svg}"
        );
        // The limit's edge in view is drawn as a line across the plot.
        assert!(
            svg.contains("stroke=\"#e15759\" stroke-width=\"1\""),
            "{svg}"
        );
    }

    #[test]
    fn a_single_run_has_no_mean_or_spread() {
        let (mut points, _) = scatter();
        points.truncate(1);
        let chart = trend_chart(0, points, None, None);
        assert_eq!(chart.series.len(), 1);
        assert!(chart.bands.is_empty());
        assert!(chart.shown_y_range().is_some());
    }
}
