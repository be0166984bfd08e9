//! Request extractors whose every rejection is a problem+json [`ApiError`], never a
//! plain-text axum rejection.

use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, QueryRejection};
use axum::extract::{FromRequest, FromRequestParts, Query, Request};
use axum::http::{HeaderMap, StatusCode, header, request::Parts};
use serde::de::DeserializeOwned;

use crate::error::ApiError;

/// The media type family of a request body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MediaType {
    /// `application/json` or any `+json` type.
    Json,
    /// `application/x-www-form-urlencoded`.
    Form,
    /// Anything else (named in the error).
    Other,
    /// No `Content-Type` header.
    Missing,
}

/// Classifies the request's `Content-Type`.
pub fn media_type(headers: &HeaderMap) -> MediaType {
    let Some(v) = headers.get(header::CONTENT_TYPE) else {
        return MediaType::Missing;
    };
    let Ok(v) = v.to_str() else {
        return MediaType::Other;
    };
    let essence = v
        .split(';')
        .next()
        .unwrap_or("")
        .trim()
        .to_ascii_lowercase();
    if essence == "application/json" || essence.ends_with("+json") {
        MediaType::Json
    } else if essence == "application/x-www-form-urlencoded" {
        MediaType::Form
    } else {
        MediaType::Other
    }
}

/// The raw request body, with size-limit and read failures mapped to problem+json.
pub struct Body(pub Bytes);

impl<S: Send + Sync> FromRequest<S> for Body {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        Bytes::from_request(req, state)
            .await
            .map(Body)
            .map_err(bytes_rejection)
    }
}

fn bytes_rejection(r: BytesRejection) -> ApiError {
    if r.status() == StatusCode::PAYLOAD_TOO_LARGE {
        ApiError::PayloadTooLarge(format!(
            "the request body is larger than this server accepts ({r}); send smaller batches or raise --max-body-bytes"
        ))
    } else {
        ApiError::bad_request(format!("could not read the request body: {r}"))
    }
}

/// Parses JSON bytes into `T`, naming the offending field of a type error (400).
pub fn parse_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, ApiError> {
    Ok(wire::error::from_slice(bytes)?)
}

/// Insists on a JSON content type.
pub fn require_json(headers: &HeaderMap) -> Result<(), ApiError> {
    match media_type(headers) {
        MediaType::Json => Ok(()),
        MediaType::Missing => Err(ApiError::UnsupportedMediaType(
            "this endpoint takes a JSON body: send Content-Type: application/json".into(),
        )),
        _ => Err(ApiError::UnsupportedMediaType(format!(
            "this endpoint takes a JSON body, not {}",
            headers
                .get(header::CONTENT_TYPE)
                .and_then(|v| v.to_str().ok())
                .unwrap_or("?")
        ))),
    }
}

/// A JSON request body: checks the content type and names the field of any type error.
/// Use it instead of `axum::Json` for every input.
pub struct ApiJson<T>(pub T);

impl<S: Send + Sync, T: DeserializeOwned> FromRequest<S> for ApiJson<T> {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        require_json(req.headers())?;
        let Body(bytes) = Body::from_request(req, state).await?;
        parse_json(&bytes).map(ApiJson)
    }
}

/// A query string, with parse failures as problem+json naming the parameter.
pub struct ApiQuery<T>(pub T);

impl<S: Send + Sync, T: DeserializeOwned> FromRequestParts<S> for ApiQuery<T> {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, Self::Rejection> {
        Query::<T>::from_request_parts(parts, state)
            .await
            .map(|Query(v)| ApiQuery(v))
            .map_err(|e: QueryRejection| {
                ApiError::bad_request(format!("invalid query string: {}", e.body_text()))
            })
    }
}

/// `#[serde(default, deserialize_with = "crate::extract::opt_integer")]` for an optional
/// integer field: JSON Schema counts `301.0` as an integer, so an integral number written
/// with a fraction is accepted; a fractional one (`1.5`) or one out of `T`'s range is a
/// type error naming the field.
pub(crate) fn opt_integer<'de, D, T>(d: D) -> Result<Option<T>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: TryFrom<i128>,
{
    use serde::Deserialize;
    use serde::de::Error;
    let Some(n) = Option::<serde_json::Number>::deserialize(d)? else {
        return Ok(None);
    };
    let v: i128 = match (n.as_u64(), n.as_i64(), n.as_f64()) {
        (Some(u), _, _) => u.into(),
        (_, Some(i), _) => i.into(),
        (_, _, Some(f)) if f.fract() == 0.0 && f.abs() < 1.8e19 => f as i128,
        _ => return Err(D::Error::custom(format!("{n} is not an integer"))),
    };
    T::try_from(v)
        .map(Some)
        .map_err(|_| D::Error::custom(format!("{n} is out of range")))
}

#[cfg(test)]
mod tests {
    #[derive(Debug, serde::Deserialize)]
    struct Body {
        #[serde(default, deserialize_with = "super::opt_integer")]
        n: Option<u8>,
    }

    fn n(json: &str) -> Result<Option<u8>, String> {
        serde_json::from_str::<Body>(json)
            .map(|b| b.n)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn integral_numbers_are_integers_whatever_their_spelling() {
        assert_eq!(n(r#"{"n": 7}"#), Ok(Some(7)));
        assert_eq!(n(r#"{"n": 7.0}"#), Ok(Some(7)));
        assert_eq!(n(r#"{"n": 7e0}"#), Ok(Some(7)));
        assert_eq!(n(r#"{}"#), Ok(None));
        assert_eq!(n(r#"{"n": null}"#), Ok(None));
        assert!(n(r#"{"n": 7.5}"#).unwrap_err().contains("not an integer"));
        assert!(n(r#"{"n": 256}"#).unwrap_err().contains("out of range"));
        assert!(n(r#"{"n": -1}"#).unwrap_err().contains("out of range"));
        assert!(n(r#"{"n": "7"}"#).is_err());
    }
}
