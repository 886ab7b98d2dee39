//! Documents the store keeps as JSON text (a result, a diagnosis report),
//! handed back with the type they hold: a caller either parses one into
//! that type or serves the text as stored, which for a result is mostly
//! the convergence history and is not worth a parse and a re-serialise.

use std::fmt;
use std::marker::PhantomData;

use serde::de::DeserializeOwned;

/// The stored JSON of one `T`, as the writer serialised it.
pub struct Stored<T> {
    json: String,
    holds: PhantomData<fn() -> T>,
}

impl<T: DeserializeOwned> Stored<T> {
    pub(super) fn new(json: String) -> Self {
        Stored {
            json,
            holds: PhantomData,
        }
    }

    /// The document as its type (up to half a megabyte of JSON for a
    /// result: parse it off the async workers).
    pub fn parse(&self) -> Result<T, serde_json::Error> {
        serde_json::from_str(&self.json)
    }

    pub fn as_json(&self) -> &str {
        &self.json
    }

    pub fn into_json(self) -> String {
        self.json
    }
}

impl<T> fmt::Debug for Stored<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Stored<{}>({} bytes)",
            std::any::type_name::<T>(),
            self.json.len()
        )
    }
}
