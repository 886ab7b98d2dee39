//! Role-typed callers. A handler that asks for `Caller<roles::Engineer>`
//! instead of an [`Auth`] states in its signature who may call it, and the
//! extractor refuses everybody else before the handler runs: the check
//! cannot be left out of a new handler or lost in an edit.
//!
//! [`Caller::new`] is the one place a role is checked; the extractor and
//! the checks that depend on what a request asks for ([`Caller::narrow`],
//! a run page's action) all go through it, so the refusal is the same 403
//! everywhere.

use std::marker::PhantomData;
use std::ops::Deref;

use axum::extract::FromRequestParts;
use axum::http::request::Parts;

use super::roles::Permission;
use super::Auth;
use crate::api::error::ApiError;
use crate::api::AppState;

/// A caller whose role is one of `P`'s. There is no other way to build one
/// than [`Caller::new`], so holding one is proof of the check. It reads as
/// the [`Auth`] it wraps (its token id, [`Auth::may_read_run`]).
#[derive(Clone, Debug)]
pub struct Caller<P> {
    auth: Auth,
    permission: PhantomData<fn() -> P>,
}

impl<P: Permission> Caller<P> {
    /// `auth` if its role is one of `P`'s; a 403 naming the roles
    /// otherwise.
    pub fn new(auth: Auth) -> Result<Self, ApiError> {
        if P::ROLES.contains(&auth.role) {
            Ok(Caller {
                auth,
                permission: PhantomData,
            })
        } else {
            Err(ApiError::Forbidden(P::WHO))
        }
    }

    /// The same caller checked against `Q` now: for a role that depends
    /// on the request's data, known only inside the handler.
    pub fn narrow<Q: Permission>(&self) -> Result<Caller<Q>, ApiError> {
        Caller::new(self.auth.clone())
    }
}

impl<P> Deref for Caller<P> {
    type Target = Auth;

    fn deref(&self) -> &Auth {
        &self.auth
    }
}

/// The bearer token first (401 without a valid one), then the role (403):
/// a caller that is not authenticated never learns what a path needs.
impl<P: Permission> FromRequestParts<AppState> for Caller<P> {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, ApiError> {
        let auth = Auth::authenticate(parts, state).await?;
        Caller::new(auth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::api::auth::roles::{Admin, Engineer, Follow, Upload};
    use crate::store::Role;

    fn auth(role: Role) -> Auth {
        Auth {
            token_id: "t".into(),
            role,
        }
    }

    /// The words each refusal has always had (`Auth::require`'s).
    #[test]
    fn a_refusal_names_the_roles_as_before() {
        let refusal = |e: ApiError| e.to_string();
        assert_eq!(
            refusal(Caller::<Admin>::new(auth(Role::Engineer)).unwrap_err()),
            "this needs the role admin"
        );
        assert_eq!(
            refusal(Caller::<Upload>::new(auth(Role::Engineer)).unwrap_err()),
            "this needs the role station or admin"
        );
        assert_eq!(
            refusal(Caller::<Engineer>::new(auth(Role::Station)).unwrap_err()),
            "this needs the role engineer or admin"
        );
    }

    #[test]
    fn each_role_passes_exactly_its_sets() {
        for role in Role::ALL {
            assert_eq!(
                Caller::<Upload>::new(auth(role)).is_ok(),
                role != Role::Engineer
            );
            assert!(Caller::<Follow>::new(auth(role)).is_ok());
            assert_eq!(
                Caller::<Engineer>::new(auth(role)).is_ok(),
                role != Role::Station
            );
            assert_eq!(
                Caller::<Admin>::new(auth(role)).is_ok(),
                role == Role::Admin
            );
        }
    }

    #[test]
    fn narrowing_checks_again() {
        let engineer = Caller::<Follow>::new(auth(Role::Engineer)).unwrap();
        assert!(engineer.narrow::<Engineer>().is_ok());
        assert!(matches!(
            engineer.narrow::<Admin>(),
            Err(ApiError::Forbidden("admin"))
        ));
    }
}
