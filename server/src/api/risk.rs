//! Obstacle characterization and risk maps (seed 002): `GET
//! /api/v1/missions/{id}/obstacles` lists every obstacle with its stage, estimates and
//! stage history (stationary cylinders too), and `GET /api/v1/missions/{id}/risk` returns a
//! risk-map slice as JSON or as a PNG heatmap.
//!
//! Both read the mission's live snapshot ([`crate::live`]): the same predictor and risk
//! map a plan asked at the same moment uses (built from the stored observations on first
//! use, so it survives a restart, and kept current by every accepted batch).

use axum::extract::{Path, State};
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};
use utoipa_axum::{router::OpenApiRouter, routes};

use predictor::{Stage, StageChange};

use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::ApiQuery;
use crate::geodesy::LocalFrame;
use crate::mission::{LatLon, Mission};
use wire::ids::MissionId;

/// Characterization stage of a moving obstacle.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StageOut {
    /// Nothing known yet: a disc growing at the rules' maximum speed with a margin.
    NoFly,
    /// Constant speed, turn rate uniform within the estimated capability.
    Random,
    /// Turn rate from the obstacle's own turn-rate histogram.
    Advanced,
    /// Turn rate conditioned on the previous turn.
    Memory,
}

impl From<Stage> for StageOut {
    fn from(s: Stage) -> Self {
        match s {
            Stage::NoFly => Self::NoFly,
            Stage::Random => Self::Random,
            Stage::Advanced => Self::Advanced,
            Stage::Memory => Self::Memory,
        }
    }
}

/// Moving sphere or stationary cylinder.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, ToSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// A moving sphere characterized from telemetry.
    Moving,
    /// A stationary cylinder from the mission (a hard constraint, not predicted).
    Stationary,
}

/// Kinematic estimates of a moving obstacle.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct EstimatesOut {
    /// Speed, m/s (0 when below 0.5 m/s).
    pub speed_mps: f64,
    /// Compass heading, degrees: 0 = north, 90 = east (clockwise); null when stationary.
    pub heading_deg: Option<f64>,
    /// Tightest demonstrated turn radius (5% quantile of the radii of circles through
    /// sampled triples, floored at 5 m), metres; null when no turn has been seen.
    pub min_turn_radius_m: Option<f64>,
    /// Turn-rate capability the models use, degrees per second.
    pub turn_rate_max_dps: f64,
    /// Most recent turn-rate sample (1 s decision interval), degrees per second,
    /// counter-clockwise (left) positive.
    pub turn_rate_dps: Option<f64>,
    /// Fitted current position.
    pub position: LatLon,
}

/// One stage change and the statistic behind it.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct StageChangeOut {
    /// Time of the observation that triggered it, Unix seconds.
    pub t: f64,
    /// Stage before.
    pub from: StageOut,
    /// Stage after.
    pub to: StageOut,
    /// `min_observations`, `chi_square_uniform`, `chi_square_independence` or
    /// `weighted_js_divergence`.
    pub test: String,
    /// The statistic: an observation count, a chi-square value or a divergence in nats.
    pub statistic: f64,
    /// Degrees of freedom of a chi-square test.
    pub df: Option<u64>,
    /// p-value of a chi-square test.
    pub p_value: Option<f64>,
    /// The threshold compared with (a p-value, a count or a divergence).
    pub threshold: f64,
    /// Samples the test used.
    pub samples: u64,
}

impl From<&StageChange> for StageChangeOut {
    fn from(c: &StageChange) -> Self {
        Self {
            t: c.t_s,
            from: c.from.into(),
            to: c.to.into(),
            test: c.test.clone(),
            statistic: c.statistic,
            df: c.df.map(|d| d as u64),
            p_value: c.p_value,
            threshold: c.threshold,
            samples: c.samples as u64,
        }
    }
}

/// The newest observation of a moving obstacle.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct LastObservationOut {
    /// Unix seconds.
    pub t: f64,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude of the centre, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// A stationary cylinder.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct CylinderOut {
    /// Centre latitude, degrees.
    pub lat: f64,
    /// Centre longitude, degrees.
    pub lon: f64,
    /// Radius, metres.
    pub radius_m: f64,
    /// Top, metres MSL.
    pub top_msl_m: f64,
}

/// One obstacle of the mission.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct ObstacleOut {
    /// Obstacle id.
    pub id: String,
    /// Moving or stationary.
    pub kind: ObstacleKind,
    /// Characterization stage (moving obstacles).
    pub stage: Option<StageOut>,
    /// Current estimates (moving obstacles).
    pub estimates: Option<EstimatesOut>,
    /// Observations used (moving obstacles; 0 for cylinders).
    pub observation_count: u64,
    /// Observations refused as physically impossible (implied speed above 41 m/s).
    pub flagged_count: u64,
    /// The newest observation (moving obstacles).
    pub last_observation: Option<LastObservationOut>,
    /// Every stage change with its statistic, oldest first (moving obstacles).
    pub stage_history: Vec<StageChangeOut>,
    /// The cylinder (stationary obstacles).
    pub cylinder: Option<CylinderOut>,
}

/// Every obstacle of a mission: moving ones with their characterization, then the
/// mission's stationary cylinders.
#[utoipa::path(get, path = "/api/v1/missions/{id}/obstacles", tag = "prediction",
    params(("id" = String, Path, description = "Mission id")),
    responses(
        (status = 200, description = "Moving obstacles (by id) with stage, estimates, observation count and stage history, then stationary cylinders", body = [ObstacleOut]),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn list_obstacles(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
) -> Result<axum::Json<Vec<ObstacleOut>>, ApiError> {
    let mission = state
        .store
        .get_mission(&id)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &id))?;
    let snap = state.live.snapshot(&state, &mission).await?;
    let mut out: Vec<ObstacleOut> = {
        snap.predictor
            .obstacles()
            .map(|s| {
                let (lat, lon) = snap.frame.to_geodetic(s.estimates.position_m);
                let (olat, olon) = snap.frame.to_geodetic(s.last_observation.p_m);
                ObstacleOut {
                    id: s.id.clone(),
                    kind: ObstacleKind::Moving,
                    stage: Some(s.stage.into()),
                    estimates: Some(EstimatesOut {
                        speed_mps: s.estimates.speed_mps,
                        heading_deg: s.estimates.heading_deg,
                        min_turn_radius_m: s.estimates.min_turn_radius_m,
                        turn_rate_max_dps: s.estimates.turn_rate_max_dps,
                        turn_rate_dps: s.estimates.turn_rate_dps,
                        position: LatLon { lat, lon },
                    }),
                    observation_count: s.observations as u64,
                    flagged_count: s.flagged as u64,
                    last_observation: Some(LastObservationOut {
                        t: s.last_observation.t_s,
                        lat: olat,
                        lon: olon,
                        alt_msl_m: s.last_observation.alt_m,
                        radius_m: s.last_observation.radius_m,
                    }),
                    stage_history: s.stage_history.iter().map(StageChangeOut::from).collect(),
                    cylinder: None,
                }
            })
            .collect()
    };
    for (i, c) in mission.content.stationary_obstacles.iter().enumerate() {
        out.push(ObstacleOut {
            id: if c.id.is_empty() {
                format!("stationary-{i}")
            } else {
                c.id.to_string()
            },
            kind: ObstacleKind::Stationary,
            stage: None,
            estimates: None,
            observation_count: 0,
            flagged_count: 0,
            last_observation: None,
            stage_history: Vec::new(),
            cylinder: Some(CylinderOut {
                lat: c.lat,
                lon: c.lon,
                radius_m: c.radius_m,
                top_msl_m: c.top_msl_m,
            }),
        });
    }
    Ok(axum::Json(out))
}

/// `?t=&format=` of the risk map.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct RiskParams {
    /// Seconds ahead of the latest aircraft telemetry or obstacle observation (whichever
    /// is newer), in [0, 60]; default 0.
    pub t: Option<f64>,
    /// `json` (default) or `png`.
    pub format: Option<RiskFormat>,
}

/// Risk-map output format.
#[derive(Debug, Clone, Copy, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum RiskFormat {
    /// The slice as JSON numbers.
    Json,
    /// A PNG heatmap with the fly zone, cylinders and obstacles drawn.
    Png,
}

/// One slice of the risk map.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct RiskSliceOut {
    /// Time of the slice, Unix seconds.
    pub t: f64,
    /// Seconds ahead of the anchor.
    pub t_ahead_s: f64,
    /// The anchor: latest aircraft telemetry or observation time, Unix seconds (null with
    /// no data at all, when the map is empty).
    pub anchor_t: Option<f64>,
    /// Horizon of the map, seconds.
    pub horizon_s: f64,
    /// Origin of the mission's ENU frame (home).
    pub frame_origin: LatLon,
    /// South-west corner of the grid in the ENU frame, metres `[east, north]`.
    pub grid_origin_enu_m: [f64; 2],
    /// South-west corner of the grid.
    pub grid_origin: LatLon,
    /// Cell size, metres.
    pub cell_m: f64,
    /// Cells west to east.
    pub width: u64,
    /// Cells south to north.
    pub height: u64,
    /// Probability that a cell is within an obstacle's radius plus a 5 m buffer, row by
    /// row from the south-west corner: `values[row * width + col]`, row 0 southernmost.
    pub values: Vec<f32>,
    /// Largest value.
    pub max: f32,
}

/// A slice of the obstacle risk map.
///
/// The map covers the fly zones plus 300 m in 10 m cells, in 1 s slices over 60 s from the
/// anchor (the latest aircraft telemetry or obstacle observation). Each moving obstacle
/// contributes by its stage's model (a growing disc while NoFly, particles otherwise);
/// obstacles combine as `1 - prod(1 - p)`. Stationary cylinders are hard constraints and
/// are not in the values (the PNG draws them).
#[utoipa::path(get, path = "/api/v1/missions/{id}/risk", tag = "prediction",
    params(("id" = String, Path, description = "Mission id"), RiskParams),
    responses(
        (status = 200, description = "The slice: JSON grid (`format=json`) or a PNG heatmap (`format=png`)",
            content((RiskSliceOut = "application/json"), (Vec<u8> = "image/png"))),
        (status = 400, description = "Malformed query", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "t out of range", body = Problem, content_type = "application/problem+json"),
    ))]
async fn get_risk(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<RiskParams>,
) -> Result<Response, ApiError> {
    let ahead = q.t.unwrap_or(0.0);
    if !(ahead.is_finite() && (0.0..=60.0).contains(&ahead)) {
        return Err(ApiError::field(
            "/t",
            format!("t must be in [0, 60] seconds, got {ahead}"),
        ));
    }
    let mission = state
        .store
        .get_mission(&id)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &id))?;
    let snap = state.live.snapshot(&state, &mission).await?;
    let telemetry_t = state
        .store
        .list_telemetry(&id, Some(1))
        .await?
        .last()
        .map(|r| r.t_s);
    let format = q.format.unwrap_or(RiskFormat::Json);
    let out = state
        .run_cpu(move || {
            let obs_t = snap.anchor_t_s;
            let anchor = match (telemetry_t, obs_t) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
            let frame = snap.frame;
            let t0 = anchor.unwrap_or(0.0);
            let empty;
            let map = match &snap.map {
                Some(m) => m.as_ref(),
                None => {
                    // No observation yet: an empty map over the mission's grid.
                    empty = predictor::RiskMap::new(
                        crate::live::map_config(&mission, crate::live::snapshot::LIVE_HORIZON_S),
                        &[],
                        t0,
                    )
                    .map_err(|e| ApiError::Internal(format!("risk map: {e}")))?;
                    &empty
                }
            };
            let slice = map.slice(t0 + ahead);
            let horizon_s = map.horizon_s();
            match format {
                RiskFormat::Json => {
                    let (glat, glon) = frame.to_geodetic(slice.origin_m);
                    let (flat, flon) = frame.origin_deg();
                    let max = slice.data.iter().copied().fold(0.0f32, f32::max);
                    Ok::<_, ApiError>(
                        axum::Json(RiskSliceOut {
                            t: slice.t_s,
                            t_ahead_s: slice.t_s - t0,
                            anchor_t: anchor,
                            horizon_s,
                            frame_origin: LatLon {
                                lat: flat,
                                lon: flon,
                            },
                            grid_origin_enu_m: slice.origin_m,
                            grid_origin: LatLon {
                                lat: glat,
                                lon: glon,
                            },
                            cell_m: slice.cell_m,
                            width: slice.width as u64,
                            height: slice.height as u64,
                            values: slice.data,
                            max,
                        })
                        .into_response(),
                    )
                }
                RiskFormat::Png => {
                    let movers: Vec<([f64; 2], [f64; 2], f64)> = snap
                        .predictor
                        .obstacles()
                        .map(|s| {
                            (
                                s.estimates.position_m,
                                s.estimates.velocity_mps,
                                s.last_observation.radius_m,
                            )
                        })
                        .collect();
                    let png = render_png(&slice, &frame, &mission, &movers)
                        .map_err(|e| ApiError::Internal(format!("png: {e}")))?;
                    let mut resp = png.into_response();
                    resp.headers_mut()
                        .insert(header::CONTENT_TYPE, HeaderValue::from_static("image/png"));
                    Ok(resp)
                }
            }
        })
        .await??;
    Ok(out)
}

/// Renders a slice as a heatmap (white = no risk, pale yellow through orange to dark red =
/// certain, on a square-root scale so that a spread cloud of a few percent shows),
/// north up, with the fly zones (blue), waypoints (green), stationary cylinders (black)
/// and moving obstacles at their last fitted position (magenta circle of their radius, a
/// line showing 10 s at their estimated velocity). A 100 m scale bar sits bottom left.
fn render_png(
    slice: &predictor::SliceView,
    frame: &LocalFrame,
    mission: &Mission,
    movers: &[([f64; 2], [f64; 2], f64)],
) -> Result<Vec<u8>, image::ImageError> {
    let s = (900 / slice.width.max(slice.height).max(1)).clamp(1, 8) as u32;
    let (w, h) = (slice.width as u32 * s, slice.height as u32 * s);
    let mut img = image::RgbImage::new(w.max(1), h.max(1));
    for py in 0..h {
        for px in 0..w {
            let (cx, cy) = ((px / s) as usize, slice.height - 1 - (py / s) as usize);
            let r = slice.data[cy * slice.width + cx];
            img.put_pixel(px, py, image::Rgb(heat(r)));
        }
    }
    let to_px = |p: [f64; 2]| -> (f64, f64) {
        let x = (p[0] - slice.origin_m[0]) / slice.cell_m * f64::from(s);
        let y = f64::from(h) - (p[1] - slice.origin_m[1]) / slice.cell_m * f64::from(s);
        (x, y)
    };
    let px_per_m = f64::from(s) / slice.cell_m;
    // Light 100 m grid for scale.
    let grid = [225, 225, 225];
    let mut gx = (slice.origin_m[0] / 100.0).ceil() * 100.0;
    while gx < slice.origin_m[0] + slice.width as f64 * slice.cell_m {
        let (x, _) = to_px([gx, 0.0]);
        line(&mut img, (x, 0.0), (x, f64::from(h)), grid, 1);
        gx += 100.0;
    }
    let mut gy = (slice.origin_m[1] / 100.0).ceil() * 100.0;
    while gy < slice.origin_m[1] + slice.height as f64 * slice.cell_m {
        let (_, y) = to_px([0.0, gy]);
        line(&mut img, (0.0, y), (f64::from(w), y), grid, 1);
        gy += 100.0;
    }
    // Re-paint the risk over the grid lines so the grid never hides risk.
    for py in 0..h {
        for px in 0..w {
            let (cx, cy) = ((px / s) as usize, slice.height - 1 - (py / s) as usize);
            let r = slice.data[cy * slice.width + cx];
            if r > 0.005 {
                img.put_pixel(px, py, image::Rgb(heat(r)));
            }
        }
    }
    for z in &mission.content.fly_zones {
        let pts: Vec<(f64, f64)> = z
            .boundary
            .iter()
            .map(|p| to_px(frame.to_enu(p.lat, p.lon)))
            .collect();
        for i in 0..pts.len() {
            line(&mut img, pts[i], pts[(i + 1) % pts.len()], [0, 90, 200], 3);
        }
    }
    let wps: Vec<(f64, f64)> = mission
        .content
        .waypoints
        .iter()
        .map(|p| to_px(frame.to_enu(p.lat, p.lon)))
        .collect();
    for pair in wps.windows(2) {
        line(&mut img, pair[0], pair[1], [60, 170, 60], 1);
    }
    for p in &wps {
        disc(&mut img, *p, 4.0, [0, 140, 0]);
    }
    for c in &mission.content.stationary_obstacles {
        let p = to_px(frame.to_enu(c.lat, c.lon));
        circle(&mut img, p, c.radius_m * px_per_m, [20, 20, 20], 3);
        disc(&mut img, p, 2.0, [20, 20, 20]);
    }
    for (p, v, r) in movers {
        let c = to_px(*p);
        circle(&mut img, c, r * px_per_m, [200, 0, 200], 3);
        disc(&mut img, c, 3.0, [200, 0, 200]);
        let tip = to_px([p[0] + 10.0 * v[0], p[1] + 10.0 * v[1]]);
        line(&mut img, c, tip, [200, 0, 200], 2);
    }
    // 100 m scale bar.
    let y = f64::from(h) - 12.0;
    line(
        &mut img,
        (10.0, y),
        (10.0 + 100.0 * px_per_m, y),
        [0, 0, 0],
        3,
    );
    line(&mut img, (10.0, y - 5.0), (10.0, y + 5.0), [0, 0, 0], 2);
    let xe = 10.0 + 100.0 * px_per_m;
    line(&mut img, (xe, y - 5.0), (xe, y + 5.0), [0, 0, 0], 2);
    // North arrow, top right.
    let (ax, ay) = (f64::from(w) - 20.0, 10.0);
    line(&mut img, (ax, ay + 30.0), (ax, ay), [0, 0, 0], 2);
    line(&mut img, (ax, ay), (ax - 7.0, ay + 10.0), [0, 0, 0], 2);
    line(&mut img, (ax, ay), (ax + 7.0, ay + 10.0), [0, 0, 0], 2);
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)?;
    Ok(out.into_inner())
}

fn heat(r: f32) -> [u8; 3] {
    let lerp = |a: [f32; 3], b: [f32; 3], f: f32| -> [u8; 3] {
        [0, 1, 2].map(|i| (a[i] + (b[i] - a[i]) * f).round().clamp(0.0, 255.0) as u8)
    };
    let r = r.clamp(0.0, 1.0);
    if r <= 0.005 {
        return [250, 250, 250];
    }
    // Square root: a spread-out cloud of a few percent per cell is still visible.
    let r = r.sqrt();
    if r <= 0.0 {
        [250, 250, 250]
    } else if r < 0.5 {
        lerp([255.0, 240.0, 170.0], [255.0, 140.0, 0.0], r / 0.5)
    } else {
        lerp([255.0, 140.0, 0.0], [170.0, 0.0, 0.0], (r - 0.5) / 0.5)
    }
}

fn plot(img: &mut image::RgbImage, x: f64, y: f64, c: [u8; 3], thick: u32) {
    let half = f64::from(thick) / 2.0;
    let (x0, y0) = ((x - half).round() as i64, (y - half).round() as i64);
    for dy in 0..i64::from(thick) {
        for dx in 0..i64::from(thick) {
            let (px, py) = (x0 + dx, y0 + dy);
            if px >= 0 && py >= 0 && px < i64::from(img.width()) && py < i64::from(img.height()) {
                img.put_pixel(px as u32, py as u32, image::Rgb(c));
            }
        }
    }
}

fn line(img: &mut image::RgbImage, a: (f64, f64), b: (f64, f64), c: [u8; 3], thick: u32) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).clamp(1, 100_000);
    for i in 0..=n {
        let f = i as f64 / n as f64;
        plot(img, a.0 + (b.0 - a.0) * f, a.1 + (b.1 - a.1) * f, c, thick);
    }
}

fn circle(img: &mut image::RgbImage, c: (f64, f64), r: f64, col: [u8; 3], thick: u32) {
    let n = ((r * std::f64::consts::TAU).ceil() as usize).clamp(16, 100_000);
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        plot(img, c.0 + r * a.cos(), c.1 + r * a.sin(), col, thick);
    }
}

fn disc(img: &mut image::RgbImage, c: (f64, f64), r: f64, col: [u8; 3]) {
    let ri = r.ceil() as i64;
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            if ((dx * dx + dy * dy) as f64) <= r * r {
                plot(img, c.0 + dx as f64, c.1 + dy as f64, col, 1);
            }
        }
    }
}

/// Obstacle and risk-map routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(list_obstacles))
        .routes(routes!(get_risk))
}
