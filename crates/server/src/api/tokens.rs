//! Tokens (admin only): create, list, revoke.

use axum::extract::rejection::{JsonRejection, PathRejection};
use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::routing::{delete, get};
use axum::{Json, Router};
use serde::{Deserialize, Serialize};

use super::auth::{new_token, roles, Caller};
use super::error::ApiError;
use super::{parse_id, rfc3339, AppState};
use crate::store::Role;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NewTokenRequest {
    pub role: Role,
    pub label: Option<String>,
}

#[derive(Serialize)]
pub struct NewTokenView {
    pub id: String,
    pub role: Role,
    pub label: Option<String>,
    /// Shown once: only its hash is stored.
    pub token: String,
}

#[derive(Serialize)]
pub struct TokenView {
    pub id: String,
    pub role: Role,
    pub label: Option<String>,
    pub created_at: String,
    pub revoked_at: Option<String>,
}

pub fn router() -> Router<AppState> {
    Router::new()
        .route("/tokens", get(list_tokens).post(create_token))
        .route("/tokens/{id}", delete(revoke_token))
}

async fn create_token(
    State(st): State<AppState>,
    _: Caller<roles::Admin>,
    body: Result<Json<NewTokenRequest>, JsonRejection>,
) -> Result<(StatusCode, Json<NewTokenView>), ApiError> {
    let Json(req) = body?;
    Ok((StatusCode::CREATED, Json(issue_token(&st, req).await?)))
}

/// Makes a token (the API's and the admin page's): the only moment its
/// secret exists outside the caller's hands.
pub(crate) async fn issue_token(
    st: &AppState,
    req: NewTokenRequest,
) -> Result<NewTokenView, ApiError> {
    if req.label.as_ref().is_some_and(|l| l.len() > 200) {
        return Err(ApiError::BadRequest(
            "label is longer than 200 bytes".into(),
        ));
    }
    let (token, hash) = new_token();
    let id = uuid::Uuid::new_v4().to_string();
    st.store
        .insert_token(&id, &hash, req.role, req.label.as_deref())
        .await?;
    tracing::info!(token = %id, role = req.role.as_str(), "token issued");
    Ok(NewTokenView {
        id,
        role: req.role,
        label: req.label,
        token,
    })
}

async fn list_tokens(
    State(st): State<AppState>,
    _: Caller<roles::Admin>,
) -> Result<Json<Vec<TokenView>>, ApiError> {
    let rows = st.store.list_tokens().await?;
    Ok(Json(
        rows.into_iter()
            .map(|t| TokenView {
                id: t.id,
                role: t.role,
                label: t.label,
                created_at: rfc3339(t.created_at),
                revoked_at: t.revoked_at.map(rfc3339),
            })
            .collect(),
    ))
}

async fn revoke_token(
    State(st): State<AppState>,
    auth: Caller<roles::Admin>,
    path: Result<Path<String>, PathRejection>,
) -> Result<StatusCode, ApiError> {
    // A token's id is a UUID too, kept as its text.
    let id: uuid::Uuid = parse_id(path?.0, "token")?;
    revoke(&st, &auth, &id.to_string()).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Revokes another live token; its sessions end with it.
pub(crate) async fn revoke(
    st: &AppState,
    auth: &Caller<roles::Admin>,
    id: &str,
) -> Result<(), ApiError> {
    if id == auth.token_id {
        return Err(ApiError::Conflict("a token cannot revoke itself".into()));
    }
    if st.store.revoke_token(id).await? {
        tracing::info!(token = %id, "token revoked");
        Ok(())
    } else {
        Err(ApiError::NotFound(format!("no live token {id}")))
    }
}
