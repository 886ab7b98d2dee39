//! The ids of runs and jobs as types. Both are UUIDs the server makes
//! (version 4), stored as TEXT in their lowercase hyphenated spelling and
//! sent in JSON the same way; a value of [`RunId`] or [`JobId`] is one
//! that parsed, so a malformed id is refused where it enters (a path
//! segment) and never reaches a query. The two are distinct types so that
//! a job's id cannot be passed where a run's is meant. A leaf of `store`.

use std::fmt;
use std::str::FromStr;

use sqlx::any::{Any, AnyTypeInfo, AnyValueRef};
use sqlx::encode::IsNull;
use sqlx::error::BoxDynError;
use uuid::Uuid;

/// The same UUID boundary for each id: parsing (any spelling
/// `Uuid::parse_str` takes, so an upper-case id in a URL still names its
/// run), the one spelling written (`Display`, JSON, the TEXT column), and
/// reading the column back.
macro_rules! uuid_id {
    ($($(#[$doc:meta])* $t:ident),*) => {$(
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $t(Uuid);

        impl $t {
            /// A fresh random id.
            pub fn new() -> Self {
                $t(Uuid::new_v4())
            }
        }

        impl Default for $t {
            fn default() -> Self {
                $t::new()
            }
        }

        impl FromStr for $t {
            type Err = uuid::Error;
            fn from_str(s: &str) -> Result<Self, uuid::Error> {
                Uuid::parse_str(s).map($t)
            }
        }

        impl fmt::Display for $t {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                fmt::Display::fmt(&self.0.hyphenated(), f)
            }
        }

        impl serde::Serialize for $t {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.collect_str(self)
            }
        }

        impl<'de> serde::Deserialize<'de> for $t {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let s = <std::borrow::Cow<'de, str>>::deserialize(d)?;
                s.parse().map_err(serde::de::Error::custom)
            }
        }

        impl sqlx::Type<Any> for $t {
            fn type_info() -> AnyTypeInfo {
                <String as sqlx::Type<Any>>::type_info()
            }
            fn compatible(ty: &AnyTypeInfo) -> bool {
                <String as sqlx::Type<Any>>::compatible(ty)
            }
        }

        impl<'q> sqlx::Encode<'q, Any> for $t {
            fn encode_by_ref(
                &self,
                args: &mut <Any as sqlx::Database>::ArgumentBuffer<'q>,
            ) -> Result<IsNull, BoxDynError> {
                <String as sqlx::Encode<'q, Any>>::encode(self.to_string(), args)
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

uuid_id!(
    /// A run's id (`runs.id`, and `run_id` wherever a row names its run).
    RunId,
    /// A job's id (`jobs.id`, and `job_id` wherever a row names its job).
    JobId
);

#[cfg(test)]
mod tests {
    use super::*;

    /// Every spelling a UUID parser takes reads as the one lowercase
    /// hyphenated id, which is what JSON and the column hold.
    #[test]
    fn an_id_has_one_spelling() {
        let text = "6f9619ff-8b86-d011-b42d-00c04fc964ff";
        for other in [
            text.to_uppercase(),
            text.replace('-', ""),
            format!("{{{text}}}"),
        ] {
            let id: RunId = other.parse().unwrap();
            assert_eq!(id.to_string(), text);
        }
        let id: JobId = text.parse().unwrap();
        assert_eq!(serde_json::to_string(&id).unwrap(), format!("\"{text}\""));
        assert_eq!(
            serde_json::from_str::<JobId>(&format!("\"{text}\"")).unwrap(),
            id
        );
        assert!("run-1".parse::<RunId>().is_err());
        assert!(serde_json::from_str::<RunId>("\"run-1\"").is_err());
    }

    /// A fresh id is the spelling the server always wrote: `new_v4`'s
    /// `to_string`.
    #[test]
    fn a_fresh_id_is_lowercase_hyphenated() {
        let s = RunId::new().to_string();
        assert_eq!(s, Uuid::parse_str(&s).unwrap().to_string());
        assert_eq!((s.len(), s.to_lowercase()), (36, s.clone()));
    }
}
