//! `POST /api/v1/avoid/insert-waypoint`: seed 004's waypoint insertion for one leg and one
//! obstacle (`planner::insertion`). Stateless.
//!
//! Positions are WGS84 degrees; the computation runs in a local ENU frame centred on the
//! leg's start (`crate::geodesy`), and the answer comes back in degrees.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;
use utoipa_axum::{router::OpenApiRouter, routes};

use planner::insertion::{
    Circle, DEFAULT_BUFFER_FRACTION, Endpoint, InsertError, InsertOutcome, insert_waypoint,
};

use crate::app::AppState;
use crate::error::{ApiError, FieldError};
use crate::extract::ApiJson;
use crate::geodesy::LocalFrame;
use crate::mission::LatLon;

/// The obstacle: a circle.
#[derive(Debug, Clone, Copy, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ObstacleIn {
    /// Centre latitude, degrees.
    #[schema(minimum = -90, maximum = 90)]
    pub lat: f64,
    /// Centre longitude, degrees.
    #[schema(minimum = -180, maximum = 180)]
    pub lon: f64,
    /// Radius, metres (> 0).
    #[schema(exclusive_minimum = 0)]
    pub radius_m: f64,
}

/// `POST /api/v1/avoid/insert-waypoint` body.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(example = json!({
    "from": {"lat": 38.1446, "lon": -76.4300},
    "to": {"lat": 38.1446, "lon": -76.4250},
    "obstacle": {"lat": 38.1447, "lon": -76.4275, "radius_m": 40.0}
}))]
pub struct InsertRequest {
    /// The leg's start (w1).
    pub from: LatLon,
    /// The leg's end (w2).
    pub to: LatLon,
    /// The obstacle.
    pub obstacle: ObstacleIn,
    /// Safety buffer as a fraction of the radius, default 0.2 (seed 004).
    #[schema(minimum = 0)]
    pub buffer_fraction: Option<f64>,
    /// Optional fly-zone boundary (at least 3 points): candidates whose point or new legs
    /// leave it are discarded.
    #[schema(min_items = 3)]
    pub fly_zone: Option<Vec<LatLon>>,
}

/// What happened.
#[derive(Debug, Clone, Copy, Serialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum InsertOutcomeOut {
    /// The leg keeps the buffer: no waypoint needed (`waypoint` is null).
    NotNeeded,
    /// `waypoint` goes between `from` and `to`.
    Inserted,
    /// `from` lies inside the safety buffer: no single waypoint can help.
    FromInBuffer,
    /// `to` lies inside the safety buffer.
    ToInBuffer,
    /// Both candidates leave the fly zone.
    NoCandidate,
}

/// The answer.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct InsertResponse {
    /// The waypoint to insert, or null when none is needed or possible.
    pub waypoint: Option<LatLon>,
    /// The seed's two candidates f1 (left of the leg) and f2 (right), when computed.
    pub candidates: Vec<LatLon>,
    /// What happened.
    pub outcome: InsertOutcomeOut,
    /// Whether both new legs keep the buffer (false: insert again on the blocked new leg).
    pub legs_clear: Option<bool>,
}

fn check(errs: &mut Vec<FieldError>, ptr: &str, p: LatLon) {
    wire::coords::check_lat_lon(
        errs,
        &format!("{ptr}/lat"),
        &format!("{ptr}/lon"),
        p.lat,
        p.lon,
    );
}

/// Insert a waypoint to avoid an obstacle (seed 004).
///
/// The leg's line meets the safety-buffer circle (radius `r + b`, `b = buffer_fraction *
/// r`) in a secant; the candidates are where the secant's perpendicular bisector meets
/// the circle of radius `r + 2b`. Of the candidates inside the fly zone, one whose new
/// legs keep the buffer wins, then the shorter detour.
#[utoipa::path(post, path = "/api/v1/avoid/insert-waypoint", tag = "avoid",
    request_body(content = InsertRequest, description = "The leg, the obstacle, options", content_type = "application/json"),
    responses(
        (status = 200, description = "The waypoint to insert (or null) and the candidates", body = InsertResponse),
    ))]
async fn insert(
    ApiJson(req): ApiJson<InsertRequest>,
) -> Result<axum::Json<InsertResponse>, ApiError> {
    let mut errs = Vec::new();
    check(&mut errs, "/from", req.from);
    check(&mut errs, "/to", req.to);
    check(
        &mut errs,
        "/obstacle",
        LatLon {
            lat: req.obstacle.lat,
            lon: req.obstacle.lon,
        },
    );
    if !(req.obstacle.radius_m.is_finite() && req.obstacle.radius_m > 0.0) {
        errs.push(FieldError::new(
            "/obstacle/radius_m",
            "radius must be positive",
        ));
    }
    let bf = req.buffer_fraction.unwrap_or(DEFAULT_BUFFER_FRACTION);
    if !(bf.is_finite() && bf >= 0.0) {
        errs.push(FieldError::new(
            "/buffer_fraction",
            "buffer fraction must be >= 0",
        ));
    }
    if let Some(z) = &req.fly_zone {
        if z.len() < 3 {
            errs.push(FieldError::new(
                "/fly_zone",
                "a fly zone needs at least 3 points",
            ));
        }
        for (i, p) in z.iter().enumerate() {
            check(&mut errs, &format!("/fly_zone/{i}"), *p);
        }
    }
    if !errs.is_empty() {
        return Err(ApiError::validation(errs));
    }
    let frame = LocalFrame::new(req.from.lat, req.from.lon);
    let enu = |p: LatLon| frame.to_enu(p.lat, p.lon);
    let zone: Option<Vec<[f64; 2]>> = req
        .fly_zone
        .as_ref()
        .map(|z| z.iter().map(|&p| enu(p)).collect());
    let obstacle = Circle {
        center_m: frame.to_enu(req.obstacle.lat, req.obstacle.lon),
        radius_m: req.obstacle.radius_m,
    };
    let out = insert_waypoint(enu(req.from), enu(req.to), obstacle, bf, zone.as_deref()).map_err(
        |e| match e {
            InsertError::NonPositiveRadius(_) => {
                ApiError::field("/obstacle/radius_m", e.to_string())
            }
            InsertError::NegativeBuffer(_) => ApiError::field("/buffer_fraction", e.to_string()),
            other => ApiError::field("", other.to_string()),
        },
    )?;
    let geo = |p: [f64; 2]| {
        let (lat, lon) = frame.to_geodetic(p);
        LatLon { lat, lon }
    };
    let resp = match out {
        InsertOutcome::Inserted {
            waypoint,
            candidates,
            legs_clear,
            ..
        } => InsertResponse {
            waypoint: Some(geo(waypoint)),
            candidates: candidates.iter().map(|&c| geo(c)).collect(),
            outcome: InsertOutcomeOut::Inserted,
            legs_clear: Some(legs_clear),
        },
        InsertOutcome::NoCandidate { candidates } => InsertResponse {
            waypoint: None,
            candidates: candidates.iter().map(|&c| geo(c)).collect(),
            outcome: InsertOutcomeOut::NoCandidate,
            legs_clear: None,
        },
        InsertOutcome::EndpointInBuffer { endpoint } => InsertResponse {
            waypoint: None,
            candidates: vec![],
            outcome: if endpoint == Endpoint::From {
                InsertOutcomeOut::FromInBuffer
            } else {
                InsertOutcomeOut::ToInBuffer
            },
            legs_clear: None,
        },
        _ => InsertResponse {
            waypoint: None,
            candidates: vec![],
            outcome: InsertOutcomeOut::NotNeeded,
            legs_clear: None,
        },
    };
    Ok(axum::Json(resp))
}

/// Avoidance routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new().routes(routes!(insert))
}
