//! Risk maps (seed 002), one operation per media type: `GET /api/v1/missions/{id}/risk`
//! answers a slice of the risk map as JSON, `GET /api/v1/missions/{id}/risk/png` draws the
//! same slice as a PNG heatmap ([`crate::render`]). The older `GET .../risk?format=png`
//! answers 303 to the PNG.
//!
//! Both read the mission's live snapshot ([`crate::live`]): the same risk map a plan asked
//! at the same moment uses.

use axum::extract::{Path, State};
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};
use utoipa_axum::{router::OpenApiRouter, routes};

use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::ApiQuery;
use crate::live::snapshot::LIVE_HORIZON_S;
use crate::mission::LatLon;
use wire::ids::MissionId;

/// `?t=&format=` of the risk map as JSON.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub(crate) struct RiskParams {
    /// Seconds ahead of the latest aircraft telemetry or obstacle observation (whichever
    /// is newer), from 0 to the map's horizon (30 s); default 0.
    #[param(minimum = 0, maximum = 30)]
    pub t: Option<f64>,
    /// `json` (default). `png` answers 303 to `.../risk/png` (kept for older clients).
    pub format: Option<RiskFormat>,
}

/// `?t=` of the risk map as a PNG.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub(crate) struct RiskPngParams {
    /// Seconds ahead of the latest aircraft telemetry or obstacle observation (whichever
    /// is newer), from 0 to the map's horizon (30 s); default 0.
    #[param(minimum = 0, maximum = 30)]
    pub t: Option<f64>,
}

/// Risk-map output format of the older `?format=` parameter.
#[derive(Debug, Clone, Copy, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub(crate) enum RiskFormat {
    /// The slice as JSON numbers.
    Json,
    /// Redirects (303) to `.../risk/png`.
    Png,
}

/// One slice of the risk map.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub(crate) struct RiskSliceOut {
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

/// A slice of the live risk map and what it was cut from.
pub(crate) struct Slice {
    pub slice: predictor::SliceView,
    pub snap: std::sync::Arc<crate::live::Snapshot>,
    pub mission: crate::mission::Mission,
    /// Latest aircraft telemetry or observation time (None with no data at all).
    pub anchor_t: Option<f64>,
    /// The anchor, or 0 without one.
    pub t0: f64,
    pub horizon_s: f64,
}

fn t_out_of_range(t: f64) -> ApiError {
    ApiError::field(
        "/t",
        format!("t must be in [0, {LIVE_HORIZON_S}] seconds, got {t}"),
    )
}

/// `?t=` (default 0) within the live map's horizon, else 422 naming `/t`.
fn check_t_ahead(t: Option<f64>) -> Result<f64, ApiError> {
    let t = t.unwrap_or(0.0);
    if t.is_finite() && (0.0..=LIVE_HORIZON_S).contains(&t) {
        Ok(t)
    } else {
        Err(t_out_of_range(t))
    }
}

/// Cuts the slice `t_ahead` seconds after the anchor off the live map, then hands it to
/// `f` (on the CPU pool).
///
/// # Errors
/// 404 without the mission; 422 naming `/t` when `t_ahead` is not within the map's
/// horizon.
pub(crate) async fn with_slice<T: Send + 'static>(
    state: &AppState,
    id: &MissionId,
    t_ahead: Option<f64>,
    f: impl FnOnce(Slice) -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    let ahead = check_t_ahead(t_ahead)?;
    let mission = super::missions::load(state, id).await?;
    let snap = state.live.snapshot(state, &mission).await?;
    let telemetry_t = state
        .store
        .list_telemetry(id, Some(1))
        .await?
        .last()
        .map(|r| r.t_s);
    state
        .run_cpu(move || {
            let anchor_t = match (telemetry_t, snap.anchor_t_s) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
            let t0 = anchor_t.unwrap_or(0.0);
            let empty;
            let map = match &snap.map {
                Some(m) => m.as_ref(),
                None => {
                    // No observation yet: an empty map over the mission's grid.
                    empty = predictor::RiskMap::new(
                        crate::live::map_config(&mission, LIVE_HORIZON_S),
                        &[],
                        t0,
                    )
                    .map_err(|e| ApiError::Internal(format!("risk map: {e}")))?;
                    &empty
                }
            };
            let horizon_s = map.horizon_s();
            if ahead > horizon_s {
                return Err(t_out_of_range(ahead));
            }
            let slice = map.slice(t0 + ahead);
            f(Slice {
                slice,
                snap,
                mission,
                anchor_t,
                t0,
                horizon_s,
            })
        })
        .await?
}

/// A slice of the obstacle risk map, as JSON.
///
/// The map covers the fly zones plus 300 m in 10 m cells, in half-second slices over 30 s from
/// the anchor (the latest aircraft telemetry or obstacle observation). Each moving obstacle
/// contributes by its stage's model (a growing disc while NoFly, particles otherwise);
/// obstacles combine as `1 - prod(1 - p)`. Stationary cylinders are hard constraints and
/// are not in the values (the PNG draws them).
#[utoipa::path(get, path = "/api/v1/missions/{id}/risk", tag = "prediction",
    params(("id" = String, Path, description = "Mission id"), RiskParams),
    responses(
        (status = 200, description = "The slice as a JSON grid", body = RiskSliceOut),
        (status = 303, description = "`format=png`: `Location` names the PNG of the same slice",
            headers(("Location" = String, description = "URL of the PNG"))),
        (status = 422, description = "t out of range", body = Problem, content_type = "application/problem+json"),
    ))]
async fn get_risk(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<RiskParams>,
) -> Result<Response, ApiError> {
    if matches!(q.format, Some(RiskFormat::Png)) {
        check_t_ahead(q.t)?;
        // Only stored ids (plain ASCII) reach the Location header.
        super::missions::load(&state, &id).await?;
        let query = q.t.map(|t| format!("?t={t}")).unwrap_or_default();
        let location = format!("/api/v1/missions/{id}/risk/png{query}");
        return super::see_other(&location);
    }
    let out = with_slice(&state, &id, q.t, |s| {
        let frame = s.snap.frame;
        let (glat, glon) = frame.to_geodetic(s.slice.origin_m);
        let (flat, flon) = frame.origin_deg();
        let max = s.slice.data.iter().copied().fold(0.0f32, f32::max);
        Ok(RiskSliceOut {
            t: s.slice.t_s,
            t_ahead_s: s.slice.t_s - s.t0,
            anchor_t: s.anchor_t,
            horizon_s: s.horizon_s,
            frame_origin: LatLon {
                lat: flat,
                lon: flon,
            },
            grid_origin_enu_m: s.slice.origin_m,
            grid_origin: LatLon {
                lat: glat,
                lon: glon,
            },
            cell_m: s.slice.cell_m,
            width: s.slice.width as u64,
            height: s.slice.height as u64,
            values: s.slice.data,
            max,
        })
    })
    .await?;
    Ok(axum::Json(out).into_response())
}

/// A slice of the obstacle risk map, drawn as a PNG heatmap.
///
/// The same slice as `GET .../risk`, north up: risk on a square-root colour scale (white,
/// pale yellow, orange, dark red) with its legend, fly zones blue, waypoints green,
/// cylinders black, moving obstacles magenta with a 10 s velocity line, the current plan
/// (dark green legs, orange avoid waypoints) from the item before the one flown toward,
/// the aircraft (a blue arrow along its heading), a 100 m scale bar and the slice's time
/// (seconds ahead, and UTC). The operator page's risk layer uses the same colours.
#[utoipa::path(get, path = "/api/v1/missions/{id}/risk/png", tag = "prediction",
    params(("id" = String, Path, description = "Mission id"), RiskPngParams),
    responses(
        (status = 200, description = "The slice as a PNG heatmap", body = Vec<u8>, content_type = "image/png"),
        (status = 422, description = "t out of range", body = Problem, content_type = "application/problem+json"),
    ))]
async fn get_risk_png(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<RiskPngParams>,
) -> Result<Response, ApiError> {
    let aircraft = state.store.list_telemetry(&id, Some(1)).await?.pop();
    let plan = match state.store.latest_plan_revision(&id).await? {
        0 => None,
        r => state
            .store
            .get_plan_by_revision(&id, r)
            .await?
            .map(|row| super::plan_record::stored_plan_out(&row))
            .transpose()?,
    };
    let png = with_slice(&state, &id, q.t, move |s| {
        let frame = s.snap.frame;
        let overlay = crate::render::Overlay {
            aircraft: aircraft.map(|a| (frame.to_enu(a.lat_deg, a.lon_deg), a.heading_deg)),
            plan: plan.map_or_else(Vec::new, |p| {
                p.waypoints
                    .iter()
                    .skip(p.current_index.saturating_sub(1))
                    .map(|w| {
                        (
                            frame.to_enu(w.lat, w.lon),
                            w.kind == super::plans::KindOut::Avoid,
                        )
                    })
                    .collect()
            }),
            t_s: s.anchor_t.map(|_| s.slice.t_s),
        };
        let movers: Vec<crate::render::Mover> = s
            .snap
            .predictor
            .obstacles()
            .map(|o| crate::render::Mover {
                p_m: o.estimates.position_m,
                v_mps: o.estimates.velocity_mps,
                radius_m: o.last_observation.radius_m,
            })
            .collect();
        crate::render::risk_png(
            &s.slice,
            &s.snap.frame,
            &s.mission,
            &movers,
            &overlay,
            s.slice.t_s - s.t0,
        )
        .map_err(|e| ApiError::Internal(format!("png: {e}")))
    })
    .await?;
    let mut resp = png.into_response();
    resp.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static("image/png"));
    Ok(resp)
}

/// Risk-map routes.
pub(crate) fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(get_risk))
        .routes(routes!(get_risk_png))
}
