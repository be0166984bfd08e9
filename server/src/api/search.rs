//! `POST /api/v1/missions/{id}/search-pattern`: the search-area ladder (lawnmower) pattern
//! over the mission's search grid (`planner::ladder`, seed 002's feasible-path
//! pre-processing), as waypoints. Computed from the stored mission; nothing is stored.

use axum::extract::{Path, State};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;
use utoipa_axum::{router::OpenApiRouter, routes};

use planner::ladder::{LadderOrder, LadderParams, ladder};

use crate::app::AppState;
use crate::error::{ApiError, FieldError, Problem};
use crate::extract::ApiJson;
use wire::ids::MissionId;

/// Most sweep lines one pattern may have (bounds the work a tiny spacing would ask for).
const MAX_LINES: f64 = 2_000.0;

/// Line order of a ladder.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub(crate) enum LadderOrderIn {
    /// Boustrophedon when the spacing is at least twice the turn radius, else skip order.
    #[default]
    Auto,
    /// Lines in order, alternating direction.
    Boustrophedon,
    /// From each line to the nearest unvisited one at least two turn radii away.
    Skip,
}

/// `POST .../search-pattern` body (every field optional; `{}` is fine).
#[derive(Debug, Clone, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(example = json!({"spacing_m": 60.0, "heading_deg": 90.0, "turn_radius_m": 40.0}))]
pub(crate) struct SearchPatternBody {
    /// Distance between sweep lines (the camera footprint), metres, default 60.
    #[schema(minimum = 1, maximum = 10000)]
    pub spacing_m: Option<f64>,
    /// Direction of the sweep lines, degrees true (0 = north, clockwise), default 0.
    #[schema(minimum = 0, maximum = 360)]
    pub heading_deg: Option<f64>,
    /// Shortening at both ends of each line, metres, default 0.
    #[schema(minimum = 0, maximum = 10000)]
    pub margin_m: Option<f64>,
    /// Aircraft turn radius, metres, default 40.
    #[schema(minimum = 0, maximum = 10000)]
    pub turn_radius_m: Option<f64>,
    /// Line order, default `auto`.
    pub order: Option<LadderOrderIn>,
    /// Altitude of the pattern, metres MSL; default the middle of the first fly zone's
    /// altitude band.
    #[schema(minimum = -1000, maximum = 100000)]
    pub alt_msl_m: Option<f64>,
}

/// One waypoint of the pattern.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema)]
pub(crate) struct SearchWaypoint {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
}

/// The pattern.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub(crate) struct SearchPatternOut {
    /// Waypoints in flight order, two per sweep line (its two ends).
    pub waypoints: Vec<SearchWaypoint>,
    /// Sweep lines.
    pub lines: u64,
    /// The order used: `boustrophedon` or `skip` (never `auto`).
    pub order: LadderOrderIn,
    /// Transitions between lines closer than twice the turn radius (0 unless lines are too
    /// few for the skip order).
    pub tight_turns: u64,
    /// Length of the pattern from its first to its last waypoint, metres.
    pub length_m: f64,
}

/// A search-area ladder over the mission's search grid.
///
/// Parallel sweep lines `spacing_m` apart cover the mission's `search_grid` polygon, running
/// along `heading_deg`, each spanning the polygon (shortened by `margin_m` at both ends).
/// With `spacing_m >= 2 x turn_radius_m` they are flown in order, alternating direction;
/// closer lines are flown in skip order, so that every U-turn is at least two turn radii
/// wide. The answer is waypoints (e.g. to append to a plan's stack); nothing is stored.
#[utoipa::path(post, path = "/api/v1/missions/{id}/search-pattern", tag = "plans",
    params(("id" = String, Path, description = "Mission id")),
    request_body(content = SearchPatternBody, description = "Pattern options (all optional)", content_type = "application/json"),
    responses(
        (status = 200, description = "The pattern's waypoints in flight order", body = SearchPatternOut),
        (status = 409, description = "The mission has no search area (fewer than 3 `search_grid` points)", body = Problem, content_type = "application/problem+json"),
    ))]
async fn search_pattern(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiJson(body): ApiJson<SearchPatternBody>,
) -> Result<axum::Json<SearchPatternOut>, ApiError> {
    let d = LadderParams::default();
    let spacing_m = body.spacing_m.unwrap_or(d.spacing_m);
    let heading_deg = body.heading_deg.unwrap_or(0.0);
    let margin_m = body.margin_m.unwrap_or(d.margin_m);
    let turn_radius_m = body.turn_radius_m.unwrap_or(d.turn_radius_m);
    let mut errs = Vec::new();
    let mut check = |pointer: &str, v: f64, (lo, hi): (f64, f64)| {
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            errs.push(FieldError::new(
                pointer,
                format!("{v} is not in [{lo}, {hi}]"),
            ));
        }
    };
    check("/spacing_m", spacing_m, (1.0, 10_000.0));
    check("/heading_deg", heading_deg, (0.0, 360.0));
    check("/margin_m", margin_m, (0.0, 10_000.0));
    check("/turn_radius_m", turn_radius_m, (0.0, 10_000.0));
    if let Some(alt) = body.alt_msl_m {
        check("/alt_msl_m", alt, (-1_000.0, 100_000.0));
    }
    if !errs.is_empty() {
        return Err(ApiError::validation(errs));
    }
    let mission = super::missions::load(&state, &id).await?;
    let grid = &mission.content.search_grid;
    if grid.len() < 3 {
        return Err(ApiError::Conflict(format!(
            "mission {id} has no search area: its search_grid has {} points, a ladder needs at least 3",
            grid.len()
        )));
    }
    let frame = mission.frame();
    let polygon: Vec<[f64; 2]> = grid.iter().map(|p| frame.to_enu(p.lat, p.lon)).collect();
    let extent_m = polygon
        .iter()
        .flat_map(|a| {
            polygon
                .iter()
                .map(move |b| (a[0] - b[0]).hypot(a[1] - b[1]))
        })
        .fold(0.0, f64::max);
    if extent_m / spacing_m > MAX_LINES {
        return Err(ApiError::field(
            "/spacing_m",
            format!(
                "a {spacing_m} m spacing over a {extent_m:.0} m search area makes more than {MAX_LINES} lines"
            ),
        ));
    }
    let params = LadderParams::default()
        .spacing_m(spacing_m)
        .heading_rad(heading_deg.to_radians())
        .margin_m(margin_m)
        .turn_radius_m(turn_radius_m)
        .order(match body.order.unwrap_or_default() {
            LadderOrderIn::Auto => LadderOrder::Auto,
            LadderOrderIn::Boustrophedon => LadderOrder::Boustrophedon,
            LadderOrderIn::Skip => LadderOrder::Skip,
        });
    let alt_msl_m = body.alt_msl_m.unwrap_or_else(|| {
        mission
            .content
            .fly_zones
            .first()
            .map_or(0.0, |z| 0.5 * (z.alt_min_msl_m + z.alt_max_msl_m))
    });
    let l = state
        .run_cpu(move || ladder(&polygon, &params))
        .await?
        .map_err(|e| ApiError::field("/spacing_m", e.to_string()))?;
    let length_m = l
        .points
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    Ok(axum::Json(SearchPatternOut {
        waypoints: l
            .points
            .iter()
            .map(|&p| {
                let (lat, lon) = frame.to_geodetic(p);
                SearchWaypoint {
                    lat,
                    lon,
                    alt_msl_m,
                }
            })
            .collect(),
        lines: l.lines as u64,
        order: match l.order {
            LadderOrder::Skip => LadderOrderIn::Skip,
            _ => LadderOrderIn::Boustrophedon,
        },
        tight_turns: l.tight_turns as u64,
        length_m,
    }))
}

/// Search-pattern routes.
pub(crate) fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new().routes(routes!(search_pattern))
}
