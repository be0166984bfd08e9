//! Missions: upload (native, interop 2017/2018, interop 2019+ protobuf-JSON), list, get,
//! delete.

use axum::extract::{Path, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use utoipa::IntoParams;
use utoipa_axum::{router::OpenApiRouter, routes};

use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::{ApiQuery, Body, parse_json, require_json};
use crate::mission::{Mission, MissionInput, SourceFormat};
use crate::time::{format_rfc3339, now_s};
use wire::ids::MissionId;

/// `?format=` of a mission upload.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct UploadParams {
    /// Forces the body's format instead of detecting it: `native`, `interop-2018` or
    /// `interop-2019`.
    pub format: Option<SourceFormat>,
}

/// Upload a mission.
///
/// The body is jink's native mission JSON, an interop 2017/2018 mission (or the 2018
/// `GET /api/missions` list), or an interop 2019+ protobuf-JSON mission (camelCase or
/// snake_case keys). The format is detected unless `?format=` forces it. Interop feet and
/// knots become metres and m/s. A list creates every mission in it, all or none, and
/// answers with the list.
#[utoipa::path(post, path = "/api/v1/missions", tag = "missions", params(UploadParams),
    request_body(content = MissionInput, description = "A mission in native form (or an interop mission, detected)", content_type = "application/json"),
    responses(
        (status = 201, description = "Stored; `Location` names the (first) mission", body = Mission,
            headers(("Location" = String, description = "URL of the stored mission"))),
        (status = 422, description = "Invalid mission: each offending field named by a JSON pointer", body = Problem, content_type = "application/problem+json"),
    ))]
async fn create_mission(
    State(state): State<AppState>,
    ApiQuery(params): ApiQuery<UploadParams>,
    headers: HeaderMap,
    Body(body): Body,
) -> Result<Response, ApiError> {
    require_json(&headers)?;
    let value: serde_json::Value = parse_json(&body)?;
    crate::limits::check_items(&value, &state.settings.access.items)?;
    let is_list = value.is_array();
    let read = wire::domain::read_missions(value, params.format)?;
    let (format, now) = (read.format, now_s());
    let missions: Vec<Mission> = read
        .missions
        .into_iter()
        .map(|(content, home)| Mission {
            id: new_mission_id().into(),
            source_format: format,
            created_at: format_rfc3339(now),
            home,
            content,
        })
        .collect();
    state.store.insert_missions(&missions, now).await?;
    tracing::info!(
        n = missions.len(),
        format = format.as_str(),
        "missions stored"
    );
    let location = format!("/api/v1/missions/{}", missions[0].id);
    let writer = crate::auth::writer();
    let body = if is_list {
        let all: Vec<serde_json::Value> = missions
            .iter()
            .map(|m| crate::auth::with_writer(m, &writer))
            .collect();
        serde_json::to_vec(&all)
    } else {
        serde_json::to_vec(&crate::auth::with_writer(&missions[0], &writer))
    }
    .map_err(|e| ApiError::Internal(e.to_string()))?;
    let mut resp = (StatusCode::CREATED, body).into_response();
    let h = resp.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/json"),
    );
    h.insert(
        header::LOCATION,
        HeaderValue::from_str(&location).map_err(|e| ApiError::Internal(e.to_string()))?,
    );
    Ok(resp)
}

/// A new mission id: 16 hex digits, random.
fn new_mission_id() -> String {
    format!("{:016x}", rand::random::<u64>())
}

/// List every mission, oldest first.
#[utoipa::path(get, path = "/api/v1/missions", tag = "missions",
    responses((status = 200, description = "All stored missions", body = [Mission])))]
async fn list_missions(
    State(state): State<AppState>,
) -> Result<axum::Json<Vec<serde_json::Value>>, ApiError> {
    let writers = state.store.mission_writers(None).await?;
    let missions = state.store.list_missions().await?;
    Ok(axum::Json(
        missions
            .iter()
            .map(|m| {
                let w = writers
                    .get(m.id.as_str())
                    .map_or(crate::auth::LOCAL, String::as_str);
                crate::auth::with_writer(m, w)
            })
            .collect(),
    ))
}

/// One mission in native form.
#[utoipa::path(get, path = "/api/v1/missions/{id}", tag = "missions",
    params(("id" = String, Path, description = "Mission id")),
    responses(
        (status = 200, description = "The mission", body = Mission),
    ))]
async fn get_mission(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
) -> Result<axum::Json<serde_json::Value>, ApiError> {
    let mission = load(&state, &id).await?;
    let writers = state.store.mission_writers(Some(&id)).await?;
    let w = writers
        .get(id.as_str())
        .map_or(crate::auth::LOCAL, String::as_str);
    Ok(axum::Json(crate::auth::with_writer(&mission, w)))
}

/// Delete a mission and all telemetry, plans and state recorded for it.
#[utoipa::path(delete, path = "/api/v1/missions/{id}", tag = "missions",
    params(("id" = String, Path, description = "Mission id")),
    responses(
        (status = 204, description = "Deleted"),
    ))]
async fn delete_mission(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
) -> Result<StatusCode, ApiError> {
    if state.store.delete_mission(&id).await? {
        state.live.forget(&id);
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(ApiError::not_found("mission", id))
    }
}

/// Loads a mission or answers 404.
///
/// # Errors
/// 404 when the mission does not exist; 500 on a database failure.
pub async fn load(state: &AppState, id: &MissionId) -> Result<Mission, ApiError> {
    state
        .store
        .get_mission(id)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", id.as_str()))
}

/// Answers 404 unless the mission exists (without loading it).
///
/// # Errors
/// 404 when the mission does not exist; 500 on a database failure.
pub(crate) async fn ensure_exists(state: &AppState, id: &MissionId) -> Result<(), ApiError> {
    if state.store.mission_exists(id).await? {
        Ok(())
    } else {
        Err(ApiError::not_found("mission", id.as_str()))
    }
}

/// Mission routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(create_mission, list_missions))
        .routes(routes!(get_mission, delete_mission))
}
