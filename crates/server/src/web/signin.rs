//! Signing in and out: the sign-in form (bound to its own short-lived
//! cookie, since no session exists yet to carry a CSRF token), the
//! exchange of a token for a session, and ending a session on the server.

use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::Form;
use maud::html;
use serde::Deserialize;

use super::error::PageError;
use super::layout;
use super::session::{
    constant_time_eq, cookie, over_tls, random_secret, see_other, set_cookie, CsrfForm,
    MaybeSession, Session, SESSION_COOKIE, SESSION_SECONDS, SIGNIN_COOKIE, SIGNIN_SECONDS,
};
use crate::api::auth::hash_token;
use crate::api::AppState;
use crate::store::{now_ms, Role};

/// The sign-in page, with a fresh form token in its own cookie.
pub fn signin_response(headers: &HeaderMap, problem: Option<&str>, status: StatusCode) -> Response {
    let form_token = random_secret();
    let body = layout::page(
        "Sign in",
        None,
        html! {
            h1 { "Sign in" }
            p { "Paste the bearer token you were given (it starts with " code { "sinscal_" } "). \
                 The browser keeps a session for 12 hours; the token is not stored in it." }
            @if let Some(p) = problem { p.problem role="alert" { (p) } }
            form method="post" action="/signin" {
                input type="hidden" name="form_token" value=(form_token);
                label for="token" { "Token" }
                input #token type="password" name="token" autocomplete="current-password" required;
                button type="submit" { "Sign in" }
            }
        },
    );
    let mut resp = (status, Html(body.into_string())).into_response();
    resp.headers_mut().insert(
        header::SET_COOKIE,
        set_cookie(
            SIGNIN_COOKIE,
            &form_token,
            SIGNIN_SECONDS,
            over_tls(headers),
        ),
    );
    resp
}

pub async fn signin_page(headers: HeaderMap, MaybeSession(s): MaybeSession) -> Response {
    if s.is_some() {
        return see_other("/");
    }
    signin_response(&headers, None, StatusCode::OK)
}

#[derive(Deserialize)]
pub struct SignInForm {
    #[serde(default)]
    token: String,
    #[serde(default)]
    form_token: String,
}

pub async fn sign_in(
    State(st): State<AppState>,
    headers: HeaderMap,
    Form(form): Form<SignInForm>,
) -> Result<Response, PageError> {
    let bound = cookie(&headers, SIGNIN_COOKIE).is_some_and(|c| {
        !c.is_empty() && constant_time_eq(c.as_bytes(), form.form_token.as_bytes())
    });
    if !bound {
        return Ok(signin_response(
            &headers,
            Some("the sign-in form expired or came from elsewhere; sign in again"),
            StatusCode::FORBIDDEN,
        ));
    }
    let token = form.token.trim();
    let Some((token_id, role)) = st.store.token_role(&hash_token(token)).await? else {
        tracing::info!("page sign-in refused: unknown or revoked token");
        return Ok(signin_response(
            &headers,
            Some("this token is unknown or revoked"),
            StatusCode::UNAUTHORIZED,
        ));
    };
    let secret = random_secret();
    st.store
        .insert_session(
            &hash_token(&secret),
            &token_id,
            now_ms() + SESSION_SECONDS * 1000,
        )
        .await?;
    tracing::info!(token = %token_id, role = role.as_str(), "page session opened");
    let mut resp = see_other(if role == Role::Station {
        "/upload"
    } else {
        "/"
    });
    let tls = over_tls(&headers);
    let h = resp.headers_mut();
    h.append(
        header::SET_COOKIE,
        set_cookie(SESSION_COOKIE, &secret, SESSION_SECONDS, tls),
    );
    h.append(header::SET_COOKIE, set_cookie(SIGNIN_COOKIE, "", 0, tls));
    Ok(resp)
}

pub async fn sign_out(
    State(st): State<AppState>,
    headers: HeaderMap,
    session: Session,
    Form(form): Form<CsrfForm>,
) -> Result<Response, PageError> {
    session.check_csrf(&form.csrf)?;
    if let Some(secret) = cookie(&headers, SESSION_COOKIE) {
        st.store.delete_session(&hash_token(secret)).await?;
    }
    let mut resp = see_other("/signin");
    resp.headers_mut().insert(
        header::SET_COOKIE,
        set_cookie(SESSION_COOKIE, "", 0, over_tls(&headers)),
    );
    Ok(resp)
}
