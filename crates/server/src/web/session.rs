//! Browser sessions. Signing in trades a bearer token (typed once into the
//! sign-in form) for a session cookie that is HttpOnly (no script reads
//! it), SameSite=Strict (no other site's page sends it), and Secure when the
//! server is reached over TLS through a proxy (`X-Forwarded-Proto: https`).
//! The cookie holds 32 random bytes; the store keeps their sha256 only.
//!
//! (Signing in and out is `signin`.) Every form that changes something carries a CSRF token derived from the
//! session's secret (a keyed hash, so it is never stored and never equals
//! the cookie). The sign-in form, which has no session yet, is bound to a
//! short-lived cookie of its own (double submit).

use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use rand::RngCore;
use serde::Deserialize;
use sha2::{Digest, Sha256};

use super::error::PageError;
use crate::api::auth::{hash_token, Auth};
use crate::api::AppState;
use crate::store::Role;

pub const SESSION_COOKIE: &str = "sinscal_session";
pub(super) const SIGNIN_COOKIE: &str = "sinscal_signin";
/// A session lasts a shift and a half, then the browser signs in again.
pub(super) const SESSION_SECONDS: i64 = 12 * 3600;
/// Time to fill in the sign-in form.
pub(super) const SIGNIN_SECONDS: i64 = 600;

/// The caller of a page: the token its session acts for, whatever its
/// role. A page that admits only some roles takes a role-typed session
/// instead (`access`).
#[derive(Clone, Debug)]
pub struct Session {
    pub auth: Auth,
    csrf: String,
}

impl Session {
    /// The token every form of this session carries.
    pub fn csrf(&self) -> &str {
        &self.csrf
    }

    /// Refuses a form whose CSRF token is not this session's.
    pub fn check_csrf(&self, sent: &str) -> Result<(), PageError> {
        if constant_time_eq(sent.as_bytes(), self.csrf.as_bytes()) {
            Ok(())
        } else {
            Err(PageError::Status(
                StatusCode::FORBIDDEN,
                "the form's CSRF token is missing or is not this session's; reload the page and \
                 send it again"
                    .into(),
            ))
        }
    }

    pub fn role(&self) -> Role {
        self.auth.role
    }
}

pub(super) fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

pub(super) fn random_secret() -> String {
    let mut bytes = [0u8; 32];
    rand::rngs::OsRng.fill_bytes(&mut bytes);
    hex::encode(bytes)
}

/// The CSRF token of a session: a keyed hash of its secret, so that
/// knowing a page's token reveals nothing of the cookie.
fn csrf_of(secret: &str) -> String {
    let mut h = Sha256::new();
    h.update(b"sinscal csrf\0");
    h.update(secret.as_bytes());
    hex::encode(h.finalize())
}

/// A cookie's value from the request's `Cookie` headers.
pub fn cookie<'a>(headers: &'a HeaderMap, name: &str) -> Option<&'a str> {
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|pair| pair.trim().split_once('='))
        .find(|(n, _)| *n == name)
        .map(|(_, v)| v)
}

pub(super) fn over_tls(headers: &HeaderMap) -> bool {
    headers
        .get("x-forwarded-proto")
        .is_some_and(|v| v.as_bytes().eq_ignore_ascii_case(b"https"))
}

pub(super) fn set_cookie(name: &str, value: &str, max_age_s: i64, secure: bool) -> HeaderValue {
    let secure = if secure { "; Secure" } else { "" };
    HeaderValue::from_str(&format!(
        "{name}={value}; Path=/; HttpOnly; SameSite=Strict; Max-Age={max_age_s}{secure}"
    ))
    .expect("cookie names and hex values are valid header text")
}

impl FromRequestParts<AppState> for Session {
    type Rejection = PageError;

    async fn from_request_parts(parts: &mut Parts, st: &AppState) -> Result<Self, PageError> {
        let secret = cookie(&parts.headers, SESSION_COOKIE).ok_or(PageError::SignIn)?;
        if secret.len() != 64 || !secret.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(PageError::SignIn);
        }
        match st.store.session_role(&hash_token(secret)).await? {
            Some((token_id, role)) => Ok(Session {
                auth: Auth { token_id, role },
                csrf: csrf_of(secret),
            }),
            None => Err(PageError::SignIn),
        }
    }
}

/// The session if there is one (pages that also serve the signed-out).
pub struct MaybeSession(pub Option<Session>);

impl FromRequestParts<AppState> for MaybeSession {
    type Rejection = PageError;

    async fn from_request_parts(parts: &mut Parts, st: &AppState) -> Result<Self, PageError> {
        match Session::from_request_parts(parts, st).await {
            Ok(s) => Ok(MaybeSession(Some(s))),
            Err(PageError::SignIn) => Ok(MaybeSession(None)),
            Err(e) => Err(e),
        }
    }
}

#[derive(Deserialize)]
pub struct CsrfForm {
    #[serde(default)]
    pub csrf: String,
}

pub fn see_other(location: &str) -> Response {
    let mut resp = StatusCode::SEE_OTHER.into_response();
    if let Ok(v) = HeaderValue::from_str(location) {
        resp.headers_mut().insert(header::LOCATION, v);
    }
    resp
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_csrf_token_is_derived_from_the_secret_and_differs_from_it() {
        let a = csrf_of("00");
        assert_eq!(a, csrf_of("00"));
        assert_ne!(a, csrf_of("01"));
        assert_ne!(a, "00");
        assert!(constant_time_eq(b"abc", b"abc"));
        assert!(!constant_time_eq(b"abc", b"abd"));
        assert!(!constant_time_eq(b"abc", b"ab"));
    }

    #[test]
    fn cookies_are_found_among_several() {
        let mut h = HeaderMap::new();
        h.insert(
            header::COOKIE,
            HeaderValue::from_static("a=1; sinscal_session=ff; b=2"),
        );
        assert_eq!(cookie(&h, SESSION_COOKIE), Some("ff"));
        assert_eq!(cookie(&h, "c"), None);
    }
}
