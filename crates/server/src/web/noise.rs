//! A run's noise page: the Allan deviation of every gyro and accelerometer
//! axis over the run's dwells (or the whole of a static run), log-log, with
//! the fitted model, and the identified coefficients.

use axum::extract::{Path, State};
use axum::response::Html;
use maud::{html, Markup, PreEscaped};

use super::access::PageCaller;
use super::error::PageError;
use super::format;
use super::layout;
use super::run::readable_run;
use crate::api::auth::roles;
use crate::api::noise::analyse_noise;
use crate::api::AppState;
use crate::plot::{Chart, Point, Scale, Series, Style};
use sinscal_core::noise::report::Span;
use sinscal_core::noise::{Term, TermStatus};

/// One colour per axis, shared by an axis's measured and fitted curves.
const AXIS_COLOURS: [&str; 3] = ["#4e79a7", "#f28e2b", "#e15759"];

/// Points of each fitted curve, log-spaced over the measured τ.
const MODEL_POINTS: usize = 60;

fn log_spaced(lo: f64, hi: f64) -> impl Iterator<Item = f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..MODEL_POINTS).map(move |i| (a + (b - a) * i as f64 / (MODEL_POINTS - 1) as f64).exp())
}

/// One sensor kind's chart: each axis's measured deviation (markers) and
/// its fitted model (dashed, `fit(axis, τ)`), in the axis's colour.
fn allan_chart<'a>(
    (title, y_label, sensor): (&str, &str, &str),
    tau: &[f64],
    measured: impl Iterator<Item = &'a [f64]>,
    fit: impl Fn(usize, f64) -> f64,
) -> Chart {
    let mut c = Chart::new(title, "averaging time τ (s)", y_label);
    c.x_scale = Scale::Log10;
    c.y_scale = Scale::Log10;
    c.width = 640.0;
    c.height = 380.0;
    let (lo, hi) = (
        tau.first().copied().unwrap_or(1.0),
        tau.last().copied().unwrap_or(1.0),
    );
    for (k, adev) in measured.enumerate() {
        let axis = ["x", "y", "z"][k];
        let mut data = Series::new(
            format!("{sensor} {axis}"),
            Style::Markers,
            tau.iter()
                .zip(adev)
                .map(|(&x, &y)| Point::new(x, y))
                .collect(),
        );
        data.colour = Some(AXIS_COLOURS[k].into());
        let mut model = Series::new(
            format!("fit {axis}"),
            Style::Dashed,
            log_spaced(lo, hi)
                .map(|t| Point::new(t, fit(k, t)))
                .collect(),
        );
        model.colour = Some(AXIS_COLOURS[k].into());
        c.series.push(data);
        c.series.push(model);
    }
    c
}

/// A term's cell: its value and σ, its bound, or its held value; the
/// whole sentence on hover.
fn term(t: &Term) -> Markup {
    let mark = if t.spoiled_by_departure { " *" } else { "" };
    let shown = match t.status {
        TermStatus::Resolved => format!(
            "{} ± {}",
            format::sig(t.value.unwrap_or(0.0), 3),
            format::sig(t.sigma.unwrap_or(0.0), 2)
        ),
        TermStatus::NotResolved => format!("< {}", format::sig(t.upper_bound.unwrap_or(0.0), 2)),
        TermStatus::Fixed => format!("= {}", format::sig(t.value.unwrap_or(0.0), 3)),
    };
    html! { td.num title=(t.text) { (shown) (mark) } }
}

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    let run = readable_run(&st, &session, id).await?;
    let report = analyse_noise(&st, run.id).await?;
    let tau = &report.curves.tau_s;
    let gyro = allan_chart(
        ("Gyro Allan deviation", "σ(τ) (deg/h)", "gyro"),
        tau,
        report
            .curves
            .gyro
            .iter()
            .map(|(_, c)| c.adev_deg_h.as_slice()),
        |k, t| [&report.gyro.x, &report.gyro.y, &report.gyro.z][k].model_adev_deg_h(t),
    );
    let accel = allan_chart(
        ("Accelerometer Allan deviation", "σ(τ) (µg)", "accel"),
        tau,
        report
            .curves
            .accel
            .iter()
            .map(|(_, c)| c.adev_ug.as_slice()),
        |k, t| [&report.accel.x, &report.accel.y, &report.accel.z][k].model_adev_ug(t),
    );
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
        p.muted { "v ± σ: read from the curve (1-σ); < b: not resolved, 95 % upper bound over the τ the data covers; = v: held at q/√12 of the quantum found in the data; * read where the curve departs from the model." }
        h2 { "Gyros" }
        table #gyro-noise {
            tr { th { "Axis" } th.num { "ARW (deg/√h)" } th.num { "Bias instability (deg/h)" } th.num { "Rate random walk (deg/h/√h)" } th.num { "Quantization (arcsec)" } th.num { "Quantum (arcsec)" } th.num { "Fit rms z" } }
            @for (axis, n) in report.gyro.iter() {
                tr { td { (axis) } (term(&n.arw_deg_rt_h)) (term(&n.bias_instability_deg_h))
                     (term(&n.rate_random_walk_deg_h_rt_h)) (term(&n.angle_quantization_arcsec))
                     td.num { (n.quantum_arcsec.map_or("—".into(), |q| format::sig(q, 4))) } td.num { (format::sig(n.fit_rms_z, 2)) } }
            }
        }
        figure #gyro-allan { (PreEscaped(gyro.to_svg())) }
        h2 { "Accelerometers" }
        table #accel-noise {
            tr { th { "Axis" } th.num { "VRW (µg/√Hz)" } th.num { "Bias instability (µg)" } th.num { "Acceleration random walk (µg/√h)" } th.num { "Quantization (mm/s)" } th.num { "Quantum (m/s)" } th.num { "Fit rms z" } }
            @for (axis, n) in report.accel.iter() {
                tr { td { (axis) } (term(&n.vrw_ug_rt_hz)) (term(&n.bias_instability_ug))
                     (term(&n.acceleration_random_walk_ug_rt_h)) (term(&n.velocity_quantization_mm_s))
                     td.num { (n.quantum_mps.map_or("—".into(), |q| format::sig(q, 4))) } td.num { (format::sig(n.fit_rms_z, 2)) } }
            }
        }
        figure #accel-allan { (PreEscaped(accel.to_svg())) }
    };
    Ok(Html(
        layout::page("Noise", Some(&session), body).into_string(),
    ))
}
