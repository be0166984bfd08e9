//! The HTTP API under `/api/v1` plus the service routes, every one of them in the
//! OpenAPI document (they are registered only through [`OpenApiRouter::routes`]).
//!
//! Each resource module owns its router and its wire types.

use utoipa::OpenApi;
use utoipa_axum::router::OpenApiRouter;

use crate::app::AppState;

pub mod avoid;
pub mod doc;
pub mod health;
pub mod missions;
pub mod obstacles;
pub mod operator;
pub mod plan_compute;
pub mod plan_files;
pub mod plan_inputs;
pub mod plan_record;
pub mod plan_types;
pub mod plans;
pub mod reactive;
pub mod risk;
pub mod search;
pub mod telemetry;

/// The document's fixed parts; paths and schemas come from the routers.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "jink",
        description = "Ground-station planning service for fixed-wing UAVs flying SUAS-style missions: \
mission upload (native and interop formats), obstacle and aircraft telemetry, obstacle prediction, \
risk maps, avoidance plans and exports. Errors are RFC 9457 application/problem+json.",
        license(name = "MIT OR Apache-2.0", identifier = "MIT OR Apache-2.0"),
        version = "1"
    ),
    components(schemas(plans::PlanFormat, risk::RiskFormat)),
    tags(
        (name = "missions", description = "Mission upload and retrieval"),
        (name = "telemetry", description = "Obstacle observations and aircraft telemetry"),
        (name = "service", description = "Health, metrics and the API description"),
        (name = "plans", description = "Avoidance plans: revised waypoint stacks, diffs and exports"),
        (name = "avoid", description = "Seed 004 waypoint insertion for one leg and one obstacle; stateless"),
        (name = "prediction", description = "Obstacle characterization (stages, estimates, stage history) and risk maps (seed 002)"),
        (name = "reactive", description = "Onboard LiDAR avoiders (offset algorithm, Bezier pilot, sectors); stateless"),
        (name = "interop", description = "The judges' interoperability-server API (2017/2018 and 2019+, feet), so that existing interop clients talk to jink unchanged"),
    )
)]
pub struct ApiDoc;

/// Every documented route, with its OpenAPI description.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::with_openapi(ApiDoc::openapi())
        .merge(health::router())
        .merge(missions::router())
        .merge(telemetry::router())
        .merge(operator::router())
        .merge(crate::page::router())
        .merge(reactive::router())
        .merge(plans::router())
        .merge(plan_files::router())
        .merge(avoid::router())
        .merge(obstacles::router())
        .merge(risk::router())
        .merge(search::router())
        .merge(crate::interop::api::router())
    // jink:routes -- register each new API module above this line with `.merge(module::router())`
}

/// 303 See Other to `location` (an older query form answered by the operation that now
/// serves it). Build `location` from stored ids only, which are plain ASCII.
///
/// # Errors
/// 500 when `location` is not a valid header value.
pub(crate) fn see_other(
    location: &str,
) -> Result<axum::response::Response, crate::error::ApiError> {
    use axum::response::IntoResponse;
    let mut resp = axum::http::StatusCode::SEE_OTHER.into_response();
    resp.headers_mut().insert(
        axum::http::header::LOCATION,
        axum::http::HeaderValue::from_str(location)
            .map_err(|e| crate::error::ApiError::Internal(e.to_string()))?,
    );
    Ok(resp)
}

/// The OpenAPI document as the code describes it, completed by [`doc::complete`].
pub fn openapi() -> utoipa::openapi::OpenApi {
    let mut value =
        serde_json::to_value(router().into_openapi()).expect("the OpenAPI document serializes");
    doc::complete(&mut value);
    serde_json::from_value(value).expect("the completed OpenAPI document deserializes")
}

/// The OpenAPI document as pretty JSON with a trailing newline (what
/// `jink openapi` prints and `openapi/openapi.json` holds).
pub fn openapi_json() -> String {
    let mut s = openapi()
        .to_pretty_json()
        .expect("the OpenAPI document serializes");
    s.push('\n');
    s
}
