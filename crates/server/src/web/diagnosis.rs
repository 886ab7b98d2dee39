//! A run's diagnosis (the discrepancy workflow's latest report): the
//! verdict, the gap before and after the named effects, every step's
//! candidate table, where the misfit lies, and what the run could not see.

use axum::extract::{Path, State};
use axum::response::Html;
use maud::{html, Markup, PreEscaped};

use super::access::PageCaller;
use super::error::PageError;
use super::format;
use super::layout;
use super::run::readable_run;
use crate::api::auth::roles;
use crate::api::error::ApiError;
use crate::api::AppState;
use crate::plot::{Band, Chart, Point, Series, Style, YRange};
use sinscal_core::diagnose::{DiagnoseReport, DiagnoseStep};

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let stored = crate::api::runs::latest_report(&st, run.id).await?;
    let report: DiagnoseReport = tokio::task::spawn_blocking(move || stored.parse())
        .await
        .map_err(|e| ApiError::Internal(format!("report task: {e}")))?
        .map_err(|e| ApiError::Internal(format!("stored diagnosis of run {}: {e}", run.id)))?;
    let body = html! {
        h1 { "Diagnosis of run " a href={ "/runs/" (run.id) } { code { (format::short_id(run.id)) } } " (unit " (run.unit_serial) ")" }
        p #diagnosis-verdict { strong { "Verdict: " } (report.verdict.to_string()) }
        table #gap {
            tr { th { "" } th.num { "Gap RMS (mm/s)" } th.num { "Excess over noise (mm/s)" } th.num { "z" } }
            tr { th { "Base model" } td.num { (format::sig(report.gap_rms_before * 1e3, 3)) } td.num { (format::sig(report.gap_excess_before * 1e3, 3)) } td.num { (format::sig(report.z_before, 3)) } }
            tr { th { "With the named effects" } td.num { (format::sig(report.gap_rms_after * 1e3, 3)) } td.num { (format::sig(report.gap_excess_after * 1e3, 3)) } td.num { (format::sig(report.z_after, 3)) } }
            tr { th { "Noise floor" } td.num { (format::sig(report.noise_floor_rms * 1e3, 3)) } td {} td {} }
        }
        @if !report.named.is_empty() {
            div #adopt {
                (layout::action_button(&session, &format!("/runs/{}/adopt", run.id), "Recalibrate with it", ""))
                " Calibrates the run again with " (report.named.join(", ")) " as states of the filter; the current result is kept as an earlier one."
            }
        }
        @if !report.calibration.effects.is_empty() {
            h2 { "Named effects" }
            table #named {
                tr { th { "Parameter" } th.num { "Value" } th.num { "1σ" } th { "Unit" } }
                @for (name, e) in &report.calibration.effects {
                    tr { td { (name) } td.num { (format::sig(e.value, 4)) } td.num { (format::sig(e.sigma, 2)) } td { (e.unit) } }
                }
            }
        }
        h2 { "The gap before and after" }
        div #gap-plot { (PreEscaped(gap_charts(&report))) }
        h2 { "Steps" }
        @for (k, step) in report.steps.iter().enumerate() { (step_block(k + 1, step)) }
        @if !report.detectable.is_empty() {
            h2 { "What this run could not see" }
            p.muted { "The smallest size of each effect the workflow would have named from this run; smaller effects pass unseen." }
            table #detectable {
                tr { th { "Effect" } th { "Parameterisation" } th { "Quantity" } th.num { "Smallest named" } th { "Unit" } }
                @for d in &report.detectable {
                    tr { td { (d.effect) } td { (d.candidate) } td { (d.quantity) } td.num { (format::sig(d.size, 3)) } td { (d.unit) } }
                }
            }
        }
        @if !report.warnings.is_empty() {
            h2 { "Warnings" }
            ul { @for w in &report.warnings { li { (w) } } }
        }
    };
    Ok(Html(
        layout::page("Diagnosis", Some(&session), body).into_string(),
    ))
}

fn step_block(k: usize, s: &DiagnoseStep) -> Markup {
    html! {
        section.step {
            h3 { "Step " (k) ": model " @if s.model.is_empty() { "base-24" } @else { "base-24 + " (s.model.join(" + ")) } }
            p { "Gap " (format::sig(s.gap_rms * 1e3, 3)) " mm/s against a noise floor of " (format::sig(s.noise_floor_rms * 1e3, 3)) " mm/s (z = " (format::sig(s.z, 3)) ", "
                @if s.significant { span.fail { "significant" } } @else { span.pass { "not significant" } } "). " (s.decision) }
            p.muted { "Where the misfit lies: " (s.localisation.summary) }
            @if !s.candidates.is_empty() {
                table.candidates {
                    tr { th { "Effect" } th { "Parameterisation" } th.num { "Parameters" } th.num { "ΔBIC" } th.num { "Probability" } th { "Estimates" } }
                    @for c in &s.candidates {
                        tr class=[(s.named.as_deref() == Some(c.candidate.as_str())).then_some("flag")] {
                            td { (c.effect) } td { (c.candidate) } td.num { (c.n_params) }
                            td.num { (format::sig(c.delta_bic, 3)) } td.num { (format::sig(c.probability, 2)) }
                            td { @for p in &c.params { (p.name) " = " (format::sig(p.value, 3)) " ± " (format::sig(p.sigma, 2)) " " (p.unit) br; } }
                        }
                    }
                }
            }
        }
    }
}

/// The velocity gap at the nodes (the residual the model leaves, east,
/// north, up) before and after the named effects, behind the ±noise-floor
/// band: what the workflow set out to shrink.
fn gap_charts(report: &DiagnoseReport) -> String {
    let g = &report.series;
    let floor_mm_s = report.noise_floor_rms * 1e3;
    let mut svg = String::new();
    for (title, values) in [
        ("Gap with the base model", &g.before),
        ("Gap with the named effects", &g.after),
    ] {
        svg.push_str("<figure>");
        gap_chart(title, &g.t, values, floor_mm_s).write_svg(&mut svg);
        svg.push_str("</figure>");
    }
    svg
}

/// One gap chart, scaled to the gap itself: a noise floor far wider than
/// the gap left after the named effects must not flatten it into a line.
fn gap_chart(title: &str, t_s: &[f64], gap_enu_mps: &[[f64; 3]], floor_mm_s: f64) -> Chart {
    let mut chart = Chart::new(title, "time (s)", "velocity gap (mm/s)");
    chart.width = 900.0;
    chart.height = 280.0;
    chart.y_range = YRange::Data;
    chart
        .bands
        .push(Band::new("± noise floor", -floor_mm_s, floor_mm_s));
    for (axis, name) in ["east", "north", "up"].iter().enumerate() {
        let points = t_s
            .iter()
            .zip(gap_enu_mps)
            .map(|(&t, v)| Point::new(t, v[axis] * 1e3))
            .collect();
        chart.series.push(Series::new(*name, Style::Line, points));
    }
    chart
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gap of ±0.02 mm/s behind a noise floor of 1 mm/s.
    fn small_gap() -> (Vec<f64>, Vec<[f64; 3]>) {
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 10.0).collect();
        let gap = t
            .iter()
            .map(|&t| {
                let v = 2e-5 * (t / 40.0).sin();
                [v, -v, 0.5 * v]
            })
            .collect();
        (t, gap)
    }

    #[test]
    fn a_gap_far_below_its_noise_floor_keeps_a_third_of_the_axis() {
        let (t, gap) = small_gap();
        let chart = gap_chart("after", &t, &gap, 1.0);
        let (lo, hi) = chart.shown_y_range().unwrap();
        let (min, max) = (-0.02, 0.02);
        assert!(lo <= min && hi >= max, "axis {lo} … {hi}");
        assert!(max - min >= (hi - lo) / 3.0, "axis {lo} … {hi}");
    }

    #[test]
    fn a_gap_near_its_noise_floor_shows_the_floor() {
        let (t, gap) = small_gap();
        let chart = gap_chart("after", &t, &gap, 0.03);
        let (lo, hi) = chart.shown_y_range().unwrap();
        assert!(lo <= -0.03 && hi >= 0.03, "axis {lo} … {hi}");
        assert!(0.04 >= (hi - lo) / 3.0, "axis {lo} … {hi}");
    }
}
