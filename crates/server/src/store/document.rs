//! Documents the store keeps as JSON text (a result, a diagnosis report, a
//! run's metadata), handed back with the type they hold: a caller either
//! parses one into that type or serves the text as stored, which for a
//! result is mostly the convergence history and is not worth a parse and
//! a re-serialise. A document enters the store as its type, serialised
//! here, so the text is always one `T`'s.

use std::fmt;
use std::marker::PhantomData;

use serde::de::DeserializeOwned;
use serde::Serialize;

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

impl<T: Serialize + DeserializeOwned> Stored<T> {
    /// The document of `value`, as the store will keep it.
    pub fn of(value: &T) -> Result<Self, serde_json::Error> {
        serde_json::to_string(value).map(Stored::new)
    }
}

/// A stored document read back from its column (the store's rows decode
/// through this).
impl<T: DeserializeOwned> From<String> for Stored<T> {
    fn from(json: String) -> Self {
        Stored::new(json)
    }
}

impl<T> Clone for Stored<T> {
    fn clone(&self) -> Self {
        Stored {
            json: self.json.clone(),
            holds: PhantomData,
        }
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
