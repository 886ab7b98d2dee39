//! A unit's held noise model on its page: shown in a line, with a form
//! that holds one (checked as the API checks it, a refused term named) and
//! a button that lets it go. Engineers and admins, as through the API.

use axum::extract::{Path, State};
use axum::response::Response;
use axum::Form;
use maud::{html, Markup};
use serde::Deserialize;

use super::access::FormCaller;
use super::error::PageError;
use super::format;
use super::layout::action_button;
use super::session::{see_other, CsrfForm, Session};
use crate::api::auth::roles;
use crate::api::noise_models::hold_for_unit;
use crate::api::AppState;
use sinscal_core::calib::{HeldNoise, HeldNoiseUse};
use sinscal_core::io::UnitSerial;

/// What the form starts from when no model is held: the two terms every
/// model states, at a navigation-grade unit's sizes.
const EXAMPLE: &str = r#"{"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5}"#;

/// The section: the held model in a line, the form, and the button.
pub fn section(session: &Session, serial: &UnitSerial, held: Option<&(HeldNoise, i64)>) -> Markup {
    let action = format!("/units/{serial}/noise-model");
    let text = held.map_or_else(
        || EXAMPLE.to_string(),
        |(h, _)| serde_json::to_string_pretty(&h.noise).unwrap_or_default(),
    );
    let given = !matches!(held, Some((h, _)) if h.used_as == HeldNoiseUse::Reference);
    html! {
        h2 #noise-model { "Noise model" }
        p #held-noise { (held_line(held)) }
        p.muted { "A model held for the unit (its characterisation, e.g. " code { "sinscal noise --static" } " of a long static recording) reaches the unit's next calibrations; calibrate a run again to use it. Terms by the truth file's " code { "noise" } " names (CONTRACT §2a)." }
        form.stack #hold-noise method="post" action=(action) {
            input type="hidden" name="csrf" value=(session.csrf());
            label for="noise" { "Terms (JSON)" }
            textarea #noise name="noise" required { (text) }
            label for="used_as" { "Used as" }
            select #used_as name="used_as" {
                option value="given" selected[given] { "given: the runs' noise model" }
                option value="reference" selected[!given] { "reference: each run's fitted model is tested against it" }
            }
            button.primary type="submit" { "Hold" }
        }
        @if held.is_some() {
            (action_button(session, &format!("{action}/release"), "Let it go", "danger"))
        }
    }
}

/// The held model in a line, or what the unit's runs use instead.
fn held_line(held: Option<&(HeldNoise, i64)>) -> Markup {
    let Some((held, set_at)) = held else {
        return html! { "None held: each run's own is measured and fitted." };
    };
    let n = &held.noise;
    let terms = [
        ("gyro ARW", n.gyro_arw_deg_rt_h, "deg/√h"),
        ("VRW", n.accel_vrw_ug_rt_hz, "µg/√Hz"),
        ("gyro instability", n.gyro_bias_instability_deg_h, "deg/h"),
        (
            "accelerometer instability",
            n.accel_bias_instability_ug,
            "µg",
        ),
        ("gyro RRW", n.gyro_rrw_deg_h_rt_h, "deg/h/√h"),
        ("accelerometer RW", n.accel_rw_ug_rt_h, "µg/√h"),
        ("gyro quantum", n.gyro_quantum_arcsec, "″"),
        ("accelerometer quantum", n.accel_quantum_mps, "m/s"),
    ];
    let used = match held.used_as {
        HeldNoiseUse::Given => "given to each calibration",
        HeldNoiseUse::Reference => "the reference each run's fitted model is tested against",
    };
    html! {
        @for (k, (name, value, unit)) in terms.iter().filter(|t| t.1 > 0.0).enumerate() {
            @if k > 0 { ", " }
            (name) " " (format::sig(*value, 3)) " " (unit)
        }
        "; " (used) " (set " (format::time(*set_at)) ")."
    }
}

#[derive(Debug, Deserialize)]
pub struct HoldForm {
    #[serde(default)]
    csrf: String,
    noise: String,
    used_as: String,
}

/// Holds the form's model for the unit; back to its page.
pub async fn hold(
    State(st): State<AppState>,
    sender: FormCaller<roles::Engineer>,
    Path(serial): Path<String>,
    Form(form): Form<HoldForm>,
) -> Result<Response, PageError> {
    let session = sender.check_csrf(&form.csrf)?;
    let serial: UnitSerial = serial.parse().map_err(PageError::bad_request)?;
    let noise: serde_json::Value = serde_json::from_str(&form.noise)
        .map_err(|e| PageError::bad_request(format!("the terms are not JSON: {e}")))?;
    let used_as: HeldNoiseUse = form.used_as.parse().map_err(PageError::bad_request)?;
    hold_for_unit(&st, &serial, (&noise, used_as), &session.caller().token_id).await?;
    Ok(see_other(&format!("/units/{serial}#noise-model")))
}

/// Lets the unit's model go; back to its page.
pub async fn release(
    State(st): State<AppState>,
    sender: FormCaller<roles::Engineer>,
    Path(serial): Path<String>,
    Form(form): Form<CsrfForm>,
) -> Result<Response, PageError> {
    sender.check_csrf(&form.csrf)?;
    let serial: UnitSerial = serial.parse().map_err(PageError::bad_request)?;
    st.store.release_noise_model(&serial).await?;
    Ok(see_other(&format!("/units/{serial}#noise-model")))
}
