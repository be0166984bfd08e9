//! Telemetry ingest: moving-obstacle observations (interop 2017/2018 `/api/obstacles`
//! snapshots, or native batches) and aircraft telemetry (native JSON, interop 2018
//! form-encoded, interop 2019 JSON). Stored durably, ordered by timestamp whatever order
//! they arrive in; a resent observation is counted as a duplicate, not stored twice.

use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};
use utoipa_axum::{router::OpenApiRouter, routes};

use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::{ApiQuery, Body, MediaType, media_type, parse_json};
use crate::store::InsertCounts;
use crate::time::{WireTime, now_s};
use crate::timing::ServerTiming;
use axum::response::IntoResponse;
use wire::ids::MissionId;
use wire::telemetry::{
    AircraftSample, AircraftTelemetry, AircraftTelemetryOut, ObservationBatch, ObservationOut,
    parse_observations, parse_telemetry_form, parse_telemetry_json,
};

/// What happened to a posted batch.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub(crate) struct IngestResult {
    /// Newly stored.
    pub accepted: u64,
    /// Already stored (same obstacle and timestamp, or same aircraft timestamp); ignored.
    pub duplicate: u64,
}

impl From<InsertCounts> for IngestResult {
    fn from(c: InsertCounts) -> Self {
        Self {
            accepted: c.accepted,
            duplicate: c.duplicate,
        }
    }
}

/// `?time=` for interop snapshots.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub(crate) struct SnapshotParams {
    /// Time of an interop snapshot (RFC 3339 or Unix seconds) when the body has no `time`;
    /// receipt time when neither is given.
    #[param(value_type = Option<WireTime>)]
    pub time: Option<WireTime>,
}

/// Post moving-obstacle observations.
///
/// Native: `{"observations": [{"obstacle_id", "t", "lat", "lon", "alt_msl_m", "radius_m"}]}`.
/// Interop 2017/2018: the `/api/obstacles` snapshot as the judges' server sent it (feet);
/// each moving obstacle's id is its index in the list (`"0"`, `"1"`, ...), stamped with the
/// body's `time`, else `?time=`, else the time of receipt. Stationary obstacles in a
/// snapshot are already part of the mission and are not stored.
#[utoipa::path(post, path = "/api/v1/missions/{id}/obstacles", tag = "telemetry",
    params(("id" = String, Path, description = "Mission id"), SnapshotParams),
    request_body(content = ObservationBatch, description = "Native batch, or an interop 2017/2018 obstacle snapshot", content_type = "application/json"),
    responses(
        (status = 202, description = "Stored; counts of new and duplicate observations", body = IngestResult),
        (status = 422, description = "Invalid observation, the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn post_obstacles(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(params): ApiQuery<SnapshotParams>,
    headers: HeaderMap,
    Body(body): Body,
) -> Result<axum::response::Response, ApiError> {
    let mut timing = ServerTiming::start();
    crate::extract::require_json(&headers)?;
    let value: serde_json::Value = parse_json(&body)?;
    crate::limits::check_items(&value, &state.settings.access.items)?;
    let received = now_s();
    let rows = parse_observations(value, params.time.map(|t| t.0), received)?;
    timing.lap("parse");
    // The insert itself answers "no such mission" (a foreign key), in one round trip.
    let batch = state
        .store
        .insert_observations(&id, &rows, received)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &id))?;
    timing.lap("store");
    state.live.apply(&state, &id, &batch).await;
    timing.lap("live");
    let mut resp = (
        StatusCode::ACCEPTED,
        axum::Json(IngestResult::from(batch.counts)),
    )
        .into_response();
    crate::timing::insert(&mut resp, &timing);
    Ok(resp)
}

/// `?obstacle_id=&after=` of the observation listing.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub(crate) struct ObservationQuery {
    /// Only this obstacle's observations.
    pub obstacle_id: Option<String>,
    /// Only observations strictly after this time (RFC 3339 or Unix seconds).
    #[param(value_type = Option<WireTime>)]
    pub after: Option<WireTime>,
}

/// The stored observations, ordered by time.
#[utoipa::path(get, path = "/api/v1/missions/{id}/observations", tag = "telemetry",
    params(("id" = String, Path, description = "Mission id"), ObservationQuery),
    responses(
        (status = 200, description = "Observations ordered by time, then obstacle id", body = [ObservationOut]),
    ))]
async fn list_observations(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<ObservationQuery>,
) -> Result<axum::Json<Vec<serde_json::Value>>, ApiError> {
    super::missions::ensure_exists(&state, &id).await?;
    let rows = state
        .store
        .list_observations_written(&id, q.obstacle_id.as_deref(), q.after.map(|t| t.0))
        .await?;
    Ok(axum::Json(
        rows.iter()
            .map(|(r, w)| crate::auth::with_writer(&ObservationOut::from(r), w))
            .collect(),
    ))
}

/// The aircraft samples of a telemetry body: JSON (native or interop 2019+, its items
/// counted against the limits) or an interop 2017/2018 form, stamped `received` when they
/// carry no time; any other media type is a 415 saying `unsupported`.
pub(crate) fn telemetry_rows(
    state: &AppState,
    headers: &HeaderMap,
    body: &[u8],
    received: f64,
    unsupported: &str,
) -> Result<Vec<AircraftSample>, ApiError> {
    Ok(match media_type(headers) {
        MediaType::Form => vec![parse_telemetry_form(body, received)?],
        MediaType::Json => {
            let value: serde_json::Value = parse_json(body)?;
            crate::limits::check_items(&value, &state.settings.access.items)?;
            parse_telemetry_json(value, received)?
        }
        _ => return Err(ApiError::UnsupportedMediaType(unsupported.into())),
    })
}

/// Post aircraft telemetry.
///
/// Native JSON `{"t", "lat", "lon", "alt_msl_m", "heading_deg", "speed_mps"}` (or a list
/// of them); interop 2019 JSON `{"latitude", "longitude", "altitude" (ft), "heading"}`;
/// interop 2018 form-encoded `latitude`, `longitude`, `altitude_msl` (ft), `uas_heading`.
/// Interop samples carry no time and are stamped on receipt.
#[utoipa::path(post, path = "/api/v1/missions/{id}/telemetry", tag = "telemetry",
    params(("id" = String, Path, description = "Mission id")),
    request_body(content = AircraftTelemetry, description = "Native or interop 2019 JSON, or interop 2018 form-encoded", content_type = "application/json"),
    responses(
        (status = 202, description = "Stored", body = IngestResult),
        (status = 415, description = "Neither JSON nor form-encoded", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "Invalid sample, the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn post_telemetry(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    headers: HeaderMap,
    Body(body): Body,
) -> Result<axum::response::Response, ApiError> {
    let mut timing = ServerTiming::start();
    let received = now_s();
    let rows = telemetry_rows(
        &state,
        &headers,
        &body,
        received,
        "aircraft telemetry is application/json (native or interop 2019) or application/x-www-form-urlencoded (interop 2018)",
    )?;
    timing.lap("parse");
    let counts = state
        .store
        .insert_telemetry(&id, &rows, received)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &id))?;
    timing.lap("store");
    let mut resp = (StatusCode::ACCEPTED, axum::Json(IngestResult::from(counts))).into_response();
    crate::timing::insert(&mut resp, &timing);
    Ok(resp)
}

/// `?last=` of the telemetry listing.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub(crate) struct TelemetryQuery {
    /// Only the newest n samples.
    #[param(value_type = Option<u64>, minimum = 0, maximum = 4294967295_u64)]
    pub last: Option<u32>,
}

/// The stored aircraft telemetry, ordered by time.
#[utoipa::path(get, path = "/api/v1/missions/{id}/telemetry", tag = "telemetry",
    params(("id" = String, Path, description = "Mission id"), TelemetryQuery),
    responses(
        (status = 200, description = "Samples ordered by time", body = [AircraftTelemetryOut]),
    ))]
async fn list_telemetry(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<TelemetryQuery>,
) -> Result<axum::Json<Vec<serde_json::Value>>, ApiError> {
    super::missions::ensure_exists(&state, &id).await?;
    let rows = state.store.list_telemetry_written(&id, q.last).await?;
    Ok(axum::Json(
        rows.iter()
            .map(|(r, w)| crate::auth::with_writer(&AircraftTelemetryOut::from(r), w))
            .collect(),
    ))
}

/// Telemetry routes.
pub(crate) fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(post_obstacles))
        .routes(routes!(list_observations))
        .routes(routes!(post_telemetry, list_telemetry))
}
