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
use crate::error::{ApiError, FieldError, Problem};
use crate::extract::{ApiQuery, Body, MediaType, from_value, media_type, parse_json};
use crate::interop::{self, ObstacleSnapshot2018, Telemetry2018, Telemetry2019};
use crate::store::{InsertCounts, ObservationRow, TelemetryRow};
use crate::time::{WireTime, now_s};
use wire::ids::MissionId;

/// One native moving-obstacle observation.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ObservationIn {
    /// The obstacle's id within the mission.
    pub obstacle_id: String,
    /// When it was observed (RFC 3339 or Unix seconds); receipt time when absent.
    #[serde(default)]
    pub t: Option<WireTime>,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude of the sphere's centre, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres (> 0).
    pub radius_m: f64,
}

/// A native batch of observations.
#[derive(Debug, Deserialize, ToSchema)]
pub struct ObservationBatch {
    /// The observations, in any order.
    pub observations: Vec<ObservationIn>,
}

/// A stored observation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ObservationOut {
    /// The obstacle's id.
    pub obstacle_id: String,
    /// Observation time, Unix seconds.
    pub t: f64,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// What happened to a posted batch.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct IngestResult {
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
pub struct SnapshotParams {
    /// Time of an interop snapshot (RFC 3339 or Unix seconds) when the body has no `time`;
    /// receipt time when neither is given.
    #[param(value_type = Option<String>)]
    pub time: Option<WireTime>,
}

fn check_position(
    errs: &mut Vec<FieldError>,
    at: &str,
    lat: f64,
    lon: f64,
    lat_key: &str,
    lon_key: &str,
) {
    let (lat_ptr, lon_ptr) = (format!("{at}/{lat_key}"), format!("{at}/{lon_key}"));
    wire::coords::check_lat_lon(errs, &lat_ptr, &lon_ptr, lat, lon);
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
        (status = 400, description = "Malformed body", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
        (status = 415, description = "Not JSON", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "Invalid observation, the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn post_obstacles(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(params): ApiQuery<SnapshotParams>,
    headers: HeaderMap,
    Body(body): Body,
) -> Result<(StatusCode, axum::Json<IngestResult>), ApiError> {
    crate::extract::require_json(&headers)?;
    let value: serde_json::Value = parse_json(&body)?;
    let received = now_s();
    let rows =
        if value.get("moving_obstacles").is_some() || value.get("stationary_obstacles").is_some() {
            let snap: ObstacleSnapshot2018 = from_value(value)?;
            let t = snap.time.or(params.time).map_or(received, |t| t.0);
            let mut errs = Vec::new();
            let rows: Vec<ObservationRow> = snap
                .moving_obstacles
                .iter()
                .enumerate()
                .map(|(i, o)| {
                    let at = format!("/moving_obstacles/{i}");
                    check_position(
                        &mut errs,
                        &at,
                        o.latitude,
                        o.longitude,
                        "latitude",
                        "longitude",
                    );
                    if !(o.sphere_radius.is_finite() && o.sphere_radius > 0.0) {
                        errs.push(FieldError::new(
                            format!("{at}/sphere_radius"),
                            "the sphere radius must be positive",
                        ));
                    }
                    if !o.altitude_msl.is_finite() {
                        errs.push(FieldError::new(
                            format!("{at}/altitude_msl"),
                            "altitude must be finite",
                        ));
                    }
                    ObservationRow {
                        obstacle_id: i.to_string(),
                        t_s: t,
                        lat_deg: o.latitude,
                        lon_deg: o.longitude,
                        alt_msl_m: interop::ft(o.altitude_msl),
                        radius_m: interop::ft(o.sphere_radius),
                    }
                })
                .collect();
            if !errs.is_empty() {
                return Err(ApiError::Validation(errs));
            }
            rows
        } else {
            let batch: ObservationBatch = from_value(value)?;
            validate_batch(&batch, received)?
        };
    // The insert itself answers "no such mission" (a foreign key), in one round trip.
    let batch = state
        .store
        .insert_observations(&id, &rows, received)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &id))?;
    state.live.apply(&state, &id, &batch).await;
    Ok((StatusCode::ACCEPTED, axum::Json(batch.counts.into())))
}

fn validate_batch(
    batch: &ObservationBatch,
    received: f64,
) -> Result<Vec<ObservationRow>, ApiError> {
    let mut errs = Vec::new();
    let rows = batch
        .observations
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let at = format!("/observations/{i}");
            if o.obstacle_id.trim().is_empty() {
                errs.push(FieldError::new(
                    format!("{at}/obstacle_id"),
                    "the obstacle id must not be empty",
                ));
            }
            check_position(&mut errs, &at, o.lat, o.lon, "lat", "lon");
            if !(o.radius_m.is_finite() && o.radius_m > 0.0) {
                errs.push(FieldError::new(
                    format!("{at}/radius_m"),
                    format!("the radius must be positive, got {}", o.radius_m),
                ));
            }
            if !o.alt_msl_m.is_finite() {
                errs.push(FieldError::new(
                    format!("{at}/alt_msl_m"),
                    "altitude must be finite",
                ));
            }
            ObservationRow {
                obstacle_id: o.obstacle_id.clone(),
                t_s: o.t.map_or(received, |t| t.0),
                lat_deg: o.lat,
                lon_deg: o.lon,
                alt_msl_m: o.alt_msl_m,
                radius_m: o.radius_m,
            }
        })
        .collect();
    if errs.is_empty() {
        Ok(rows)
    } else {
        Err(ApiError::Validation(errs))
    }
}

/// `?obstacle_id=&after=` of the observation listing.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ObservationQuery {
    /// Only this obstacle's observations.
    pub obstacle_id: Option<String>,
    /// Only observations strictly after this time (RFC 3339 or Unix seconds).
    #[param(value_type = Option<String>)]
    pub after: Option<WireTime>,
}

/// The stored observations, ordered by time.
#[utoipa::path(get, path = "/api/v1/missions/{id}/observations", tag = "telemetry",
    params(("id" = String, Path, description = "Mission id"), ObservationQuery),
    responses(
        (status = 200, description = "Observations ordered by time, then obstacle id", body = [ObservationOut]),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn list_observations(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<ObservationQuery>,
) -> Result<axum::Json<Vec<ObservationOut>>, ApiError> {
    if !state.store.mission_exists(&id).await? {
        return Err(ApiError::not_found("mission", id));
    }
    let rows = state
        .store
        .list_observations(&id, q.obstacle_id.as_deref(), q.after.map(|t| t.0))
        .await?;
    Ok(axum::Json(
        rows.into_iter()
            .map(|r| ObservationOut {
                obstacle_id: r.obstacle_id,
                t: r.t_s,
                lat: r.lat_deg,
                lon: r.lon_deg,
                alt_msl_m: r.alt_msl_m,
                radius_m: r.radius_m,
            })
            .collect(),
    ))
}

/// One native aircraft telemetry sample.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct AircraftTelemetry {
    /// Sample time (RFC 3339 or Unix seconds); receipt time when absent.
    #[serde(default)]
    pub t: Option<WireTime>,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Heading, degrees true, [0, 360].
    pub heading_deg: f64,
    /// Ground speed, m/s (>= 0).
    #[serde(default)]
    pub speed_mps: Option<f64>,
}

/// A stored aircraft telemetry sample.
#[derive(Debug, Serialize, ToSchema)]
pub struct AircraftTelemetryOut {
    /// Sample time, Unix seconds.
    pub t: f64,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Heading, degrees true.
    pub heading_deg: f64,
    /// Ground speed, m/s, when reported.
    pub speed_mps: Option<f64>,
}

fn telemetry_row(
    errs: &mut Vec<FieldError>,
    at: &str,
    s: &AircraftTelemetry,
    keys: [&str; 5],
    received: f64,
) -> TelemetryRow {
    check_position(errs, at, s.lat, s.lon, keys[0], keys[1]);
    if !s.alt_msl_m.is_finite() {
        errs.push(FieldError::new(
            format!("{at}/{}", keys[2]),
            "altitude must be finite",
        ));
    }
    if !(s.heading_deg.is_finite() && (0.0..=360.0).contains(&s.heading_deg)) {
        errs.push(FieldError::new(
            format!("{at}/{}", keys[3]),
            format!("heading {} is not in [0, 360]", s.heading_deg),
        ));
    }
    if let Some(v) = s.speed_mps
        && !(v.is_finite() && v >= 0.0)
    {
        errs.push(FieldError::new(
            format!("{at}/{}", keys[4]),
            format!("speed {v} must be a non-negative number"),
        ));
    }
    TelemetryRow {
        t_s: s.t.map_or(received, |t| t.0),
        lat_deg: s.lat,
        lon_deg: s.lon,
        alt_msl_m: s.alt_msl_m,
        heading_deg: s.heading_deg % 360.0,
        speed_mps: s.speed_mps,
    }
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
        (status = 400, description = "Malformed body", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
        (status = 415, description = "Neither JSON nor form-encoded", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "Invalid sample, the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn post_telemetry(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    headers: HeaderMap,
    Body(body): Body,
) -> Result<(StatusCode, axum::Json<IngestResult>), ApiError> {
    let received = now_s();
    let mut errs = Vec::new();
    let rows: Vec<TelemetryRow> = match media_type(&headers) {
        MediaType::Form => {
            let t: Telemetry2018 = serde_urlencoded::from_bytes(&body).map_err(|e| ApiError::BadRequest {
                detail: format!("invalid interop 2018 telemetry form: {e} (expected latitude, longitude, altitude_msl, uas_heading)"),
                pointer: None,
            })?;
            let s = AircraftTelemetry {
                t: None,
                lat: t.latitude,
                lon: t.longitude,
                alt_msl_m: interop::ft(t.altitude_msl),
                heading_deg: t.uas_heading,
                speed_mps: None,
            };
            vec![telemetry_row(
                &mut errs,
                "",
                &s,
                ["latitude", "longitude", "altitude_msl", "uas_heading", "-"],
                received,
            )]
        }
        MediaType::Json => {
            let value: serde_json::Value = parse_json(&body)?;
            if value.get("latitude").is_some() {
                let t: Telemetry2019 = from_value(value)?;
                let s = AircraftTelemetry {
                    t: None,
                    lat: t.latitude,
                    lon: t.longitude,
                    alt_msl_m: interop::ft(t.altitude),
                    heading_deg: t.heading,
                    speed_mps: None,
                };
                vec![telemetry_row(
                    &mut errs,
                    "",
                    &s,
                    ["latitude", "longitude", "altitude", "heading", "-"],
                    received,
                )]
            } else if value.is_array() {
                let samples: Vec<AircraftTelemetry> = from_value(value)?;
                samples
                    .iter()
                    .enumerate()
                    .map(|(i, s)| {
                        telemetry_row(&mut errs, &format!("/{i}"), s, NATIVE_KEYS, received)
                    })
                    .collect()
            } else {
                let s: AircraftTelemetry = from_value(value)?;
                vec![telemetry_row(&mut errs, "", &s, NATIVE_KEYS, received)]
            }
        }
        _ => {
            return Err(ApiError::UnsupportedMediaType(
                "aircraft telemetry is application/json (native or interop 2019) or application/x-www-form-urlencoded (interop 2018)".into(),
            ));
        }
    };
    if !errs.is_empty() {
        return Err(ApiError::Validation(errs));
    }
    let counts = state
        .store
        .insert_telemetry(&id, &rows, received)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &id))?;
    Ok((StatusCode::ACCEPTED, axum::Json(counts.into())))
}

const NATIVE_KEYS: [&str; 5] = ["lat", "lon", "alt_msl_m", "heading_deg", "speed_mps"];

/// `?last=` of the telemetry listing.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct TelemetryQuery {
    /// Only the newest n samples.
    pub last: Option<u32>,
}

/// The stored aircraft telemetry, ordered by time.
#[utoipa::path(get, path = "/api/v1/missions/{id}/telemetry", tag = "telemetry",
    params(("id" = String, Path, description = "Mission id"), TelemetryQuery),
    responses(
        (status = 200, description = "Samples ordered by time", body = [AircraftTelemetryOut]),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn list_telemetry(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<TelemetryQuery>,
) -> Result<axum::Json<Vec<AircraftTelemetryOut>>, ApiError> {
    if !state.store.mission_exists(&id).await? {
        return Err(ApiError::not_found("mission", id));
    }
    let rows = state.store.list_telemetry(&id, q.last).await?;
    Ok(axum::Json(
        rows.into_iter()
            .map(|r| AircraftTelemetryOut {
                t: r.t_s,
                lat: r.lat_deg,
                lon: r.lon_deg,
                alt_msl_m: r.alt_msl_m,
                heading_deg: r.heading_deg,
                speed_mps: r.speed_mps,
            })
            .collect(),
    ))
}

/// Telemetry routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(post_obstacles))
        .routes(routes!(list_observations))
        .routes(routes!(post_telemetry, list_telemetry))
}
