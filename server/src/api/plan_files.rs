//! Plan file downloads for ground stations, one operation (and one media type) per format:
//! `GET .../plans/{plan_id}/qgc-wpl` (QGC WPL 110 text) and `.../qgc-plan` (QGroundControl
//! `.plan` JSON). Both come from the stored plan, never recomputed.

use axum::extract::{Path, State};
use axum::response::Response;
use utoipa_axum::{router::OpenApiRouter, routes};

use super::plans::{PlanFormat, plan_file};
use crate::app::AppState;
use crate::error::{ApiError, Problem};
use wire::ids::{MissionId, PlanId};

/// A stored plan as a QGC WPL 110 file (index 0 = home).
#[utoipa::path(get, path = "/api/v1/missions/{id}/plans/{plan_id}/qgc-wpl", tag = "plans",
    params(("id" = String, Path, description = "Mission id"), ("plan_id" = String, Path, description = "Plan id")),
    responses(
        (status = 200, description = "QGC WPL 110 text: tab-separated, index 0 = home, loadable by QGroundControl and pymavlink",
            body = String, content_type = "text/plain"),
        (status = 404, description = "No such mission or plan", body = Problem, content_type = "application/problem+json"),
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
        (status = 404, description = "No such mission or plan", body = Problem, content_type = "application/problem+json"),
    ))]
async fn get_plan_qgc(
    State(state): State<AppState>,
    Path((id, plan_id)): Path<(MissionId, PlanId)>,
) -> Result<Response, ApiError> {
    plan_file(&state, &id, &plan_id, PlanFormat::QgcPlan).await
}

/// Plan file routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(get_plan_wpl))
        .routes(routes!(get_plan_qgc))
}
