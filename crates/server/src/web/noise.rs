//! A run's noise page: the identified coefficients, and the Allan deviation
//! of every gyro and accelerometer axis over the run's dwells (or the
//! whole of a static run), log-log, with the fitted model and its terms
//! (`noise_charts`).

use axum::extract::{Path, State};
use axum::response::Html;
use maud::{html, Markup};

use super::access::PageCaller;
use super::error::PageError;
use super::format;
use super::layout;
use super::noise_charts::allan_charts;
use super::run::readable_run;
use crate::api::auth::roles;
use crate::api::noise::analyse_noise;
use crate::api::AppState;
use sinscal_core::noise::report::Span;
use sinscal_core::noise::{Term, TermStatus};

/// A term's cell: its value and σ, "not resolved" with the bound the
/// data set, or its held value; the whole sentence on hover. A figure the
/// report lacks is said to be missing, never shown as 0.
fn term(t: &Term) -> Markup {
    let mark = if t.spoiled_by_departure { " *" } else { "" };
    let shown = match (t.status, t.value, t.sigma, t.upper_bound) {
        (TermStatus::Resolved, Some(v), Some(s), _) => {
            format!("{} ± {}", format::sig(v, 3), format::sig(s, 2))
        }
        (TermStatus::Resolved, Some(v), None, _) => format!("{} (σ not given)", format::sig(v, 3)),
        (TermStatus::NotResolved, _, _, Some(b)) => {
            format!("not resolved (< {})", format::sig(b, 2))
        }
        (TermStatus::Fixed, Some(v), _, _) => format!("{} (held)", format::sig(v, 3)),
        (TermStatus::NotResolved, _, _, None) => "not resolved".to_string(),
        _ => "—".to_string(),
    };
    let class = if t.status == TermStatus::NotResolved {
        "num muted"
    } else {
        "num"
    };
    html! { td class=(class) title=(t.text) { (shown) (mark) } }
}

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let report = analyse_noise(&st, run.id).await?;
    let (gyro, accel) = allan_charts(&report);
    let over = &report.computed_over;
    let body = html! {
        h1 { "Noise of run " a href={ "/runs/" (run.id) } { code { (format::short_id(run.id)) } } " (unit " (run.unit_serial) ")" }
        p.muted {
            "Overlapping Allan deviation over "
            @match over.span { Span::Dwells => { (over.stretches.len()) " dwells" }, Span::WholeRun => "the whole (static) run" }
            ", " (format::sig(over.seconds_used, 4)) " s of data at " (over.sample_rate_hz) " Hz; τ up to " (format::sig(over.max_tau_s, 3)) " s. "
            (report.method)
        }
        @if !report.warnings.is_empty() {
            h2 { "Where the curve departs from the noise model" }
            ul #noise-warnings { @for w in &report.warnings { li { (w) } } }
        }
        p.muted { "v ± σ: read from the curve (1-σ); not resolved (< b): the curve does not show the term, b its 95 % upper bound over the τ the data covers; v (held): held at q/√12 of the quantum found in the data; * read where the curve departs from the model. On the charts, each measured point carries its 1σ, the dashed curve is the fitted model and each dotted line one term the fit resolved or held (quantization slope −1, white noise −½, bias instability flat at 0.664·B, random walk +½)." }
        h2 { "Gyros" }
        table #gyro-noise {
            tr { th { "Axis" } th.num { "ARW (deg/√h)" } th.num { "Bias instability (deg/h)" } th.num { "Rate random walk (deg/h/√h)" } th.num { "Quantization (arcsec)" } th.num { "Quantum (arcsec)" } th.num { "Fit rms z" } }
            @for (axis, n) in report.gyro.iter() {
                tr { td { (axis) } (term(&n.arw_deg_rt_h)) (term(&n.bias_instability_deg_h))
                     (term(&n.rate_random_walk_deg_h_rt_h)) (term(&n.angle_quantization_arcsec))
                     td.num { (n.quantum_arcsec.map_or("—".into(), |q| format::sig(q, 4))) } td.num { (format::sig(n.fit_rms_z, 2)) } }
            }
        }
        div.charts.thirds #gyro-allan { (gyro) }
        h2 { "Accelerometers" }
        table #accel-noise {
            tr { th { "Axis" } th.num { "VRW (µg/√Hz)" } th.num { "Bias instability (µg)" } th.num { "Acceleration random walk (µg/√h)" } th.num { "Quantization (mm/s)" } th.num { "Quantum (m/s)" } th.num { "Fit rms z" } }
            @for (axis, n) in report.accel.iter() {
                tr { td { (axis) } (term(&n.vrw_ug_rt_hz)) (term(&n.bias_instability_ug))
                     (term(&n.acceleration_random_walk_ug_rt_h)) (term(&n.velocity_quantization_mm_s))
                     td.num { (n.quantum_mps.map_or("—".into(), |q| format::sig(q, 4))) } td.num { (format::sig(n.fit_rms_z, 2)) } }
            }
        }
        div.charts.thirds #accel-allan { (accel) }
    };
    Ok(Html(
        layout::page("Noise", Some(&session), body).into_string(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sinscal_core::noise::fit::Estimate;
    use sinscal_core::noise::term::Reach;

    fn cell(e: Estimate) -> String {
        let t = Term::from_estimate(
            &e,
            (1.0, "deg/h"),
            [0.1, 10.0],
            [0.1, 10.0],
            Reach::Long,
            false,
        );
        term(&t).into_string()
    }

    #[test]
    fn a_term_shows_its_sigma_or_says_it_is_not_resolved() {
        let resolved = cell(Estimate::Resolved {
            value: 0.012,
            sigma: 0.0011,
        });
        assert!(resolved.contains(">0.0120 ± 0.0011</td>"), "{resolved}");
        let bound = cell(Estimate::Bound { upper: 0.003 });
        assert!(
            bound.contains(">not resolved (&lt; 0.0030)</td>"),
            "{bound}"
        );
        assert!(bound.contains("class=\"num muted\""), "{bound}");
        let held = cell(Estimate::Fixed { value: 0.5 });
        assert!(held.contains(">0.500 (held)</td>"), "{held}");
        let mut t = Term::from_estimate(
            &Estimate::Bound { upper: 1.0 },
            (1.0, "x"),
            [1.0; 2],
            [1.0; 2],
            Reach::Long,
            false,
        );
        t.upper_bound = None;
        assert!(term(&t).into_string().contains(">not resolved</td>"));
    }
}
