//! Role-typed sessions, the pages' side of `api::auth::Caller`: a page
//! handler that takes `PageCaller<roles::Engineer>` states who may see it,
//! and the extractor refuses everybody else with the page the API's 403
//! becomes. Signed out, the browser goes to the sign-in form first, as with
//! a plain [`Session`].
//!
//! A form handler takes a [`FormCaller`] instead, which hands over its
//! session only once the form's CSRF token has been checked, and checks
//! the role after it: a forged form is refused as forged whatever the
//! session's role, and a form's fields are read (axum's `Form`) before
//! either check, in the order the forms have always answered in.

use std::marker::PhantomData;
use std::ops::Deref;

use axum::extract::FromRequestParts;
use axum::http::request::Parts;

use super::error::PageError;
use super::session::Session;
use crate::api::auth::roles::Permission;
use crate::api::auth::Caller;
use crate::api::AppState;

/// A session whose role is one of `P`'s. It reads as its [`Session`] (the
/// CSRF token its forms carry, the role for the buttons shown), and
/// [`PageCaller::caller`] is the API's caller for `api`'s action functions.
#[derive(Clone, Debug)]
pub struct PageCaller<P> {
    session: Session,
    caller: Caller<P>,
}

impl<P: Permission> PageCaller<P> {
    /// `session` if its role is one of `P`'s, checked by [`Caller::new`]
    /// (the one place a role is checked); the refusal as a page.
    pub fn new(session: Session) -> Result<Self, PageError> {
        let caller = Caller::new(session.auth.clone())?;
        Ok(PageCaller { session, caller })
    }

    /// The same session checked against `Q` now: for a role that depends
    /// on what the request asks for (a run's action, a download).
    pub fn narrow<Q: Permission>(&self) -> Result<PageCaller<Q>, PageError> {
        PageCaller::new(self.session.clone())
    }

    /// The API's caller, for `api`'s action functions.
    pub fn caller(&self) -> &Caller<P> {
        &self.caller
    }
}

impl<P> Deref for PageCaller<P> {
    type Target = Session;

    fn deref(&self) -> &Session {
        &self.session
    }
}

impl<P: Permission> FromRequestParts<AppState> for PageCaller<P> {
    type Rejection = PageError;

    async fn from_request_parts(parts: &mut Parts, st: &AppState) -> Result<Self, PageError> {
        PageCaller::new(Session::from_request_parts(parts, st).await?)
    }
}

/// The session that sent a form to a handler that admits `P`'s roles:
/// nothing of it is reachable but [`FormCaller::check_csrf`], which
/// checks the form's token, then the role.
pub struct FormCaller<P> {
    session: Session,
    permission: PhantomData<fn() -> P>,
}

impl<P: Permission> FormCaller<P> {
    /// The sender if `sent` is its session's CSRF token (403 otherwise)
    /// and its role is one of `P`'s (then 403 naming the roles).
    pub fn check_csrf(self, sent: &str) -> Result<PageCaller<P>, PageError> {
        self.session.check_csrf(sent)?;
        PageCaller::new(self.session)
    }
}

impl<P: Permission> FromRequestParts<AppState> for FormCaller<P> {
    type Rejection = PageError;

    async fn from_request_parts(parts: &mut Parts, st: &AppState) -> Result<Self, PageError> {
        Ok(FormCaller {
            session: Session::from_request_parts(parts, st).await?,
            permission: PhantomData,
        })
    }
}
