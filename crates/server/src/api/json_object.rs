//! A JSON request body that must be an object. serde's derived structs
//! also take a JSON array, field by field in order, so a request whose
//! fields are all optional (a design request) would read `[null, null]`
//! as "every default" and run. The body is read as an object first, then
//! into its type; anything else is refused as 422.

use axum::extract::{FromRequest, OptionalFromRequest, Request};
use axum::http::header::{CONTENT_LENGTH, CONTENT_TYPE, TRANSFER_ENCODING};
use axum::Json;
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};

use super::error::ApiError;

/// The request's JSON body, an object, as a `T`.
pub(crate) struct JsonObject<T>(pub T);

impl<T, S> FromRequest<S> for JsonObject<T>
where
    T: DeserializeOwned,
    S: Send + Sync,
{
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, ApiError> {
        let Json(object) = <Json<Value> as FromRequest<S>>::from_request(req, state).await?;
        match object {
            Value::Object(fields) => into_type(fields).map(JsonObject),
            other => Err(ApiError::Unprocessable(format!(
                "the request body must be a JSON object, not {}",
                kind_of(&other)
            ))),
        }
    }
}

/// A body that may be left out: none at all (no content type, no length
/// or a length of 0) is `None`; anything else is read as above.
impl<T, S> OptionalFromRequest<S> for JsonObject<T>
where
    T: DeserializeOwned,
    S: Send + Sync,
{
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Option<Self>, ApiError> {
        let headers = req.headers();
        let sent = headers.contains_key(CONTENT_TYPE)
            || headers.contains_key(TRANSFER_ENCODING)
            || headers.get(CONTENT_LENGTH).is_some_and(|n| n != "0");
        if !sent {
            return Ok(None);
        }
        <Self as FromRequest<S>>::from_request(req, state)
            .await
            .map(Some)
    }
}

/// The object as a `T`, a refusal naming the field at fault (as axum's
/// `Json` does).
fn into_type<T: DeserializeOwned>(fields: Map<String, Value>) -> Result<T, ApiError> {
    serde_path_to_error::deserialize(Value::Object(fields)).map_err(|e| {
        let at = e.path().to_string();
        let at = if at == "." {
            String::new()
        } else {
            format!("{at}: ")
        };
        ApiError::Unprocessable(format!(
            "Failed to deserialize the JSON body into the target type: {at}{}",
            e.inner()
        ))
    })
}

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}
