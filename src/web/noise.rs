//! A run's noise page: the Allan deviation of every gyro and accelerometer
//! axis over the run's dwells (or the whole of a static run), log-log, with
//! the fitted model, and the identified coefficients.

use axum::extract::{Path, State};
use axum::response::Html;
use maud::{html, PreEscaped};

use super::error::PageError;
use super::format;
use super::layout;
use super::run::readable_run;
use super::session::Session;
use crate::api::auth::roles;
use crate::api::noise::analyse_noise;
use crate::api::AppState;
use crate::noise::report::Span;
use crate::plot::{Chart, Point, Scale, Series, Style};

/// One colour per axis, shared by an axis's measured and fitted curves.
const AXIS_COLOURS: [&str; 3] = ["#4e79a7", "#f28e2b", "#e15759"];

/// Points of each fitted curve, log-spaced over the measured τ.
const MODEL_POINTS: usize = 60;

fn log_spaced(lo: f64, hi: f64) -> impl Iterator<Item = f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..MODEL_POINTS).map(move |i| (a + (b - a) * i as f64 / (MODEL_POINTS - 1) as f64).exp())
}

fn allan_chart(title: &str, y_label: &str) -> Chart {
    let mut c = Chart::new(title, "averaging time τ (s)", y_label);
    c.x_scale = Scale::Log10;
    c.y_scale = Scale::Log10;
    c.width = 640.0;
    c.height = 380.0;
    c
}

pub async fn page(
    State(st): State<AppState>,
    session: Session,
    Path(id): Path<String>,
) -> Result<Html<String>, PageError> {
    session.require(roles::ENGINEER)?;
    let run = readable_run(&st, &session, id).await?;
    let report = analyse_noise(&st, &run.id).await?;
    let tau = &report.curves.tau_s;
    let (lo, hi) = (
        tau.first().copied().unwrap_or(1.0),
        tau.last().copied().unwrap_or(1.0),
    );
    let points = |adev: &[f64]| -> Vec<Point> {
        tau.iter()
            .zip(adev)
            .map(|(&x, &y)| Point { x, y, sigma: None })
            .collect()
    };
    let mut gyro = allan_chart("Gyro Allan deviation", "σ(τ) (deg/h)");
    for (k, (axis, curve)) in report.curves.gyro.iter().enumerate() {
        gyro.series.push(Series {
            name: format!("gyro {axis}"),
            style: Style::Markers,
            colour: Some(AXIS_COLOURS[k].into()),
            points: points(&curve.adev_deg_h),
        });
    }
    for (k, (axis, n)) in report.gyro.iter().enumerate() {
        gyro.series.push(Series {
            name: format!("fit {axis}"),
            style: Style::Dashed,
            colour: Some(AXIS_COLOURS[k].into()),
            points: log_spaced(lo, hi)
                .map(|t| Point {
                    x: t,
                    y: n.model_adev_deg_h(t),
                    sigma: None,
                })
                .collect(),
        });
    }
    let mut accel = allan_chart("Accelerometer Allan deviation", "σ(τ) (µg)");
    for (k, (axis, curve)) in report.curves.accel.iter().enumerate() {
        accel.series.push(Series {
            name: format!("accel {axis}"),
            style: Style::Markers,
            colour: Some(AXIS_COLOURS[k].into()),
            points: points(&curve.adev_ug),
        });
    }
    for (k, (axis, n)) in report.accel.iter().enumerate() {
        accel.series.push(Series {
            name: format!("fit {axis}"),
            style: Style::Dashed,
            colour: Some(AXIS_COLOURS[k].into()),
            points: log_spaced(lo, hi)
                .map(|t| Point {
                    x: t,
                    y: n.model_adev_ug(t),
                    sigma: None,
                })
                .collect(),
        });
    }
    let over = &report.computed_over;
    let body = html! {
        h1 { "Noise of run " a href={ "/runs/" (run.id) } { code { (format::short_id(&run.id)) } } " (unit " (run.unit_serial) ")" }
        p.muted {
            "Overlapping Allan deviation over "
            @match over.span { Span::Dwells => { (over.stretches.len()) " dwells" }, Span::WholeRun => "the whole (static) run" }
            ", " (format::sig(over.seconds_used, 4)) " s of data at " (over.sample_rate_hz) " Hz; τ up to " (format::sig(over.max_tau_s, 3)) " s. "
            (report.method)
        }
        h2 { "Gyros" }
        table #gyro-noise {
            tr { th { "Axis" } th.num { "ARW (deg/√h)" } th.num { "Bias instability (deg/h)" } th.num { "Rate random walk (deg/h/√h)" } th.num { "Quantization (arcsec)" } th.num { "Fit rms z" } }
            @for (axis, n) in report.gyro.iter() {
                tr { td { (axis) } td.num { (format::sig(n.arw_deg_rt_h, 3)) } td.num { (format::sig(n.bias_instability_deg_h, 3)) }
                     td.num { (format::sig(n.rate_random_walk_deg_h_rt_h, 3)) } td.num { (format::sig(n.angle_quantization_arcsec, 3)) } td.num { (format::sig(n.fit_rms_z, 2)) } }
            }
        }
        figure #gyro-allan { (PreEscaped(gyro.to_svg())) }
        h2 { "Accelerometers" }
        table #accel-noise {
            tr { th { "Axis" } th.num { "VRW (µg/√Hz)" } th.num { "Bias instability (µg)" } th.num { "Acceleration random walk (µg/√h)" } th.num { "Quantization (mm/s)" } th.num { "Fit rms z" } }
            @for (axis, n) in report.accel.iter() {
                tr { td { (axis) } td.num { (format::sig(n.vrw_ug_rt_hz, 3)) } td.num { (format::sig(n.bias_instability_ug, 3)) }
                     td.num { (format::sig(n.acceleration_random_walk_ug_rt_h, 3)) } td.num { (format::sig(n.velocity_quantization_mm_s, 3)) } td.num { (format::sig(n.fit_rms_z, 2)) } }
            }
        }
        figure #accel-allan { (PreEscaped(accel.to_svg())) }
    };
    Ok(Html(
        layout::page("Noise", Some(&session), body).into_string(),
    ))
}
