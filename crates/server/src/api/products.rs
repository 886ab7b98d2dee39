//! Product types: their acceptance limits (admins write, engineers read).
//! Every change judges again the verdicts of the runs naming the product.

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
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProductTypeUpdate {
    #[serde(default)]
    description: Option<String>,
    limits: serde_json::Value,
}

#[derive(Serialize)]
pub struct ProductTypeView {
    pub name: String,
    pub description: Option<String>,
    pub limits: ProductLimits,
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
    let row = save_product_type(
        &st,
        &auth,
        &req.name,
        req.description.as_deref(),
        &req.limits,
        true,
    )
    .await?;
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
    let row = save_product_type(
        &st,
        &auth,
        &name,
        req.description.as_deref(),
        &req.limits,
        false,
    )
    .await?;
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
/// (the API's and the admin page's); the verdicts it touches are judged
/// again by the store.
pub(crate) async fn save_product_type(
    st: &AppState,
    auth: &Caller<roles::Admin>,
    name: &str,
    description: Option<&str>,
    limits: &serde_json::Value,
    create: bool,
) -> Result<ProductTypeRow, ApiError> {
    validate_product(name).map_err(|message| ApiError::InvalidField {
        field: "name".into(),
        message,
    })?;
    check_description(description)?;
    let limits = ProductLimits::from_json(limits, "limits")?;
    let change = ProductTypeChange {
        name,
        description,
        limits: &limits,
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
    tracing::info!(product = %row.name, revision = row.revision, "product type saved");
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
