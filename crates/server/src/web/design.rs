//! The design page: a form with the design request's main fields,
//! pre-filled with the example the docs give (Table 1 at margin 3, every
//! other field at the command line's default), which queues a design job
//! through the API's own action function and goes to its page
//! (`design_job`).

use axum::extract::State;
use axum::response::{Html, Response};
use axum::Form;
use maud::{html, Markup};
use serde::Deserialize;

use super::access::{FormCaller, PageCaller};
use super::error::PageError;
use super::layout;
use super::session::see_other;
use crate::api::auth::roles;
use crate::api::designs::queue_design;
use crate::api::error::ApiError;
use crate::api::AppState;
use sinscal_core::design::{Axes, DesignRequest, DesignSpec, TargetSpec};

/// The form's numeric fields: name, label, the value it starts with (the
/// docs' example: the defaults) and the step the browser offers.
fn number_fields() -> [(&'static str, &'static str, String, &'static str); 8] {
    let d = DesignRequest::default();
    [
        (
            "margin",
            "Margin (σ × margin ≤ target)",
            d.margin.to_string(),
            "any",
        ),
        (
            "arw_deg_rt_h",
            "Gyro ARW (deg/√h)",
            d.noise.gyro_arw_deg_rt_h.to_string(),
            "any",
        ),
        (
            "vrw_ug_rt_hz",
            "Accelerometer VRW (µg/√Hz)",
            d.noise.accel_vrw_ug_rt_hz.to_string(),
            "any",
        ),
        (
            "rate_dps",
            "Turn rate (deg/s)",
            d.rate_dps.to_string(),
            "any",
        ),
        (
            "accel_dps2",
            "Turn acceleration (deg/s²)",
            d.accel_dps2.to_string(),
            "any",
        ),
        (
            "min_dwell_s",
            "Shortest dwell (s)",
            d.min_dwell_s.to_string(),
            "any",
        ),
        (
            "max_dwell_s",
            "Longest dwell (s)",
            d.max_dwell_s.to_string(),
            "any",
        ),
        ("max_turns", "Most turns", d.max_turns.to_string(), "1"),
    ]
}

pub async fn page(session: PageCaller<roles::Engineer>) -> Html<String> {
    let body = html! {
        h1 { "Design a scheme" }
        p.muted { "The shortest rotation scheme whose predicted 1-σ is at most target / margin for every parameter (what " code { "sinscal design" } " prints). It runs as a job: this page goes to its progress, then to the scheme." }
        (form(&session))
    };
    Html(layout::page("Design", Some(&session), body).into_string())
}

fn form(session: &PageCaller<roles::Engineer>) -> Markup {
    html! {
        form.stack #design method="post" action="/design" {
            input type="hidden" name="csrf" value=(session.csrf());
            label for="target" { "Target" }
            select #target name="target" { option value="table1" selected { "Table 1 (the seed paper's accuracies)" } }
            label for="tighten" { "Tighten (divide every target by)" }
            input #tighten type="number" name="tighten" step="any" min="0" placeholder="1";
            @for (name, label, value, step) in number_fields() {
                label for=(name) { (label) }
                input id=(name) type="number" name=(name) step=(step) value=(value) required;
            }
            label for="axes" { "Axes the table turns about" }
            select #axes name="axes" {
                option value="body" selected { "the unit's own (body)" }
                option value="nav" { "fixed east, north, up (nav)" }
                option value="both" { "both" }
            }
            label for="max_duration_s" { "Longest acceptable run (s, optional)" }
            input #max_duration_s type="number" name="max_duration_s" step="any" min="1";
            label for="detect" { "Effects to detect (optional, comma separated)" }
            input #detect type="text" name="detect" maxlength="400" placeholder="accel_lever_arm=2cm, accel_delay=0.5ms";
            label { input #by_hand type="checkbox" name="by_hand" value="true"; " turned by hand" }
            button.primary type="submit" { "Design" }
        }
    }
}

/// The form as sent: every field text, an empty one left to its default.
#[derive(Deserialize)]
pub struct DesignForm {
    #[serde(default)]
    csrf: String,
    #[serde(default)]
    target: String,
    #[serde(default)]
    tighten: String,
    #[serde(default)]
    margin: String,
    #[serde(default)]
    arw_deg_rt_h: String,
    #[serde(default)]
    vrw_ug_rt_hz: String,
    #[serde(default)]
    rate_dps: String,
    #[serde(default)]
    accel_dps2: String,
    #[serde(default)]
    min_dwell_s: String,
    #[serde(default)]
    max_dwell_s: String,
    #[serde(default)]
    max_turns: String,
    #[serde(default)]
    max_duration_s: String,
    #[serde(default)]
    axes: String,
    #[serde(default)]
    detect: String,
    #[serde(default)]
    by_hand: Option<String>,
}

/// A field's value, `None` when left empty; a value that does not parse
/// is refused naming its field, as the API names a body's.
fn parsed<T: std::str::FromStr>(field: &str, text: &str) -> Result<Option<T>, ApiError> {
    let text = text.trim();
    if text.is_empty() {
        return Ok(None);
    }
    text.parse().map(Some).map_err(|_| ApiError::InvalidField {
        field: field.to_string(),
        message: format!("{text:?} is not a number"),
    })
}

impl DesignForm {
    /// The request the form asks for, as the API's body would say it.
    fn spec(&self) -> Result<DesignSpec, ApiError> {
        let axes = match self.axes.trim() {
            "" => None,
            "body" => Some(Axes::Body),
            "nav" => Some(Axes::Nav),
            "both" => Some(Axes::Both),
            other => {
                return Err(ApiError::InvalidField {
                    field: "axes".into(),
                    message: format!("{other:?} is not body, nav or both"),
                })
            }
        };
        let target = self.target.trim();
        let detect: Vec<String> = self
            .detect
            .split(',')
            .map(str::trim)
            .filter(|g| !g.is_empty())
            .map(String::from)
            .collect();
        Ok(DesignSpec {
            target: (!target.is_empty()).then(|| TargetSpec::Named(target.to_string())),
            tighten: parsed("tighten", &self.tighten)?,
            margin: parsed("margin", &self.margin)?,
            arw_deg_rt_h: parsed("arw_deg_rt_h", &self.arw_deg_rt_h)?,
            vrw_ug_rt_hz: parsed("vrw_ug_rt_hz", &self.vrw_ug_rt_hz)?,
            axes,
            rate_dps: parsed("rate_dps", &self.rate_dps)?,
            accel_dps2: parsed("accel_dps2", &self.accel_dps2)?,
            min_dwell_s: parsed("min_dwell_s", &self.min_dwell_s)?,
            max_dwell_s: parsed("max_dwell_s", &self.max_dwell_s)?,
            max_turns: parsed("max_turns", &self.max_turns)?,
            max_duration_s: parsed("max_duration_s", &self.max_duration_s)?,
            by_hand: self.by_hand.as_ref().map(|_| true),
            detect: (!detect.is_empty()).then_some(detect),
            ..DesignSpec::default()
        })
    }
}

/// Queues the design and goes to its page.
pub async fn submit(
    State(st): State<AppState>,
    sender: FormCaller<roles::Engineer>,
    Form(form): Form<DesignForm>,
) -> Result<Response, PageError> {
    let session = sender.check_csrf(&form.csrf)?;
    let spec = form.spec()?;
    let row = queue_design(&st, session.caller(), &spec).await?;
    Ok(see_other(&format!("/designs/{}", row.job.id)))
}
