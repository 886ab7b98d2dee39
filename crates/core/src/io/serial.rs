//! A unit's serial as a type: text that passed [`validate_serial`], so a
//! value of it can go into a path, a lock key or a query without being
//! checked again.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::meta::validate_serial;

/// A valid unit serial (1–64 letters, digits, `-`, `_`, `.`, starting with
/// a letter or digit). Made only by parsing; JSON is the plain string.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct UnitSerial(String);

impl UnitSerial {
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl TryFrom<String> for UnitSerial {
    /// [`validate_serial`]'s message.
    type Error = String;

    fn try_from(serial: String) -> Result<Self, String> {
        validate_serial(&serial)?;
        Ok(UnitSerial(serial))
    }
}

impl FromStr for UnitSerial {
    type Err = String;

    fn from_str(serial: &str) -> Result<Self, String> {
        UnitSerial::try_from(serial.to_string())
    }
}

impl From<UnitSerial> for String {
    fn from(serial: UnitSerial) -> String {
        serial.0
    }
}

impl AsRef<str> for UnitSerial {
    fn as_ref(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for UnitSerial {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_as_validate_serial_checks() {
        for bad in ["", "../etc", "RLG 42", ".hidden", "é"] {
            let err = bad.parse::<UnitSerial>().unwrap_err();
            assert_eq!(err, validate_serial(bad).unwrap_err());
        }
        let s: UnitSerial = "RLG-0042".parse().unwrap();
        assert_eq!((s.as_str(), s.to_string()), ("RLG-0042", "RLG-0042".into()));
    }

    #[test]
    fn json_is_the_plain_string() {
        let s: UnitSerial = serde_json::from_str(r#""u_1.2""#).unwrap();
        assert_eq!(serde_json::to_string(&s).unwrap(), r#""u_1.2""#);
        let err = serde_json::from_str::<UnitSerial>(r#""a/b""#).unwrap_err();
        assert!(
            err.to_string().contains("unit_serial \"a/b\" contains '/'"),
            "{err}"
        );
    }
}
