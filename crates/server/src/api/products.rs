//! Product types: their acceptance limits and their line's error model
//! (admins write, engineers read). Every change judges again the verdicts
//! of the runs naming the product; the next calibration job of a run
//! naming it carries its model.

use axum::extract::rejection::{JsonRejection, PathRejection};
use axum::extract::{Path, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use serde::{Deserialize, Serialize};

use super::auth::{roles, Caller};
use super::error::ApiError;
use super::{rfc3339, AppState};
use crate::store::{ProductTypeChange, ProductTypeRow};
use sinscal_core::accept::ProductLimits;
use sinscal_core::calib::ErrorModel;
use sinscal_core::io::meta::validate_product;

/// Longest description kept.
const MAX_DESCRIPTION: usize = 500;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NewProductType {
    name: String,
    #[serde(default)]
    description: Option<String>,
    /// Checked by `ProductLimits::from_json`, which names the field at
    /// fault.
    limits: serde_json::Value,
    /// Parsed by [`parse_model`]; absent or null: the server's model.
    #[serde(default)]
    model: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProductTypeUpdate {
    #[serde(default)]
    description: Option<String>,
    limits: serde_json::Value,
    #[serde(default)]
    model: Option<String>,
}

/// A product type as the API's body or the admin page's form gives it,
/// before it is checked.
pub(crate) struct ProductTypeInput<'a> {
    pub name: &'a str,
    pub description: Option<&'a str>,
    pub limits: &'a serde_json::Value,
    /// The line's error model as written (`None`: the server's).
    pub model: Option<&'a str>,
}

#[derive(Serialize)]
pub struct ProductTypeView {
    pub name: String,
    pub description: Option<String>,
    pub limits: ProductLimits,
    /// The error model its runs are calibrated with (null: the server's).
    pub model: Option<ErrorModel>,
    /// Counts the versions of this name (deletions included); verdicts name
    /// the revision they were judged against.
    pub revision: i64,
    pub created_at: String,
    pub updated_at: String,
}

impl TryFrom<ProductTypeRow> for ProductTypeView {
    type Error = ApiError;
    fn try_from(r: ProductTypeRow) -> Result<Self, ApiError> {
        Ok(ProductTypeView {
            limits: r.parsed_limits()?,
            model: r.parsed_model()?,
            name: r.name,
            description: r.description,
            revision: r.revision,
            created_at: rfc3339(r.created_at),
            updated_at: rfc3339(r.updated_at),
        })
    }
}

pub fn router() -> Router<AppState> {
    Router::new()
        .route(
            "/product-types",
            get(list_product_types).post(create_product_type),
        )
        .route(
            "/product-types/{name}",
            get(get_product_type)
                .put(update_product_type)
                .delete(delete_product_type),
        )
}

fn name_of(path: Result<Path<String>, PathRejection>) -> Result<String, ApiError> {
    let name = path?.0;
    validate_product(&name).map_err(ApiError::BadRequest)?;
    Ok(name)
}

/// A line's error model as a body or form writes it, parsed once: `base`
/// or `base-24`, then `+<effect>` for each effect, without spaces (the
/// spelling openapi.yaml's pattern states). A refusal is a 422 naming the
/// field `model`.
pub(crate) fn parse_model(text: &str) -> Result<ErrorModel, ApiError> {
    let refuse = |message: String| ApiError::InvalidField {
        field: "model".into(),
        message,
    };
    if text.chars().any(char::is_whitespace) {
        return Err(refuse(format!(
            "{text:?} has white space; write the model without it, e.g. base+accel_delay"
        )));
    }
    text.parse().map_err(|e| refuse(format!("{e}")))
}

fn check_description(d: Option<&str>) -> Result<(), ApiError> {
    match d {
        Some(d) if d.len() > MAX_DESCRIPTION => Err(ApiError::InvalidField {
            field: "description".into(),
            message: format!("longer than {MAX_DESCRIPTION} bytes"),
        }),
        _ => Ok(()),
    }
}

async fn list_product_types(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
) -> Result<Json<Vec<ProductTypeView>>, ApiError> {
    let rows = st.store.list_product_types().await?;
    Ok(Json(
        rows.into_iter()
            .map(TryInto::try_into)
            .collect::<Result<_, _>>()?,
    ))
}

async fn get_product_type(
    State(st): State<AppState>,
    _: Caller<roles::Engineer>,
    path: Result<Path<String>, PathRejection>,
) -> Result<Json<ProductTypeView>, ApiError> {
    let name = name_of(path)?;
    let row = st
        .store
        .get_product_type(&name)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no product type {name}")))?;
    Ok(Json(row.try_into()?))
}

async fn create_product_type(
    State(st): State<AppState>,
    auth: Caller<roles::Admin>,
    body: Result<Json<NewProductType>, JsonRejection>,
) -> Result<Response, ApiError> {
    let Json(req) = body?;
    let input = ProductTypeInput {
        name: &req.name,
        description: req.description.as_deref(),
        limits: &req.limits,
        model: req.model.as_deref(),
    };
    let row = save_product_type(&st, &auth, input, true).await?;
    let url = format!("/api/v1/product-types/{}", row.name);
    let mut resp = (StatusCode::CREATED, Json(ProductTypeView::try_from(row)?)).into_response();
    if let Ok(v) = HeaderValue::from_str(&url) {
        resp.headers_mut().insert(header::LOCATION, v);
    }
    Ok(resp)
}

async fn update_product_type(
    State(st): State<AppState>,
    auth: Caller<roles::Admin>,
    path: Result<Path<String>, PathRejection>,
    body: Result<Json<ProductTypeUpdate>, JsonRejection>,
) -> Result<Json<ProductTypeView>, ApiError> {
    let name = name_of(path)?;
    let Json(req) = body?;
    let input = ProductTypeInput {
        name: &name,
        description: req.description.as_deref(),
        limits: &req.limits,
        model: req.model.as_deref(),
    };
    let row = save_product_type(&st, &auth, input, false).await?;
    Ok(Json(row.try_into()?))
}

async fn delete_product_type(
    State(st): State<AppState>,
    auth: Caller<roles::Admin>,
    path: Result<Path<String>, PathRejection>,
) -> Result<StatusCode, ApiError> {
    let name = name_of(path)?;
    remove_product_type(&st, &auth, &name).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Creates (`create`) or changes a product type from its limits as JSON
/// and its model as written (the API's and the admin page's); the
/// verdicts it touches are judged again by the store.
pub(crate) async fn save_product_type(
    st: &AppState,
    auth: &Caller<roles::Admin>,
    input: ProductTypeInput<'_>,
    create: bool,
) -> Result<ProductTypeRow, ApiError> {
    let name = input.name;
    validate_product(name).map_err(|message| ApiError::InvalidField {
        field: "name".into(),
        message,
    })?;
    check_description(input.description)?;
    let limits = ProductLimits::from_json(input.limits, "limits")?;
    let model = input.model.map(parse_model).transpose()?;
    let change = ProductTypeChange {
        name,
        description: input.description,
        limits: &limits,
        model: model.as_ref(),
        by: &auth.token_id,
    };
    let row = if create {
        st.store
            .create_product_type(change)
            .await?
            .ok_or_else(|| ApiError::Conflict(format!("product type {name} exists")))?
    } else {
        st.store
            .update_product_type(change)
            .await?
            .ok_or_else(|| ApiError::NotFound(format!("no product type {name}")))?
    };
    tracing::info!(product = %row.name, revision = row.revision, model = ?row.model, "product type saved");
    Ok(row)
}

pub(crate) async fn remove_product_type(
    st: &AppState,
    auth: &Caller<roles::Admin>,
    name: &str,
) -> Result<(), ApiError> {
    if st.store.delete_product_type(name, &auth.token_id).await? {
        tracing::info!(product = %name, "product type deleted");
        Ok(())
    } else {
        Err(ApiError::NotFound(format!("no product type {name}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refusal(text: &str) -> String {
        match parse_model(text) {
            Err(ApiError::InvalidField { field, message }) => {
                assert_eq!(field, "model");
                message
            }
            other => panic!("{text:?}: {other:?}"),
        }
    }

    #[test]
    fn a_model_is_read_in_its_one_spelling_and_a_refusal_names_the_field() {
        let m = parse_model("base+accel_delay").unwrap();
        assert_eq!(m.to_string(), "base-24+accel_delay");
        assert!(parse_model("base-24").unwrap().is_base());
        assert!(refusal("base+accel_dleay").contains("accel_dleay"));
        assert!(refusal("accel_delay").contains("must start with the base model"));
        assert!(refusal("base + accel_delay").contains("white space"));
        assert!(refusal("").contains("base"));
    }

    /// openapi.yaml's pattern for a model names every effect the parser
    /// knows, so schema-valid models are exactly the accepted ones.
    #[test]
    fn the_schema_pattern_names_every_effect() {
        use sinscal_core::calib::Effect;
        let names = Effect::ALL.map(Effect::name).join("|");
        let pattern = format!("pattern: '^base(-24)?(\\+({names}))*$'");
        let uses = crate::api::OPENAPI_YAML.matches(&pattern).count();
        assert_eq!(uses, 2, "{pattern} in the create and replace bodies");
    }
}
