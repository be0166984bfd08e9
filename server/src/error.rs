//! The service's one error type and its RFC 9457 `application/problem+json` rendering.
//!
//! Internal details (database errors, panics) are logged, never returned. Validation
//! failures carry one entry per offending field, each with a JSON pointer into the request
//! body as the client sent it.

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use utoipa::ToSchema;

pub use wire::error::{FieldError, WireError};

/// Every way a request can fail.
#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    /// The body or query could not be parsed (400), or it parsed but some fields are
    /// invalid (422); the offending fields are named by pointers.
    #[error(transparent)]
    Wire(#[from] WireError),
    /// The addressed resource does not exist (404).
    #[error("{what} '{id}' does not exist")]
    NotFound { what: &'static str, id: String },
    /// The request conflicts with the current state (409).
    #[error("{0}")]
    Conflict(String),
    /// A plan named a base revision older than the mission's latest (409). The problem
    /// document carries the latest as `latest_revision`, so a client can replan from it
    /// without parsing the detail.
    #[error(
        "base_revision {base_revision} is older than the latest revision {latest}: plan from revision {latest}"
    )]
    StaleBase { base_revision: i64, latest: i64 },
    /// A plan named a base revision that does not exist (422, pointer `/base_revision`);
    /// the problem document carries the latest as `latest_revision`.
    #[error("revision {base_revision} does not exist (latest is {latest})")]
    NoSuchBase { base_revision: i64, latest: i64 },
    /// The body's media type is not accepted here (415).
    #[error("{0}")]
    UnsupportedMediaType(String),
    /// The body is larger than the configured limit (413).
    #[error("{0}")]
    PayloadTooLarge(String),
    /// No route answers this path (404) or this method (405).
    #[error("{detail}")]
    Route { status: StatusCode, detail: String },
    /// Something failed inside the service (500); the detail is logged, not returned.
    #[error("internal error: {0}")]
    Internal(String),
    /// No credentials, or credentials that name no valid token (401).
    #[error("{0}")]
    Unauthorized(String),
    /// The token's role does not allow this request (403).
    #[error("{0}")]
    Forbidden(String),
    /// More items in one request than the server accepts (413); the pointer names the list.
    #[error("{pointer} has {count} items; at most {max} are accepted per request")]
    TooManyItems {
        pointer: String,
        count: usize,
        max: usize,
    },
    /// The token's write rate is exhausted (429); retry after `retry_after_s`.
    #[error("{detail}")]
    TooManyRequests { detail: String, retry_after_s: u64 },
    /// The service is saturated or the request took too long (503); retry after
    /// `retry_after_s`.
    #[error("{detail}")]
    Unavailable {
        slug: &'static str,
        detail: String,
        retry_after_s: u64,
    },
}

impl ApiError {
    /// A single-field validation error.
    pub fn field(pointer: impl Into<String>, detail: impl Into<String>) -> Self {
        Self::Wire(WireError::field(pointer, detail))
    }

    /// A validation error listing every invalid field (422).
    pub fn validation(errs: Vec<FieldError>) -> Self {
        Self::Wire(WireError::Validation(errs))
    }

    /// A request that could not be parsed, no field named (400).
    pub fn bad_request(detail: impl Into<String>) -> Self {
        Self::Wire(WireError::BadRequest {
            detail: detail.into(),
            pointer: None,
        })
    }

    /// A 404 for `what` with id `id`.
    pub fn not_found(what: &'static str, id: impl Into<String>) -> Self {
        Self::NotFound {
            what,
            id: id.into(),
        }
    }

    /// The HTTP status this error maps to.
    pub fn status(&self) -> StatusCode {
        match self {
            Self::Wire(WireError::Validation(_)) => StatusCode::UNPROCESSABLE_ENTITY,
            Self::Wire(WireError::BadRequest { .. }) => StatusCode::BAD_REQUEST,
            Self::NotFound { .. } => StatusCode::NOT_FOUND,
            Self::Conflict(_) | Self::StaleBase { .. } => StatusCode::CONFLICT,
            Self::NoSuchBase { .. } => StatusCode::UNPROCESSABLE_ENTITY,
            Self::UnsupportedMediaType(_) => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            Self::PayloadTooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            Self::Route { status, .. } => *status,
            Self::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
            Self::Unauthorized(_) => StatusCode::UNAUTHORIZED,
            Self::Forbidden(_) => StatusCode::FORBIDDEN,
            Self::TooManyItems { .. } => StatusCode::PAYLOAD_TOO_LARGE,
            Self::TooManyRequests { .. } => StatusCode::TOO_MANY_REQUESTS,
            Self::Unavailable { .. } => StatusCode::SERVICE_UNAVAILABLE,
        }
    }

    fn kind(&self) -> (&'static str, &'static str) {
        match self {
            Self::Wire(WireError::Validation(_)) | Self::NoSuchBase { .. } => {
                ("validation", "Invalid request content")
            }
            Self::Wire(WireError::BadRequest { .. }) => ("bad-request", "Malformed request"),
            Self::NotFound { .. } => ("not-found", "Resource not found"),
            Self::Conflict(_) | Self::StaleBase { .. } => {
                ("conflict", "Conflict with the current state")
            }
            Self::UnsupportedMediaType(_) => ("unsupported-media-type", "Unsupported media type"),
            Self::PayloadTooLarge(_) => ("payload-too-large", "Request body too large"),
            Self::Route { status, .. } if *status == StatusCode::METHOD_NOT_ALLOWED => {
                ("method-not-allowed", "Method not allowed")
            }
            Self::Route { .. } => ("no-such-route", "No such route"),
            Self::Internal(_) => ("internal", "Internal server error"),
            Self::Unauthorized(_) => ("unauthorized", "Authentication required"),
            Self::Forbidden(_) => ("forbidden", "Not allowed for this token's role"),
            Self::TooManyItems { .. } => ("too-many-items", "Too many items in one request"),
            Self::TooManyRequests { .. } => ("rate-limited", "Too many requests"),
            Self::Unavailable { slug, .. } => (slug, "Service unavailable, retry later"),
        }
    }

    /// The problem document for this error.
    pub fn problem(&self) -> Problem {
        let (slug, title) = self.kind();
        let status = self.status();
        let (detail, errors) = match self {
            Self::Wire(WireError::Validation(errs)) => {
                let first = errs.first().map(|e| format!("{}: {}", e.pointer, e.detail));
                (first.unwrap_or_else(|| self.to_string()), errs.clone())
            }
            Self::Wire(WireError::BadRequest {
                detail,
                pointer: Some(p),
            }) => (
                detail.clone(),
                vec![FieldError::new(p.clone(), detail.clone())],
            ),
            Self::Internal(_) => (
                "the service failed to handle the request; it has been logged".into(),
                vec![],
            ),
            Self::TooManyItems { pointer, .. } => (
                self.to_string(),
                vec![FieldError::new(pointer.clone(), self.to_string())],
            ),
            Self::NoSuchBase { .. } => (
                format!("/base_revision: {self}"),
                vec![FieldError::new("/base_revision", self.to_string())],
            ),
            other => (other.to_string(), vec![]),
        };
        let latest_revision = match self {
            Self::StaleBase { latest, .. } | Self::NoSuchBase { latest, .. } => Some(*latest),
            _ => None,
        };
        Problem {
            type_: format!("urn:jink:problem:{slug}"),
            title: title.to_string(),
            status: status.as_u16(),
            detail,
            errors,
            latest_revision,
        }
    }
}

/// An RFC 9457 problem document, as every 4xx/5xx answer carries it.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Problem {
    /// A URI naming the kind of problem, e.g. `urn:jink:problem:validation`.
    #[serde(rename = "type")]
    pub type_: String,
    /// A short summary of the kind of problem.
    pub title: String,
    /// The HTTP status code.
    pub status: u16,
    /// What went wrong with this request; for validation failures, the first field's
    /// pointer and message.
    pub detail: String,
    /// The invalid fields (validation and parse errors), each with a JSON pointer.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub errors: Vec<FieldError>,
    /// The mission's latest plan revision, when a plan's `base_revision` was refused
    /// (409: older than the latest; 422: no such revision). Replan with this as
    /// `base_revision`, or without one from the mission's waypoints.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0)]
    pub latest_revision: Option<i64>,
}

/// The media type of problem documents.
pub const PROBLEM_JSON: &str = "application/problem+json";

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let status = self.status();
        let problem = self.problem();
        let body = serde_json::to_vec(&problem).unwrap_or_default();
        let mut resp = (status, body).into_response();
        resp.headers_mut()
            .insert(header::CONTENT_TYPE, HeaderValue::from_static(PROBLEM_JSON));
        // The logging middleware reads this to log internal failures with their cause.
        if let Self::Internal(msg) = &self {
            resp.extensions_mut().insert(InternalCause(msg.clone()));
        }
        match &self {
            Self::TooManyRequests { retry_after_s, .. }
            | Self::Unavailable { retry_after_s, .. } => {
                resp.headers_mut()
                    .insert(header::RETRY_AFTER, HeaderValue::from(*retry_after_s));
            }
            Self::Unauthorized(_) => {
                // Bearer for API clients; Basic makes a browser prompt (the token is the
                // password), so the operator page works on a guarded bind.
                resp.headers_mut().insert(
                    header::WWW_AUTHENTICATE,
                    HeaderValue::from_static(
                        r#"Bearer realm="jink", Basic realm="jink", charset="UTF-8""#,
                    ),
                );
            }
            _ => {}
        }
        resp
    }
}

/// The hidden cause of a 500, carried to the logging middleware in the response's
/// extensions.
#[derive(Debug, Clone)]
pub struct InternalCause(pub String);

impl From<sqlx::Error> for ApiError {
    fn from(e: sqlx::Error) -> Self {
        Self::Internal(format!("database: {e}"))
    }
}

impl From<tokio::task::JoinError> for ApiError {
    fn from(e: tokio::task::JoinError) -> Self {
        Self::Internal(format!("background task: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_validation_error_names_its_first_field_in_the_detail() {
        let e = ApiError::validation(vec![
            FieldError::new("/waypoints/1/lat", "latitude 91 is outside [-90, 90]"),
            FieldError::new("/fly_zones", "at least one fly zone is required"),
        ]);
        let p = e.problem();
        assert_eq!(p.status, 422);
        assert_eq!(p.type_, "urn:jink:problem:validation");
        assert!(p.detail.starts_with("/waypoints/1/lat"));
        assert_eq!(p.errors.len(), 2);
    }

    #[test]
    fn a_refused_base_revision_names_the_latest_revision() {
        let stale = ApiError::StaleBase {
            base_revision: 2,
            latest: 5,
        };
        let p = stale.problem();
        assert_eq!(
            (p.status, p.type_.as_str()),
            (409, "urn:jink:problem:conflict")
        );
        assert_eq!(p.latest_revision, Some(5));
        assert!(p.errors.is_empty());
        let v = serde_json::to_value(&p).unwrap();
        assert_eq!(v["latest_revision"], 5);

        let gone = ApiError::NoSuchBase {
            base_revision: 9,
            latest: 5,
        };
        let p = gone.problem();
        assert_eq!(
            (p.status, p.type_.as_str()),
            (422, "urn:jink:problem:validation")
        );
        assert_eq!(p.latest_revision, Some(5));
        assert_eq!(p.errors.len(), 1);
        assert_eq!(p.errors[0].pointer, "/base_revision");
        assert_eq!(
            p.detail,
            "/base_revision: revision 9 does not exist (latest is 5)"
        );

        // Other problems do not carry the member at all.
        let v = serde_json::to_value(ApiError::Conflict("x".into()).problem()).unwrap();
        assert!(v.get("latest_revision").is_none(), "{v}");
    }

    #[test]
    fn internal_errors_do_not_leak_their_cause() {
        let p = ApiError::Internal("database: disk I/O error at /secret/path".into()).problem();
        assert_eq!(p.status, 500);
        assert!(!p.detail.contains("secret"));
    }
}
