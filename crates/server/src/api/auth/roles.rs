//! Who may do what. Each set of roles is written twice: as a slice, for a
//! page deciding which buttons to show, and as a zero-sized type naming
//! the slice, for the extractors ([`super::Caller`], the pages'
//! `PageCaller`), so that a handler's signature states who may call it.

use crate::store::Role;

/// Upload runs.
pub const UPLOAD: &[Role] = &[Role::Station, Role::Admin];
/// Read a run or a job: stations follow the Location of their own
/// uploads only (see [`super::Auth::may_read_run`]).
pub const FOLLOW: &[Role] = &[Role::Station, Role::Engineer, Role::Admin];
/// Read results, units, history, statistics, product types; cancel jobs.
pub const ENGINEER: &[Role] = &[Role::Engineer, Role::Admin];
/// Tokens, deletes, product types.
pub const ADMIN: &[Role] = &[Role::Admin];

/// A set of roles as a type: what a typed caller has been checked
/// against.
pub trait Permission {
    /// The roles allowed.
    const ROLES: &'static [Role];
    /// The same roles in words, as a refusal names them ("this needs the
    /// role engineer or admin").
    const WHO: &'static str;
}

/// `Self`'s roles are all among `Q`'s: a caller checked against `Self` may
/// be handed where `Q` is asked for, with no second check. The pairs are
/// listed by hand; a unit test holds each to the subset it claims.
pub trait Implies<Q: Permission>: Permission {}

impl<P: Permission> Implies<P> for P {}

/// Station or admin: [`UPLOAD`].
#[derive(Clone, Copy, Debug)]
pub struct Upload;

/// Every role: [`FOLLOW`].
#[derive(Clone, Copy, Debug)]
pub struct Follow;

/// Engineer or admin: [`ENGINEER`].
#[derive(Clone, Copy, Debug)]
pub struct Engineer;

/// Admin only: [`ADMIN`].
#[derive(Clone, Copy, Debug)]
pub struct Admin;

impl Permission for Upload {
    const ROLES: &'static [Role] = UPLOAD;
    const WHO: &'static str = "station or admin";
}

impl Permission for Follow {
    const ROLES: &'static [Role] = FOLLOW;
    const WHO: &'static str = "station, engineer or admin";
}

impl Permission for Engineer {
    const ROLES: &'static [Role] = ENGINEER;
    const WHO: &'static str = "engineer or admin";
}

impl Permission for Admin {
    const ROLES: &'static [Role] = ADMIN;
    const WHO: &'static str = "admin";
}

impl Implies<Follow> for Upload {}
impl Implies<Follow> for Engineer {}
impl Implies<Follow> for Admin {}
impl Implies<Upload> for Admin {}
impl Implies<Engineer> for Admin {}

#[cfg(test)]
mod tests {
    use super::*;

    /// The roles in words: "a", "a or b", "a, b or c".
    fn in_words(roles: &[Role]) -> String {
        let names: Vec<&str> = roles.iter().map(|r| r.as_str()).collect();
        match names.split_last() {
            Some((last, [])) => last.to_string(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        }
    }

    fn names_its_roles<P: Permission>() {
        assert_eq!(P::WHO, in_words(P::ROLES));
    }

    fn is_subset<P: Implies<Q>, Q: Permission>() {
        assert!(
            P::ROLES.iter().all(|r| Q::ROLES.contains(r)),
            "{} is not within {}",
            P::WHO,
            Q::WHO
        );
    }

    #[test]
    fn each_permission_names_exactly_its_roles() {
        names_its_roles::<Upload>();
        names_its_roles::<Follow>();
        names_its_roles::<Engineer>();
        names_its_roles::<Admin>();
    }

    #[test]
    fn each_implication_is_a_subset() {
        is_subset::<Upload, Follow>();
        is_subset::<Engineer, Follow>();
        is_subset::<Admin, Follow>();
        is_subset::<Admin, Upload>();
        is_subset::<Admin, Engineer>();
    }
}
