//! `/api/v1/reactive/*`: the onboard LiDAR avoiders of `planner::reactive` over HTTP
//! (seeds 000, 001, 003). Stateless: every answer depends on the request alone.
//!
//! Angles are degrees, 0 straight ahead, counter-clockwise positive (left = positive); lateral
//! offsets (`deviation_m`, `x_m`) are positive to the left, `y_m` is forward. JSON cannot
//! carry `inf`/`NaN`: a `null` distance means "no return" (free space).

use axum::extract::State;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;
use utoipa_axum::{router::OpenApiRouter, routes};

use planner::reactive::{
    Beam, OffsetError, OffsetParams, PilotError, PilotInput, PilotLimit, PilotParams, SectorError,
    SectorParams, Side, offset_decide, pilot_plan, sectors_decide,
};

use crate::app::AppState;
use crate::error::{ApiError, FieldError, Problem};
use crate::extract::ApiJson;

/// Largest magnitude of the lengths (and ratios, weights) the reactive endpoints take:
/// 1000 km is far beyond any LiDAR, and keeps every answer finite (JSON has no infinity).
const MAX_MAGNITUDE: f64 = 1e6;

/// 422 for every named value whose magnitude exceeds [`MAX_MAGNITUDE`].
fn check_magnitudes<'a>(
    values: impl IntoIterator<Item = (&'a str, Option<f64>)>,
) -> Result<(), ApiError> {
    let errs: Vec<FieldError> = values
        .into_iter()
        .filter_map(|(pointer, v)| {
            v.filter(|v| v.abs() > MAX_MAGNITUDE).map(|v| {
                FieldError::new(
                    pointer,
                    format!("{v} exceeds the largest accepted magnitude, {MAX_MAGNITUDE}"),
                )
            })
        })
        .collect();
    if errs.is_empty() {
        Ok(())
    } else {
        Err(ApiError::validation(errs))
    }
}

/// Largest `samples_per_segment` accepted by `/pilot` (also in the OpenAPI schema).
const MAX_SAMPLES_PER_SEGMENT: usize = 10_000;

/// One LiDAR beam.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct BeamIn {
    /// Bearing, degrees, 0 straight ahead, counter-clockwise (left) positive.
    pub angle_deg: f64,
    /// Measured range, metres; `null` = no return (free). Negative or below `range_min_m`
    /// = blocked (something too close to measure).
    pub distance_m: Option<f64>,
}

/// `POST /api/v1/reactive/offset` body.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(example = json!({
    "scan": [
        {"angle_deg": -6.0, "distance_m": null}, {"angle_deg": -4.0, "distance_m": null},
        {"angle_deg": -2.0, "distance_m": 1.5}, {"angle_deg": 0.0, "distance_m": 1.5},
        {"angle_deg": 2.0, "distance_m": null}, {"angle_deg": 4.0, "distance_m": null},
        {"angle_deg": 6.0, "distance_m": null}, {"angle_deg": 8.0, "distance_m": null},
        {"angle_deg": 10.0, "distance_m": null}
    ],
    "scan_radii_m": [1.0, 2.0, 5.0]
}))]
pub struct OffsetRequest {
    /// The sweep: beams in any order; those outside the field of view are ignored.
    #[schema(min_items = 1)]
    pub scan: Vec<BeamIn>,
    /// Scan radii, metres, one frame each, any order (the nearest frame weighs most).
    #[schema(min_items = 1, max_items = 60)]
    pub scan_radii_m: Vec<f64>,
    /// Threshold `T` on the aggregate score (0..100), default 5.0.
    #[schema(minimum = 0)]
    pub threshold: Option<f64>,
    /// Window size `N`, beams, default 4.
    #[schema(minimum = 1)]
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    pub window: Option<usize>,
    /// Field of view, degrees, centred on the heading, default 120.
    #[schema(exclusive_minimum = 0, maximum = 360)]
    pub fov_deg: Option<f64>,
    /// Readings below this are blocked, metres, default 0.
    #[schema(minimum = 0)]
    pub range_min_m: Option<f64>,
    /// Readings above this are free, metres, default unlimited.
    #[schema(exclusive_minimum = 0)]
    pub range_max_m: Option<f64>,
    /// Range at which the deviation is measured, metres, default the largest scan radius.
    #[schema(exclusive_minimum = 0, maximum = 1000000)]
    pub lookahead_m: Option<f64>,
}

/// A side.
#[derive(Debug, Clone, Copy, Serialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Counter-clockwise, positive angles.
    Left,
    /// Clockwise, negative angles.
    Right,
}

/// The chosen scan window.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct WindowOut {
    /// First beam (0 = the rightmost beam in view, beams sorted by bearing).
    pub first_beam: usize,
    /// Last beam, inclusive.
    pub last_beam: usize,
    /// Bearing of its rightmost beam, degrees.
    pub right_edge_deg: f64,
    /// Bearing of its leftmost beam, degrees.
    pub left_edge_deg: f64,
    /// Mean of the edge bearings, degrees.
    pub centre_deg: f64,
}

/// The Offset Algorithm's decision.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct OffsetResponse {
    /// `left`, `right`, or `null` when no window passes the threshold (no path).
    pub direction: Option<Direction>,
    /// The deciding cycle (0-based), or the last cycle evaluated when there is no path.
    pub cycle: usize,
    /// Cycles evaluated.
    pub cycles_evaluated: usize,
    /// Left aggregate score at `cycle` (0..100).
    pub aggregate_left: f64,
    /// Right aggregate score at `cycle` (0..100).
    pub aggregate_right: f64,
    /// Lateral deviation, metres, left positive (0 when the way ahead is clear or no path).
    pub deviation_m: f64,
    /// Heading change toward the window centre, degrees, left positive.
    pub heading_change_deg: f64,
    /// Both windows at the heading are clear on the first cycle: keep straight.
    pub way_ahead_clear: bool,
    /// The chosen window, `null` when there is no path.
    pub window: Option<WindowOut>,
}

fn offset_error(e: &OffsetError) -> ApiError {
    let pointer = match e {
        OffsetError::NoScanRadii | OffsetError::TooManyScanRadii { .. } => {
            "/scan_radii_m".to_string()
        }
        OffsetError::InvalidScanRadius { index, .. } => format!("/scan_radii_m/{index}"),
        OffsetError::InvalidThreshold(_) => "/threshold".into(),
        OffsetError::ZeroWindow => "/window".into(),
        OffsetError::InvalidFov(_) => "/fov_deg".into(),
        OffsetError::InvalidRange { .. } => "/range_min_m".into(),
        OffsetError::InvalidLookahead(_) => "/lookahead_m".into(),
        OffsetError::EmptyScan | OffsetError::TooFewBeams { .. } => "/scan".into(),
        OffsetError::NonFiniteAngle { index } => format!("/scan/{index}/angle_deg"),
        _ => String::new(),
    };
    ApiError::field(pointer, e.to_string())
}

/// Offset Algorithm: pick an escape side and lateral deviation from one LiDAR sweep.
///
/// Frames per scan radius (nanobox = 1 when the beam's distance <= R), windows of `window`
/// beams stepping outward from the heading on both sides, frame weights
/// `2^(n-i)/(2^n-1)` (nearest heaviest), scan score `S = sum(n_i * 100 / N)`, aggregate
/// `A = sum(w_i S_i)`; the first cycle where a side has `A <= threshold` decides (both on
/// the first cycle: left, way ahead clear; both later: the lower). A `null` distance is "no
/// return" (free).
#[utoipa::path(post, path = "/api/v1/reactive/offset", tag = "reactive",
    request_body(content = OffsetRequest, description = "A sweep and the algorithm's parameters", content_type = "application/json"),
    responses(
        (status = 200, description = "The decision; `direction` is null when no path was found", body = OffsetResponse),
        (status = 422, description = "Invalid input (empty scan, negative radius, window 0, ...), the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn offset(
    State(state): State<AppState>,
    ApiJson(req): ApiJson<OffsetRequest>,
) -> Result<axum::Json<OffsetResponse>, ApiError> {
    let radii: Vec<(String, Option<f64>)> = req
        .scan_radii_m
        .iter()
        .enumerate()
        .map(|(i, &r)| (format!("/scan_radii_m/{i}"), Some(r)))
        .collect();
    check_magnitudes(
        radii
            .iter()
            .map(|(p, r)| (p.as_str(), *r))
            .chain([("/lookahead_m", req.lookahead_m)]),
    )?;
    let defaults = OffsetParams::default();
    let params = OffsetParams {
        scan_radii_m: req.scan_radii_m,
        threshold: req.threshold.unwrap_or(defaults.threshold),
        window: req.window.unwrap_or(defaults.window),
        fov_deg: req.fov_deg.unwrap_or(defaults.fov_deg),
        range_min_m: req.range_min_m.unwrap_or(defaults.range_min_m),
        range_max_m: req.range_max_m.unwrap_or(defaults.range_max_m),
        lookahead_m: req.lookahead_m,
    };
    let scan: Vec<Beam> = req
        .scan
        .iter()
        .map(|b| Beam::new(b.angle_deg, b.distance_m.unwrap_or(f64::INFINITY)))
        .collect();
    let d = state
        .run_cpu(move || offset_decide(&scan, &params))
        .await?
        .map_err(|e| offset_error(&e))?;
    Ok(axum::Json(OffsetResponse {
        direction: d.direction.map(|s| match s {
            Side::Left => Direction::Left,
            Side::Right => Direction::Right,
        }),
        cycle: d.cycle,
        cycles_evaluated: d.cycles_evaluated,
        aggregate_left: d.aggregate_left,
        aggregate_right: d.aggregate_right,
        deviation_m: d.deviation_m,
        heading_change_deg: d.heading_change_deg,
        way_ahead_clear: d.way_ahead_clear,
        window: d.window.map(|w| WindowOut {
            first_beam: w.first_beam,
            last_beam: w.last_beam,
            right_edge_deg: w.right_edge_deg,
            left_edge_deg: w.left_edge_deg,
            centre_deg: w.centre_deg,
        }),
    }))
}

/// `POST /api/v1/reactive/pilot` body.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(example = json!({"deviation_m": 3.0, "scan_range_m": 10.0, "goal_distance_m": 50.0}))]
pub struct PilotRequest {
    /// Lateral deviation to fly, metres, left positive (the offset decision's `deviation_m`).
    #[schema(minimum = -1000000, maximum = 1000000)]
    pub deviation_m: f64,
    /// Scan range `l` (forward distance of the offset point), metres, > 0.
    #[schema(exclusive_minimum = 0, maximum = 1000000)]
    pub scan_range_m: f64,
    /// Distance to the goal along the goal line, metres, > 0.
    #[schema(exclusive_minimum = 0, maximum = 1000000)]
    pub goal_distance_m: f64,
    /// `g = goal_fraction * goal_distance`, in (0, 1), default 0.6.
    #[schema(exclusive_minimum = 0, exclusive_maximum = 1)]
    pub goal_fraction: Option<f64>,
    /// `delta` in `P2 = (0, g + delta)`, metres, default `goal_distance - g` (rejoin at the goal).
    #[schema(exclusive_minimum = 0, maximum = 1000000)]
    pub return_overhead_m: Option<f64>,
    /// Largest deviation, metres, default 30.
    #[schema(minimum = 0, maximum = 1000000)]
    pub max_deviation_m: Option<f64>,
    /// Deviations up to this snap back to the goal line, metres, default 0.25.
    #[schema(minimum = 0, maximum = 1000000)]
    pub snap_back_m: Option<f64>,
    /// Goal funnel: `|d| <= funnel_ratio * goal_distance`, default 0.5.
    #[schema(minimum = 0, maximum = 1000000)]
    pub funnel_ratio: Option<f64>,
    /// Weight `k` of the deviation cost `k d^2`, default 1.
    #[schema(minimum = 0, maximum = 1000000)]
    pub deviation_cost_weight: Option<f64>,
    /// Sampled points per Bezier segment, default 16 (the answer has `2n + 1` points).
    #[schema(minimum = 1, maximum = 10000)]
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    pub samples_per_segment: Option<usize>,
}

/// A path point, aircraft-relative.
#[derive(Debug, Clone, Copy, Serialize, ToSchema)]
pub struct PointOut {
    /// Lateral, metres, left positive.
    pub x_m: f64,
    /// Forward, metres.
    pub y_m: f64,
}

/// The Bezier control points.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct ControlPointsOut {
    /// Start (the aircraft).
    pub p0: PointOut,
    /// Offset point `(d, l)`.
    pub p1: PointOut,
    /// Projected point `(d, g)`, where the away segment ends.
    pub p: PointOut,
    /// Control of the return segment `(d, g + delta/2)`.
    pub q: PointOut,
    /// Return anchor `(0, g + delta)`.
    pub p2: PointOut,
}

/// The pilot's path.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct PilotResponse {
    /// Sampled path from the aircraft back to the goal line.
    pub points: Vec<PointOut>,
    /// Deviation used after the heuristics, metres.
    pub deviation_m: f64,
    /// Deviation asked for, metres.
    pub requested_deviation_m: f64,
    /// `snap_back`, `max_deviation`, `goal_funnel`, or null when none changed it.
    pub limited_by: Option<String>,
    /// The Bezier control points.
    pub control_points: ControlPointsOut,
    /// Deviation cost `k d^2`.
    pub cost: f64,
}

fn pilot_error(e: &PilotError) -> ApiError {
    let pointer = match e {
        PilotError::InvalidInput { name, .. } | PilotError::InvalidParameter { name, .. } => {
            format!("/{name}")
        }
        _ => String::new(),
    };
    ApiError::field(pointer, e.to_string())
}

fn point(p: planner::reactive::PathPoint) -> PointOut {
    PointOut {
        x_m: p.x_m,
        y_m: p.y_m,
    }
}

/// Pilot: the quadratic Bezier path out to a lateral deviation and back to the goal line.
///
/// Two quadratic segments `P0 -> (P1) -> P` and `P -> (Q) -> P2` with `P1 = (d, l)`,
/// `P = (d, g)`, `Q = (d, g + delta/2)`, `P2 = (0, g + delta)`, `g = 0.6 x goal distance`;
/// the deviation is first limited by snap-back, the maximum deviation and the goal funnel.
#[utoipa::path(post, path = "/api/v1/reactive/pilot", tag = "reactive",
    request_body(content = PilotRequest, description = "Deviation, ranges and optional heuristics", content_type = "application/json"),
    responses(
        (status = 200, description = "The sampled path (x lateral, left positive; y forward)", body = PilotResponse),
        (status = 422, description = "Invalid input or heuristic, the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn pilot(ApiJson(req): ApiJson<PilotRequest>) -> Result<axum::Json<PilotResponse>, ApiError> {
    check_magnitudes([
        ("/deviation_m", Some(req.deviation_m)),
        ("/scan_range_m", Some(req.scan_range_m)),
        ("/goal_distance_m", Some(req.goal_distance_m)),
        ("/return_overhead_m", req.return_overhead_m),
        ("/max_deviation_m", req.max_deviation_m),
        ("/snap_back_m", req.snap_back_m),
        ("/funnel_ratio", req.funnel_ratio),
        ("/deviation_cost_weight", req.deviation_cost_weight),
    ])?;
    let d = PilotParams::default();
    let params = PilotParams {
        goal_fraction: req.goal_fraction.unwrap_or(d.goal_fraction),
        return_overhead_m: req.return_overhead_m,
        max_deviation_m: req.max_deviation_m.unwrap_or(d.max_deviation_m),
        snap_back_m: req.snap_back_m.unwrap_or(d.snap_back_m),
        funnel_ratio: req.funnel_ratio.unwrap_or(d.funnel_ratio),
        deviation_cost_weight: req.deviation_cost_weight.unwrap_or(d.deviation_cost_weight),
    };
    let samples = req.samples_per_segment.unwrap_or(16);
    if samples == 0 || samples > MAX_SAMPLES_PER_SEGMENT {
        return Err(ApiError::field(
            "/samples_per_segment",
            format!("must be between 1 and {MAX_SAMPLES_PER_SEGMENT}"),
        ));
    }
    let input = PilotInput::new(req.deviation_m, req.scan_range_m, req.goal_distance_m);
    // a handful of multiplications: no need to leave the runtime
    let plan = pilot_plan(&input, &params).map_err(|e| pilot_error(&e))?;
    Ok(axum::Json(PilotResponse {
        points: plan.sample(samples).into_iter().map(point).collect(),
        deviation_m: plan.deviation_m,
        requested_deviation_m: plan.requested_deviation_m,
        limited_by: plan.limited_by.map(|l| {
            match l {
                PilotLimit::SnapBack => "snap_back",
                PilotLimit::MaxDeviation => "max_deviation",
                PilotLimit::GoalFunnel => "goal_funnel",
            }
            .to_string()
        }),
        control_points: ControlPointsOut {
            p0: point(plan.p0),
            p1: point(plan.p1),
            p: point(plan.p),
            q: point(plan.q),
            p2: point(plan.p2),
        },
        cost: plan.cost,
    }))
}

/// `POST /api/v1/reactive/sectors` body.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(example = json!({"ranges_m": [0.4, null, null, null, null, null, null, 0.9], "range_min_m": 0.1, "obj_threshold_m": 1.0}))]
pub struct SectorsRequest {
    /// LaserScan-like ranges, metres: index `i` at bearing `angle_min_deg + i * 360 / len`,
    /// counter-clockwise. `null` = no return.
    #[schema(min_items = 1)]
    pub ranges_m: Vec<Option<f64>>,
    /// Bearing of `ranges_m[0]`, degrees, default 0 (straight ahead).
    pub angle_min_deg: Option<f64>,
    /// Readings at or below this are dropped, metres, default 0.
    #[schema(minimum = 0)]
    pub range_min_m: Option<f64>,
    /// Only readings at or below this count as obstacles, metres, default 1.0.
    #[schema(exclusive_minimum = 0)]
    pub obj_threshold_m: Option<f64>,
    /// Turn rate magnitude when avoiding, default 0.7.
    pub avoid_angular_velocity: Option<f64>,
    /// Linear velocity when avoiding, default -0.1 (reverse).
    pub reverse_linear_velocity: Option<f64>,
    /// Linear velocity when the front is clear, default 0.5.
    pub cruise_linear_velocity: Option<f64>,
    /// Angular velocity when the front is clear, default 0.
    pub cruise_angular_velocity: Option<f64>,
}

/// One region's readings.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct RegionOut {
    /// Region number: 0 front (60 deg), then 45-degree regions centred on 45, 90, ... 315 deg.
    pub region: u8,
    /// Cost: signed 45-degree steps from the front (0, 1, 2, 3, 4, -3, -2, -1).
    pub cost: i8,
    /// No reading counted as an obstacle.
    pub free: bool,
    /// Nearest counted reading, metres (null when free).
    pub nearest_m: Option<f64>,
    /// Farthest counted reading, metres (null when free).
    pub farthest_m: Option<f64>,
}

/// The sector avoider's command.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct SectorsResponse {
    /// The front region holds an obstacle.
    pub obstacle_detected: bool,
    /// The chosen region, 0-7.
    pub region: u8,
    /// Commanded angular velocity, counter-clockwise positive.
    pub angular_velocity: f64,
    /// Commanded linear velocity.
    pub linear_velocity: f64,
    /// All eight regions.
    pub regions: Vec<RegionOut>,
}

fn sector_error(e: &SectorError) -> ApiError {
    let pointer = match e {
        SectorError::EmptyScan => "/ranges_m".to_string(),
        SectorError::NonFiniteAngleMin => "/angle_min_deg".into(),
        SectorError::InvalidParameter { name, .. } => format!("/{name}"),
        _ => String::new(),
    };
    ApiError::field(pointer, e.to_string())
}

/// Sector avoider: 8 regions around the vehicle; when the front is blocked, turn toward the
/// obstacle-free region nearest the front (else the one with the farthest reading).
#[utoipa::path(post, path = "/api/v1/reactive/sectors", tag = "reactive",
    request_body(content = SectorsRequest, description = "A 360-degree sweep and optional parameters", content_type = "application/json"),
    responses(
        (status = 200, description = "Obstacle flag, chosen region and velocity command", body = SectorsResponse),
        (status = 422, description = "Invalid input (empty ranges, bad threshold, ...), the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn sectors(
    State(state): State<AppState>,
    ApiJson(req): ApiJson<SectorsRequest>,
) -> Result<axum::Json<SectorsResponse>, ApiError> {
    let d = SectorParams::default();
    let params = SectorParams {
        range_min_m: req.range_min_m.unwrap_or(d.range_min_m),
        obj_threshold_m: req.obj_threshold_m.unwrap_or(d.obj_threshold_m),
        avoid_angular_velocity: req
            .avoid_angular_velocity
            .unwrap_or(d.avoid_angular_velocity),
        reverse_linear_velocity: req
            .reverse_linear_velocity
            .unwrap_or(d.reverse_linear_velocity),
        cruise_linear_velocity: req
            .cruise_linear_velocity
            .unwrap_or(d.cruise_linear_velocity),
        cruise_angular_velocity: req
            .cruise_angular_velocity
            .unwrap_or(d.cruise_angular_velocity),
        ..d
    };
    let ranges: Vec<f64> = req
        .ranges_m
        .iter()
        .map(|r| r.unwrap_or(f64::INFINITY))
        .collect();
    let angle_min = req.angle_min_deg.unwrap_or(0.0);
    let s = state
        .run_cpu(move || sectors_decide(&ranges, angle_min, &params))
        .await?
        .map_err(|e| sector_error(&e))?;
    Ok(axum::Json(SectorsResponse {
        obstacle_detected: s.obstacle_detected,
        region: s.region,
        angular_velocity: s.angular_velocity,
        linear_velocity: s.linear_velocity,
        regions: (0..8)
            .map(|k| RegionOut {
                region: k as u8,
                cost: planner::reactive::sectors::REGION_COSTS[k],
                free: s.free[k],
                nearest_m: (!s.free[k]).then_some(s.nearest_m[k]),
                farthest_m: (!s.free[k]).then_some(s.farthest_m[k]),
            })
            .collect(),
    }))
}

/// The reactive avoider routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(offset))
        .routes(routes!(pilot))
        .routes(routes!(sectors))
}
