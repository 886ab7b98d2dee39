//! The unit page's two views of its runs: the repeatability table (each
//! run's values, mean, standard deviation, range, largest change between
//! consecutive runs, flags) and one trend chart per parameter.

use std::collections::BTreeMap;

use maud::{html, Markup, PreEscaped};

use super::format;
use crate::plot::{Band, Chart, Point, Series, Style, XAxis};
use crate::store::{ParamSpread, RunId};
use sinscal_core::accept::{LimitKind, ProductLimits, VerdictStatus};
use sinscal_core::calib::ParameterEstimate;
use sinscal_core::model::{Group, PARAMETERS};

/// Runs shown as columns unless all are asked for.
const DEFAULT_COLUMNS: usize = 10;

/// One calibrated run as the unit page reads it.
pub struct UnitRun {
    pub run_id: RunId,
    pub run_time: i64,
    pub parameters: BTreeMap<String, ParameterEstimate>,
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

/// Per parameter, each run's estimate ± σ against its date, behind the
/// product's ±|value| limit; grouped by family as SPEC §2 lists them.
pub fn trend_charts(runs: &[UnitRun], limits: Option<&ProductLimits>) -> Markup {
    let mut svg = String::with_capacity(runs.len() * 24 * 160);
    for group in Group::ALL {
        for i in group.range() {
            let p = &PARAMETERS[i];
            let mut chart = Chart::new(p.name, "run date", format!("estimate ({})", p.unit));
            chart.x_axis = XAxis::TimeMs;
            chart.width = 460.0;
            chart.height = 240.0;
            if let Some(l) = limits.and_then(|l| l.of(i).get(LimitKind::MaxAbsValue)) {
                chart.bands.push(Band {
                    name: format!("|value| ≤ {}", format::sig(l, 3)),
                    lo: -l,
                    hi: l,
                });
            }
            chart.series.push(Series {
                name: "estimate ± 1σ".into(),
                style: Style::MarkersWithErrorBars,
                colour: None,
                points: runs
                    .iter()
                    .filter_map(|r| {
                        r.parameters.get(p.name).map(|e| Point {
                            x: r.run_time as f64,
                            y: e.value,
                            sigma: Some(e.sigma),
                        })
                    })
                    .collect(),
            });
            svg.push_str("<figure>");
            chart.write_svg(&mut svg);
            svg.push_str("</figure>");
        }
    }
    html! { div.charts #trends { (PreEscaped(svg)) } }
}
