//! Plan downloads: `GET .../plans/{plan_id}` (the plan as JSON; `?format=` answers 303 to a
//! file), and the files for ground stations, one operation (and one media type) per format:
//! `GET .../plans/{plan_id}/qgc-wpl` (QGC WPL 110 text) and `.../qgc-plan` (QGroundControl
//! `.plan` JSON). Both come from the stored plan, never recomputed.

use axum::extract::{Path, State};
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use utoipa_axum::{router::OpenApiRouter, routes};

use planner::ItemKind;
use planner::export::qgc_plan::{ExclusionCircle, qgc_plan_with_fence};
use planner::export::{GeoItem, GeoPoint, PlanFileOptions, qgc_wpl};

use super::plan_record::stored_plan_out;
use super::plan_types::{GetParams, KindOut, PlanFormat, PlanOut};
use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::ApiQuery;
use crate::mission::Mission;
use wire::ids::{MissionId, PlanId};

/// One stored plan as JSON. `?format=qgc-wpl` / `qgc-plan` answers 303 to the plan's file
/// download (`.../qgc-wpl`, `.../qgc-plan`), kept for older clients.
#[utoipa::path(get, path = "/api/v1/missions/{id}/plans/{plan_id}", tag = "plans",
    params(("id" = String, Path, description = "Mission id"), ("plan_id" = String, Path, description = "Plan id"), GetParams),
    responses(
        (status = 200, description = "The plan", body = PlanOut),
        (status = 303, description = "`format=qgc-wpl` or `qgc-plan`: `Location` names the file download",
            headers(("Location" = String, description = "URL of the file download"))),
        (status = 400, description = "Unknown format", body = Problem, content_type = "application/problem+json"),
    ))]
async fn get_plan(
    State(state): State<AppState>,
    Path((id, plan_id)): Path<(MissionId, PlanId)>,
    ApiQuery(q): ApiQuery<GetParams>,
) -> Result<Response, ApiError> {
    let fmt = q.format.unwrap_or(PlanFormat::Json);
    if !matches!(fmt, PlanFormat::Json) {
        // Only stored ids (plain ASCII) reach the Location header.
        super::missions::load(&state, &id).await?;
        state
            .store
            .get_plan(&id, &plan_id)
            .await?
            .ok_or_else(|| ApiError::not_found("plan", plan_id.clone()))?;
        let file = if matches!(fmt, PlanFormat::QgcWpl) {
            "qgc-wpl"
        } else {
            "qgc-plan"
        };
        let location = format!("/api/v1/missions/{id}/plans/{plan_id}/{file}");
        return super::see_other(&location);
    }
    plan_file(&state, &id, &plan_id, fmt).await
}

/// A stored plan in format `fmt`: the stored JSON, a QGC WPL 110 text file or a
/// QGroundControl `.plan` file (as an attachment).
///
/// # Errors
/// 404 when the mission or the plan does not exist.
pub(crate) async fn plan_file(
    state: &AppState,
    id: &MissionId,
    plan_id: &PlanId,
    fmt: PlanFormat,
) -> Result<Response, ApiError> {
    let mission = super::missions::load(state, id).await?;
    let row = state
        .store
        .get_plan(id, plan_id)
        .await?
        .ok_or_else(|| ApiError::not_found("plan", plan_id))?;
    let out = stored_plan_out(&row)?;
    if matches!(fmt, PlanFormat::Json) {
        return Ok(axum::Json(out).into_response());
    }
    let (text, ctype, ext) = plan_file_text(&mission, &out, fmt);
    let mut resp = text.into_response();
    let h = resp.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(ctype));
    h.insert(
        header::CONTENT_DISPOSITION,
        HeaderValue::from_str(&format!(
            "attachment; filename=\"{id}-r{}.{ext}\"",
            out.revision
        ))
        .map_err(|e| ApiError::Internal(e.to_string()))?,
    );
    Ok(resp)
}

/// A plan as a file: (contents, media type, file extension). `fmt` `json` gives the plan
/// as pretty JSON; `qgc-wpl` a QGC WPL 110 text file (index 0 = home); `qgc-plan` a
/// QGroundControl `.plan` with the fly zones as inclusion fences and the cylinders as
/// exclusion circles.
pub fn plan_file_text(
    mission: &Mission,
    out: &PlanOut,
    fmt: PlanFormat,
) -> (String, &'static str, &'static str) {
    if matches!(fmt, PlanFormat::Json) {
        let mut s = serde_json::to_string_pretty(out).unwrap_or_default();
        s.push('\n');
        return (s, "application/json", "json");
    }
    let home = GeoItem {
        lat_deg: mission.home.lat,
        lon_deg: mission.home.lon,
        alt_msl_m: mission.home.alt_msl_m.unwrap_or(0.0),
        kind: ItemKind::Mission,
    };
    let items: Vec<GeoItem> = out
        .waypoints
        .iter()
        .map(|w| GeoItem {
            lat_deg: w.lat,
            lon_deg: w.lon,
            alt_msl_m: w.alt_msl_m,
            kind: match w.kind {
                KindOut::Mission => ItemKind::Mission,
                KindOut::Avoid => ItemKind::Avoid,
                KindOut::Search => ItemKind::Search,
            },
        })
        .collect();
    match fmt {
        PlanFormat::QgcWpl => (
            qgc_wpl(&home, &items),
            "text/plain; charset=utf-8",
            "waypoints",
        ),
        _ => {
            let zones: Vec<Vec<GeoPoint>> = mission
                .content
                .fly_zones
                .iter()
                .map(|z| {
                    z.boundary
                        .iter()
                        .map(|p| GeoPoint {
                            lat_deg: p.lat,
                            lon_deg: p.lon,
                        })
                        .collect()
                })
                .collect();
            let cylinders: Vec<ExclusionCircle> = mission
                .content
                .stationary_obstacles
                .iter()
                .map(|c| ExclusionCircle {
                    center: GeoPoint {
                        lat_deg: c.lat,
                        lon_deg: c.lon,
                    },
                    radius_m: c.radius_m,
                })
                .collect();
            (
                qgc_plan_with_fence(
                    &home,
                    &items,
                    &zones,
                    &cylinders,
                    &PlanFileOptions::default(),
                ),
                "application/json",
                "plan",
            )
        }
    }
}

/// A stored plan as a QGC WPL 110 file (index 0 = home).
#[utoipa::path(get, path = "/api/v1/missions/{id}/plans/{plan_id}/qgc-wpl", tag = "plans",
    params(("id" = String, Path, description = "Mission id"), ("plan_id" = String, Path, description = "Plan id")),
    responses(
        (status = 200, description = "QGC WPL 110 text: tab-separated, index 0 = home, loadable by QGroundControl and pymavlink",
            body = String, content_type = "text/plain"),
    ))]
async fn get_plan_wpl(
    State(state): State<AppState>,
    Path((id, plan_id)): Path<(MissionId, PlanId)>,
) -> Result<Response, ApiError> {
    plan_file(&state, &id, &plan_id, PlanFormat::QgcWpl).await
}

/// A stored plan as a QGroundControl `.plan` file, the fly zones as inclusion geofences and
/// the stationary obstacles (cylinders) as exclusion circles.
#[utoipa::path(get, path = "/api/v1/missions/{id}/plans/{plan_id}/qgc-plan", tag = "plans",
    params(("id" = String, Path, description = "Mission id"), ("plan_id" = String, Path, description = "Plan id")),
    responses(
        (status = 200, description = "A QGroundControl `.plan` JSON document (`fileType: Plan`)",
            body = Object, content_type = "application/json"),
    ))]
async fn get_plan_qgc(
    State(state): State<AppState>,
    Path((id, plan_id)): Path<(MissionId, PlanId)>,
) -> Result<Response, ApiError> {
    plan_file(&state, &id, &plan_id, PlanFormat::QgcPlan).await
}

/// Plan file routes.
pub(crate) fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(get_plan))
        .routes(routes!(get_plan_wpl))
        .routes(routes!(get_plan_qgc))
}
