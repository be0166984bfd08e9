//! Errors of wire parsing and validation, each naming the offending field by an RFC 6901
//! JSON pointer into the document as the client sent it (in the client's own field names).
//!
//! The server maps [`WireError::BadRequest`] to HTTP 400 and [`WireError::Validation`] to 422,
//! both as problem+json listing the pointers.

use serde::Serialize;
use serde::de::DeserializeOwned;

/// One invalid field of a request.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FieldError {
    /// RFC 6901 JSON pointer to the field in the request body (or `#/query/<name>` for a
    /// query parameter), e.g. `/waypoints/3/lat`.
    pub pointer: String,
    /// What is wrong with it, for a person.
    pub detail: String,
}

impl FieldError {
    /// A field error at `pointer`.
    pub fn new(pointer: impl Into<String>, detail: impl Into<String>) -> Self {
        Self {
            pointer: pointer.into(),
            detail: detail.into(),
        }
    }
}

/// Why a wire document was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WireError {
    /// The document parsed but some fields are invalid (every one listed).
    #[error("the request has {} invalid field(s)", .0.len())]
    Validation(Vec<FieldError>),
    /// The document does not parse; `pointer` names the field when known.
    #[error("{detail}")]
    BadRequest {
        detail: String,
        pointer: Option<String>,
    },
}

impl WireError {
    /// A single-field validation error.
    pub fn field(pointer: impl Into<String>, detail: impl Into<String>) -> Self {
        Self::Validation(vec![FieldError::new(pointer, detail)])
    }
}

/// Deserializes an already parsed JSON value into `T`, naming the offending field.
///
/// # Errors
/// [`WireError::BadRequest`] with the pointer of the field that does not parse.
pub fn from_value<T: DeserializeOwned>(value: serde_json::Value) -> Result<T, WireError> {
    serde_path_to_error::deserialize(value).map_err(field_type_error)
}

/// Parses JSON bytes into `T`, naming the offending field of a type error.
///
/// # Errors
/// [`WireError::BadRequest`]: without a pointer when the bytes are not JSON at all, else
/// with the pointer of the field that does not parse.
pub fn from_slice<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, WireError> {
    let de = &mut serde_json::Deserializer::from_slice(bytes);
    serde_path_to_error::deserialize(de).map_err(|e| {
        if e.inner().is_syntax() || e.inner().is_eof() {
            WireError::BadRequest {
                detail: format!("the body is not valid JSON: {}", e.into_inner()),
                pointer: None,
            }
        } else {
            field_type_error(e)
        }
    })
}

/// A field of the wrong type, named by its pointer (also at the start of the detail).
fn field_type_error(e: serde_path_to_error::Error<serde_json::Error>) -> WireError {
    let pointer = serde_path_to_pointer(e.path());
    let inner = e.into_inner();
    WireError::BadRequest {
        detail: format!(
            "{}: {inner}",
            if pointer.is_empty() { "/" } else { &pointer }
        ),
        pointer: Some(pointer),
    }
}

/// Turns a `serde_path_to_error` path (`waypoints[2].lat`) into a JSON pointer
/// (`/waypoints/2/lat`).
pub fn serde_path_to_pointer(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => out.push_str(&format!("/{index}")),
            Segment::Map { key } => out.push_str(&format!("/{}", escape_pointer(key))),
            Segment::Enum { variant } => out.push_str(&format!("/{}", escape_pointer(variant))),
            Segment::Unknown => out.push_str("/?"),
        }
    }
    out
}

/// Escapes one JSON pointer reference token (RFC 6901: `~` -> `~0`, `/` -> `~1`).
pub fn escape_pointer(token: &str) -> String {
    token.replace('~', "~0").replace('/', "~1")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointer_tokens_are_escaped() {
        assert_eq!(escape_pointer("a/b~c"), "a~1b~0c");
    }

    #[test]
    fn bytes_that_are_not_json_name_no_field_and_a_wrong_type_names_its_field() {
        match from_slice::<Vec<f64>>(b"[1.0, ").unwrap_err() {
            WireError::BadRequest { pointer, detail } => {
                assert_eq!(pointer, None);
                assert!(detail.starts_with("the body is not valid JSON"), "{detail}");
            }
            other => panic!("{other:?}"),
        }
        match from_slice::<Vec<f64>>(b"[1.0, true]").unwrap_err() {
            WireError::BadRequest { pointer, .. } => assert_eq!(pointer.as_deref(), Some("/1")),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_bad_field_is_named_by_its_pointer() {
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct P {
            pts: Vec<f64>,
        }
        let e = from_value::<P>(serde_json::json!({"pts": [1.0, "x"]})).unwrap_err();
        match e {
            WireError::BadRequest { pointer, detail } => {
                assert_eq!(pointer.as_deref(), Some("/pts/1"));
                assert!(detail.starts_with("/pts/1: "), "{detail}");
            }
            other => panic!("{other:?}"),
        }
    }
}
