//! Bearer tokens with roles. A token is 32 random bytes shown once; the
//! database holds only its sha256, so a leaked database grants nothing.
//! Tokens are never logged.
//!
//! [`Auth`] says who is calling; which roles a handler admits is stated by
//! the [`Caller`] it extracts instead (see `caller`), with the role sets in
//! [`roles`].

mod caller;
pub mod roles;

pub use self::caller::Caller;

use axum::http::header::AUTHORIZATION;
use axum::http::request::Parts;
use rand::RngCore;
use sha2::{Digest, Sha256};

use super::error::ApiError;
use super::AppState;
use crate::store::Role;

/// Prefix of every token, so that a token pasted somewhere is recognisable
/// (secret scanners) and a typo in the scheme is caught early.
const TOKEN_PREFIX: &str = "sinscal_";

/// A new random token and its stored hash.
pub fn new_token() -> (String, String) {
    let mut bytes = [0u8; 32];
    rand::rngs::OsRng.fill_bytes(&mut bytes);
    let token = format!("{TOKEN_PREFIX}{}", hex::encode(bytes));
    let hash = hash_token(&token);
    (token, hash)
}

pub fn hash_token(token: &str) -> String {
    hex::encode(Sha256::digest(token.as_bytes()))
}

/// The caller, authenticated by its bearer token, its role not yet
/// checked against anything: handlers take a [`Caller`].
#[derive(Clone, Debug)]
pub struct Auth {
    pub token_id: String,
    pub role: Role,
}

impl Auth {
    /// Whether the caller may read a run (and its jobs) uploaded by the
    /// token `uploaded_by`: a station reads only what it uploaded;
    /// engineers and admins read everything. Callers answer 404 otherwise,
    /// so a station cannot even learn that another station's id exists.
    pub fn may_read_run(&self, uploaded_by: Option<&str>) -> bool {
        self.role != Role::Station || uploaded_by == Some(self.token_id.as_str())
    }

    /// The bearer token's caller, or 401. Not an extractor of its own: a
    /// handler that took an `Auth` could forget to check its role, so
    /// handlers take a [`Caller`], which calls this first.
    async fn authenticate(parts: &Parts, state: &AppState) -> Result<Auth, ApiError> {
        let header = parts
            .headers
            .get(AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .ok_or(ApiError::Unauthenticated)?;
        let (scheme, token) = header.split_once(' ').ok_or(ApiError::Unauthenticated)?;
        if !scheme.eq_ignore_ascii_case("bearer") || !token.trim().starts_with(TOKEN_PREFIX) {
            return Err(ApiError::Unauthenticated);
        }
        match state.store.token_role(&hash_token(token.trim())).await? {
            Some((token_id, role)) => Ok(Auth { token_id, role }),
            None => Err(ApiError::Unauthenticated),
        }
    }
}
