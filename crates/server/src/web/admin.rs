//! The admin page: tokens (issue, revoke) and product types (create,
//! change, delete; their limits and their line's error model), through the
//! API's own action functions. A new token's
//! secret is shown once, in the answer to the form that made it.

use axum::extract::{Path, Query, State};
use axum::response::{Html, Response};
use axum::Form;
use maud::{html, Markup};
use serde::Deserialize;

use super::access::{FormCaller, PageCaller};
use super::error::PageError;
use super::format;
use super::layout::{self, action_button};
use super::session::{see_other, CsrfForm};
use crate::api::auth::roles;
use crate::api::products::{remove_product_type, save_product_type, ProductTypeInput};
use crate::api::tokens::{issue_token, revoke, NewTokenRequest, NewTokenView};
use crate::api::{parse_id, AppState};
use crate::store::Role;
use sinscal_core::calib::Effect;

/// An example of the limits' JSON form, shown in an empty form.
const LIMITS_EXAMPLE: &str = r#"{
  "gyro_bias_x": {"max_abs_value": 0.05, "max_sigma": 0.002, "max_repeatability": 0.003},
  "accel_bias_x": {"max_abs_value": 200, "max_sigma": 10}
}"#;

async fn render(
    st: &AppState,
    session: &PageCaller<roles::Admin>,
    issued: Option<&NewTokenView>,
    editing: Option<&str>,
) -> Result<Html<String>, PageError> {
    let tokens = st.store.list_tokens().await?;
    let products = st.store.list_product_types().await?;
    // The form starts from the product being changed, so a change to its
    // limits does not silently drop its model (or the other way round).
    let edited = editing.and_then(|name| products.iter().find(|p| p.name == name));
    let limits_text = edited.map_or_else(|| LIMITS_EXAMPLE.to_string(), |p| pretty_json(&p.limits));
    let body = html! {
        h1 { "Admin" }
        @if let Some(t) = issued { (issued_notice(t)) }
        h2 { "Tokens" }
        table #tokens {
            tr { th { "Label" } th { "Role" } th { "Created" } th { "State" } th {} }
            @for t in &tokens {
                tr {
                    td { (t.label.as_deref().unwrap_or("—")) } td { (t.role.as_str()) } td { (format::time(t.created_at)) }
                    td { @if let Some(r) = t.revoked_at { "revoked " (format::time(r)) } @else { "live" } }
                    td { @if t.revoked_at.is_none() && t.id != session.auth.token_id {
                        (action_button(session, &format!("/admin/tokens/{}/revoke", t.id), "Revoke", "danger"))
                    } }
                }
            }
        }
        h3 { "Issue a token" }
        form.filters #new-token method="post" action="/admin/tokens" {
            input type="hidden" name="csrf" value=(session.csrf());
            label for="label" { "Label" }
            input #label type="text" name="label" maxlength="200" placeholder="station 3, line A";
            label for="role" { "Role" }
            select #role name="role" {
                option value="station" { "station (uploads)" }
                option value="engineer" { "engineer (reads, diagnoses)" }
                option value="admin" { "admin" }
            }
            button.primary type="submit" { "Issue" }
        }
        h2 { "Product types" }
        table #products {
            tr { th { "Name" } th { "Description" } th { "Model" } th.num { "Revision" } th { "Changed" } th { "Limits" } th {} }
            @for p in &products {
                tr {
                    td { (p.name) } td { (p.description.as_deref().unwrap_or("")) }
                    td { @if let Some(m) = &p.model { code { (m) } } @else { span.muted { "the server's" } } }
                    td.num { (p.revision) } td { (format::time(p.updated_at)) }
                    td { details { summary { "JSON" } pre { (p.limits) } } }
                    td { a.edit href={ "/admin?edit=" (p.name) "#product" } { "Change" } " "
                         (action_button(session, &format!("/admin/products/{}/delete", p.name), "Delete", "danger")) }
                }
            }
        }
        h3 { @if let Some(p) = edited { "Change product type " (p.name) } @else { "Create or change a product type" } }
        p.muted { "Limits per canonical parameter, in its unit (SPEC §2): " code { "max_abs_value" } ", " code { "max_sigma" } ", " code { "max_repeatability" } ". Saving a name that exists makes its next revision; the verdicts it touches are judged again." }
        p.muted { "The model is the error model the line's runs are calibrated with from their next calibration job: " code { "base" } " or " code { "base" } " followed by " code { "+" } " and an effect for each effect the line shows (" (effect_names()) "). Empty: the server's model." }
        form.stack #product method="post" action="/admin/products" {
            input type="hidden" name="csrf" value=(session.csrf());
            label for="name" { "Name" }
            input #name type="text" name="name" required maxlength="64" value=[edited.map(|p| &p.name)];
            label for="description" { "Description" }
            input #description type="text" name="description" maxlength="500" value=[edited.and_then(|p| p.description.as_ref())];
            label for="limits" { "Limits (JSON)" }
            textarea #limits name="limits" required { (limits_text) }
            label for="model" { "Model" }
            input #model type="text" name="model" maxlength="200" placeholder="base+accel_delay" value=[edited.and_then(|p| p.model.as_ref())];
            button.primary type="submit" { "Save" }
        }
    };
    Ok(Html(
        layout::page("Admin", Some(session), body).into_string(),
    ))
}

/// The effects a model may add, as the form's note lists them.
fn effect_names() -> String {
    Effect::ALL.map(Effect::name).join(", ")
}

fn issued_notice(t: &NewTokenView) -> Markup {
    html! {
        div.notice #issued {
            p { "Token for " strong { (t.label.as_deref().unwrap_or("(no label)")) } " with role " strong { (t.role.as_str()) } ". It is shown this once; only its hash is kept." }
            p.secret #issued-token { (t.token) }
        }
    }
}

/// `?edit=<product type>` opens the form on that product's current values.
#[derive(Deserialize)]
pub struct AdminQuery {
    edit: Option<String>,
}

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Admin>,
    Query(q): Query<AdminQuery>,
) -> Result<Html<String>, PageError> {
    render(&st, &session, None, q.edit.as_deref()).await
}

/// Stored limits as the form shows them: indented JSON, or the text as
/// stored should it not parse.
fn pretty_json(text: &str) -> String {
    serde_json::from_str::<serde_json::Value>(text)
        .and_then(|v| serde_json::to_string_pretty(&v))
        .unwrap_or_else(|_| text.to_string())
}

#[derive(Deserialize)]
pub struct TokenForm {
    #[serde(default)]
    csrf: String,
    role: Role,
    #[serde(default)]
    label: String,
}

pub async fn create_token(
    State(st): State<AppState>,
    sender: FormCaller<roles::Admin>,
    Form(form): Form<TokenForm>,
) -> Result<Html<String>, PageError> {
    let session = sender.check_csrf(&form.csrf)?;
    let label = form.label.trim();
    let issued = issue_token(
        &st,
        NewTokenRequest {
            role: form.role,
            label: (!label.is_empty()).then(|| label.to_string()),
        },
    )
    .await?;
    render(&st, &session, Some(&issued), None).await
}

pub async fn revoke_token(
    State(st): State<AppState>,
    sender: FormCaller<roles::Admin>,
    Path(id): Path<String>,
    Form(form): Form<CsrfForm>,
) -> Result<Response, PageError> {
    let session = sender.check_csrf(&form.csrf)?;
    // A token's id is a UUID too, kept as its text.
    let id: uuid::Uuid = parse_id(id, "token")?;
    revoke(&st, session.caller(), &id.to_string()).await?;
    Ok(see_other("/admin"))
}

#[derive(Deserialize)]
pub struct ProductForm {
    #[serde(default)]
    csrf: String,
    name: String,
    #[serde(default)]
    description: String,
    limits: String,
    /// Empty: the server's model.
    #[serde(default)]
    model: String,
}

pub async fn save_product(
    State(st): State<AppState>,
    sender: FormCaller<roles::Admin>,
    Form(form): Form<ProductForm>,
) -> Result<Response, PageError> {
    let session = sender.check_csrf(&form.csrf)?;
    let name = form.name.trim();
    let limits: serde_json::Value = serde_json::from_str(&form.limits)
        .map_err(|e| PageError::bad_request(format!("the limits are not JSON: {e}")))?;
    let description = form.description.trim();
    let description = (!description.is_empty()).then_some(description);
    let model = form.model.trim();
    let input = ProductTypeInput {
        name,
        description,
        limits: &limits,
        model: (!model.is_empty()).then_some(model),
    };
    let exists = st.store.get_product_type(name).await?.is_some();
    save_product_type(&st, session.caller(), input, !exists).await?;
    Ok(see_other("/admin"))
}

pub async fn delete_product(
    State(st): State<AppState>,
    sender: FormCaller<roles::Admin>,
    Path(name): Path<String>,
    Form(form): Form<CsrfForm>,
) -> Result<Response, PageError> {
    let session = sender.check_csrf(&form.csrf)?;
    remove_product_type(&st, session.caller(), &name).await?;
    Ok(see_other("/admin"))
}
