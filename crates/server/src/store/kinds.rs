//! The closed vocabularies the database stores as TEXT: a token's role, a
//! job's kind and its state. Each is an enum in Rust; its `as_str` is the
//! one spelling, used for the column (sqlx `Type`/`Encode`/`Decode`) and
//! for parsing (`FromStr`); JSON uses the same lowercase names. The
//! spellings are the values the schema's CHECK constraints allow, so no
//! migration is involved.
//!
//! SQL text spells them as literals where a statement filters or sets a
//! fixed value (`state = 'running'`): SQLite matches a partial index such
//! as `jobs_calibrate_run` or `jobs_diagnose_active` only against literal
//! terms. What crosses into Rust is always one of these types. A result's
//! verdict (`sinscal_core::accept::VerdictStatus`, parsed and written by
//! the core) is bound as its `as_str` and read back through its `FromStr`.

use std::fmt;
use std::str::FromStr;

use sqlx::any::{Any, AnyTypeInfo, AnyTypeInfoKind, AnyValueRef};
use sqlx::encode::IsNull;
use sqlx::error::BoxDynError;
use sqlx::ValueRef as _;

/// A bearer token's role.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Uploads runs and follows their jobs.
    Station,
    /// Reads everything, cancels jobs.
    Engineer,
    /// Everything, including tokens and deletes.
    Admin,
}

impl Role {
    pub const ALL: [Role; 3] = [Role::Station, Role::Engineer, Role::Admin];

    pub fn as_str(self) -> &'static str {
        match self {
            Role::Station => "station",
            Role::Engineer => "engineer",
            Role::Admin => "admin",
        }
    }
}

/// What a job runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JobKind {
    /// The estimator on a run: one per run, queued by its upload.
    Calibrate,
    /// The discrepancy workflow on a run: on request, or after a
    /// calibration whose model check failed.
    Diagnose,
    /// A scheme design (`POST /designs`): the one kind that belongs to no
    /// run; its request and answer are a `designs` row.
    Design,
}

impl JobKind {
    pub const ALL: [JobKind; 3] = [JobKind::Calibrate, JobKind::Diagnose, JobKind::Design];

    pub fn as_str(self) -> &'static str {
        match self {
            JobKind::Calibrate => "calibrate",
            JobKind::Diagnose => "diagnose",
            JobKind::Design => "design",
        }
    }
}

/// Where a job is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JobState {
    /// Waiting for a worker (possibly for its retry backoff to pass).
    Queued,
    /// Held by a worker's lease.
    Running,
    Succeeded,
    /// Failed for good: a failure retrying cannot fix (the run's data).
    Failed,
    /// The dead-letter state: every allowed attempt failed with an error
    /// worth retrying (I/O, a lost worker). Set aside for an operator, who
    /// can queue it again (`POST /runs/{id}/calibrate`).
    #[serde(rename = "dead_letter")]
    DeadLetter,
    Cancelled,
}

impl JobState {
    pub const ALL: [JobState; 6] = [
        JobState::Queued,
        JobState::Running,
        JobState::Succeeded,
        JobState::Failed,
        JobState::DeadLetter,
        JobState::Cancelled,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::DeadLetter => "dead_letter",
            JobState::Cancelled => "cancelled",
        }
    }

    /// Succeeded, failed or dead-lettered: no worker will touch it again
    /// (a cancelled job can still be "cancelled" again, as a no-op).
    pub fn is_settled(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::DeadLetter
        )
    }
}

/// "a, b or c": the spellings a parse error lists.
fn one_of(names: impl Iterator<Item = &'static str>) -> String {
    let names: Vec<_> = names.collect();
    match names.split_last() {
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}

/// The same TEXT boundary for each vocabulary (`$what` names it in a
/// parse error): `FromStr`, `Display` and the SQLite column go through
/// `as_str` and `ALL`. (serde is derived, so that a
/// refused role in a request keeps serde's own message; a test checks the
/// spellings agree.)
macro_rules! stored_as_text {
    ($($t:ty: $what:literal),*) => {$(
        impl FromStr for $t {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                <$t>::ALL.into_iter().find(|v| v.as_str() == s).ok_or_else(|| {
                    let all = one_of(<$t>::ALL.into_iter().map(<$t>::as_str));
                    format!("unknown {} {s:?}: {all}", $what)
                })
            }
        }

        impl fmt::Display for $t {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.as_str())
            }
        }

        impl sqlx::Type<Any> for $t {
            fn type_info() -> AnyTypeInfo {
                <&str as sqlx::Type<Any>>::type_info()
            }
            fn compatible(ty: &AnyTypeInfo) -> bool {
                <&str as sqlx::Type<Any>>::compatible(ty)
            }
        }

        impl<'q> sqlx::Encode<'q, Any> for $t {
            fn encode_by_ref(
                &self,
                args: &mut <Any as sqlx::Database>::ArgumentBuffer<'q>,
            ) -> Result<IsNull, BoxDynError> {
                let s: &'q str = self.as_str();
                <&str as sqlx::Encode<'q, Any>>::encode_by_ref(&s, args)
            }
        }

        impl<'r> sqlx::Decode<'r, Any> for $t {
            fn decode(value: AnyValueRef<'r>) -> Result<Self, BoxDynError> {
                let s = <&str as sqlx::Decode<'r, Any>>::decode(value)?;
                Ok(s.parse::<$t>()?)
            }
        }
    )*};
}

/// A flag column as read: BOOLEAN on PostgreSQL, 0/1 INTEGER on SQLite
/// (which has no boolean type). Row structs read a `bool` through it
/// (`#[sqlx(try_from = "Flag")]`); writes bind `bool`, which each driver
/// stores in its own way.
#[derive(Clone, Copy, Debug)]
pub(super) struct Flag(bool);

/// A nullable flag column (see [`Flag`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct OptionalFlag(Option<bool>);

impl From<Flag> for bool {
    fn from(f: Flag) -> bool {
        f.0
    }
}

impl From<OptionalFlag> for Option<bool> {
    fn from(f: OptionalFlag) -> Option<bool> {
        f.0
    }
}

fn decode_flag(value: AnyValueRef<'_>) -> Result<bool, BoxDynError> {
    if value.type_info().kind() == AnyTypeInfoKind::Bool {
        <bool as sqlx::Decode<Any>>::decode(value)
    } else {
        Ok(<i64 as sqlx::Decode<Any>>::decode(value)? != 0)
    }
}

fn is_flag_type(ty: &AnyTypeInfo) -> bool {
    ty.kind() == AnyTypeInfoKind::Bool || ty.kind().is_integer()
}

impl sqlx::Type<Any> for Flag {
    fn type_info() -> AnyTypeInfo {
        <bool as sqlx::Type<Any>>::type_info()
    }
    fn compatible(ty: &AnyTypeInfo) -> bool {
        is_flag_type(ty)
    }
}

impl<'r> sqlx::Decode<'r, Any> for Flag {
    fn decode(value: AnyValueRef<'r>) -> Result<Self, BoxDynError> {
        decode_flag(value).map(Flag)
    }
}

impl sqlx::Type<Any> for OptionalFlag {
    fn type_info() -> AnyTypeInfo {
        <bool as sqlx::Type<Any>>::type_info()
    }
    fn compatible(ty: &AnyTypeInfo) -> bool {
        is_flag_type(ty)
    }
}

impl<'r> sqlx::Decode<'r, Any> for OptionalFlag {
    fn decode(value: AnyValueRef<'r>) -> Result<Self, BoxDynError> {
        if value.is_null() {
            return Ok(OptionalFlag(None));
        }
        decode_flag(value).map(|b| OptionalFlag(Some(b)))
    }
}

stored_as_text!(
    Role: "role",
    JobKind: "job kind",
    JobState: "job state"
);

#[cfg(test)]
mod tests {
    use super::*;
    use sinscal_core::accept::VerdictStatus;

    #[test]
    fn every_value_round_trips_through_its_text() {
        for r in Role::ALL {
            assert_eq!(r.as_str().parse::<Role>(), Ok(r));
            assert_eq!(serde_json::to_string(&r).unwrap(), format!("\"{r}\""));
        }
        for k in JobKind::ALL {
            assert_eq!(k.as_str().parse::<JobKind>(), Ok(k));
            let back: JobKind = serde_json::from_str(&format!("\"{k}\"")).unwrap();
            assert_eq!(back, k);
        }
        for s in JobState::ALL {
            assert_eq!(s.as_str().parse::<JobState>(), Ok(s));
            assert_eq!(serde_json::to_value(s).unwrap(), s.as_str());
        }
        assert_eq!(
            "root".parse::<Role>(),
            Err("unknown role \"root\": station, engineer or admin".to_string())
        );
        assert_eq!(
            "paused".parse::<JobState>(),
            Err(
                "unknown job state \"paused\": queued, running, succeeded, failed, dead_letter \
                 or cancelled"
                    .to_string()
            )
        );
        assert!(serde_json::from_str::<JobState>("\"paused\"").is_err());
        assert!(serde_json::from_str::<Role>("\"Admin\"").is_err());
        for v in VerdictStatus::ALL {
            assert_eq!(v.as_str().parse::<VerdictStatus>(), Ok(v));
            assert_eq!(serde_json::to_value(v).unwrap(), v.as_str());
        }
    }
}
