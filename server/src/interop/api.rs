//! The interop-compatible surface: the judges' server's paths and formats, so that a
//! team's existing interop clients talk to jink unchanged.
//!
//! | path | generation | answer |
//! |---|---|---|
//! | `POST /api/login` | 2019+ JSON, 2017/2018 form | `sessionid` cookie |
//! | `GET /api/missions` | both | every mission, judges' format (feet) |
//! | `GET /api/missions/{id}` | both | one mission, judges' format (feet) |
//! | `POST /api/telemetry` | 2019+ JSON, 2017/2018 form | into the active mission's telemetry |
//! | `GET /api/obstacles` | 2017/2018 | the active mission's obstacles from the live state |
//! | `GET /api/teams` | 2019+ | this client's team status |
//!
//! Logins map onto jink's access model: on an open (loopback) bind any credentials log in
//! (a valid token pair logs in as that token); on a guarded bind the username names a
//! token and the password is the token (`jink token create --name USER`), with its role.

use axum::extract::{Path, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};
use utoipa_axum::{router::OpenApiRouter, routes};

use super::{Session, active_mission, mission_named, number_of, session_cookie};
use crate::app::AppState;
use crate::auth::AuthMode;
use crate::error::{ApiError, Problem};
use crate::extract::{ApiQuery, Body, MediaType, media_type, parse_json};
use crate::mission::{Mission, SourceFormat};
use crate::time::{format_rfc3339, now_s};
use wire::interop::{
    MovingPosition, m_to_ft, render_mission_2018, render_mission_2019, render_obstacles_2018,
};

/// Interop login credentials (2019+ JSON; 2017/2018 sent the same fields form-encoded).
#[derive(Debug, Deserialize, ToSchema)]
pub struct Credentials {
    /// On a guarded bind: the name of a jink token. On an open bind: any name.
    pub username: String,
    /// On a guarded bind: the token itself. On an open bind: anything (a token logs in
    /// as that token).
    pub password: String,
}

/// Interop aircraft telemetry (2019+ JSON; 2017/2018 sent `latitude`, `longitude`,
/// `altitude_msl`, `uas_heading` form-encoded).
// The schema of the documented body only: `wire::telemetry` parses it.
#[allow(dead_code)]
#[derive(Debug, ToSchema)]
pub struct InteropTelemetry {
    /// Latitude, degrees.
    #[schema(minimum = -90.0, maximum = 90.0)]
    pub latitude: f64,
    /// Longitude, degrees.
    #[schema(minimum = -180.0, maximum = 180.0)]
    pub longitude: f64,
    /// Altitude, feet MSL.
    pub altitude: f64,
    /// Heading, degrees true (360 is read as 0).
    #[schema(minimum = 0.0, maximum = 360.0)]
    pub heading: f64,
}

/// `?format=` of the mission paths.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct MissionFormatQuery {
    /// `interop-2018` or `interop-2019` (or `native`); default: `serve --interop-format`
    /// (`auto`: the mission's source format, 2019+ for native missions).
    pub format: Option<SourceFormat>,
}

fn text(status: StatusCode, body: &'static str) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
        body,
    )
        .into_response()
}

/// The session a request's cookie names, with its cookie value.
fn session(state: &AppState, headers: &HeaderMap) -> Option<(String, Session)> {
    let id = session_cookie(headers)?;
    let s = state.interop.sessions.get(&id)?;
    Some((id, s))
}

/// Reads login credentials from JSON (2019+) or a form (2017/2018).
fn credentials(headers: &HeaderMap, body: &[u8]) -> Result<Credentials, ApiError> {
    let from_form = |body: &[u8]| -> Result<Credentials, ApiError> {
        let fields: std::collections::HashMap<String, String> = serde_urlencoded::from_bytes(body)
            .map_err(|e| {
                ApiError::bad_request(format!(
                    "invalid login form: {e} (expected username, password)"
                ))
            })?;
        let field = |k: &str| {
            fields
                .get(k)
                .cloned()
                .ok_or_else(|| ApiError::field(format!("/{k}"), format!("missing field `{k}`")))
        };
        Ok(Credentials {
            username: field("username")?,
            password: field("password")?,
        })
    };
    match media_type(headers) {
        MediaType::Json => parse_json(body),
        MediaType::Form => from_form(body),
        MediaType::Missing if body.trim_ascii_start().starts_with(b"{") => parse_json(body),
        MediaType::Missing => from_form(body),
        MediaType::Other => Err(ApiError::UnsupportedMediaType(
            "a login is application/json (2019+) or application/x-www-form-urlencoded (2017/2018)"
                .into(),
        )),
    }
}

/// Log in (interop).
///
/// 2019+ JSON `{"username", "password"}` or 2017/2018 form fields of the same names.
/// Answers a `sessionid` cookie the other interop paths accept in place of a bearer token.
/// On an open (loopback) bind any credentials log in; on a guarded bind the username names
/// a token and the password is that token, and the session has the token's role.
#[utoipa::path(post, path = "/api/login", tag = "interop",
    request_body(content = Credentials, description = "JSON (2019+) or form-encoded (2017/2018)", content_type = "application/json"),
    responses(
        (status = 200, description = "Logged in; `Set-Cookie: sessionid=...`", body = String, content_type = "text/plain",
            headers(("Set-Cookie" = String, description = "The session cookie"))),
        (status = 400, description = "Missing or malformed credentials", body = Problem, content_type = "application/problem+json"),
        (status = 401, description = "No token of that name and text (guarded bind)", body = Problem, content_type = "application/problem+json"),
    ))]
async fn interop_login(
    State(state): State<AppState>,
    headers: HeaderMap,
    Body(body): Body,
) -> Result<Response, ApiError> {
    let creds = credentials(&headers, &body)?;
    let verified = if creds.password.is_empty() {
        None
    } else {
        state
            .guard
            .tokens
            .verify(&state.store, &creds.password)
            .await?
    };
    let token = match verified {
        Some(p) if *p.name == *creds.username => Some(creds.password),
        Some(_) => {
            return Err(ApiError::Unauthorized(
                "the password is a token of another name: the username must name the token".into(),
            ));
        }
        None if state.settings.access.auth == AuthMode::Optional => None,
        None => {
            return Err(ApiError::Unauthorized(
                "invalid credentials: the username names a jink token and the password is the token (`jink token create --name USERNAME --role write`)".into(),
            ));
        }
    };
    let id = state.interop.sessions.open(creds.username, token);
    let mut resp = text(StatusCode::OK, "Logged in.");
    let cookie = format!(
        "{}={id}; Path=/; HttpOnly; SameSite=Lax",
        super::SESSION_COOKIE
    );
    resp.headers_mut().insert(
        header::SET_COOKIE,
        HeaderValue::from_str(&cookie).map_err(|e| ApiError::Internal(e.to_string()))?,
    );
    Ok(resp)
}

/// `mission` in `format` (interop formats in feet; `native` as `/api/v1` serves it).
async fn render(
    state: &AppState,
    mission: &Mission,
    format: Option<SourceFormat>,
) -> Result<serde_json::Value, ApiError> {
    let format = format.unwrap_or_else(|| state.interop.format().for_mission(mission));
    let n = number_of(state, mission).await?;
    Ok(match format {
        SourceFormat::Interop2018 => render_mission_2018(mission, n),
        SourceFormat::Interop2019 => render_mission_2019(mission, n),
        SourceFormat::Native => {
            serde_json::to_value(mission).map_err(|e| ApiError::Internal(e.to_string()))?
        }
    })
}

/// List missions (interop).
///
/// Every mission, oldest first, in the judges' format (feet MSL): 2017/2018 JSON or 2019+
/// protobuf-JSON, as `?format=` or `serve --interop-format` says (by default each
/// mission's own source format; native missions as 2019+). `id` is the interop mission id.
#[utoipa::path(get, path = "/api/missions", tag = "interop", params(MissionFormatQuery),
    responses(
        (status = 200, description = "Missions in the judges' format", body = [Object]),
    ))]
async fn interop_list_missions(
    State(state): State<AppState>,
    ApiQuery(q): ApiQuery<MissionFormatQuery>,
) -> Result<axum::Json<Vec<serde_json::Value>>, ApiError> {
    let mut out = Vec::new();
    for m in state.store.list_missions().await? {
        out.push(render(&state, &m, q.format).await?);
    }
    Ok(axum::Json(out))
}

/// One mission (interop).
///
/// `id` is an interop mission id (the judges' id of a mission that came from them, or the
/// number jink gave it) or a jink mission id. Rendered as in `GET /api/missions`. The
/// mission becomes the session's active mission (where its telemetry goes).
#[utoipa::path(get, path = "/api/missions/{id}", tag = "interop",
    params(("id" = String, Path, description = "Interop mission id (integer) or jink mission id"), MissionFormatQuery),
    responses(
        (status = 200, description = "The mission in the judges' format", body = Object),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn interop_get_mission(
    State(state): State<AppState>,
    Path(id): Path<String>,
    ApiQuery(q): ApiQuery<MissionFormatQuery>,
    headers: HeaderMap,
) -> Result<axum::Json<serde_json::Value>, ApiError> {
    let mission = mission_named(&state, &id).await?;
    if let Some((sid, _)) = session(&state, &headers) {
        state.interop.sessions.set_mission(&sid, &mission.id);
    }
    Ok(axum::Json(render(&state, &mission, q.format).await?))
}

/// Post aircraft telemetry (interop).
///
/// 2019+ JSON `{"latitude", "longitude", "altitude" (ft MSL), "heading"}` or 2017/2018
/// form-encoded `latitude`, `longitude`, `altitude_msl` (ft), `uas_heading`; stamped on
/// receipt and stored as the active mission's aircraft telemetry (the linked mission, else
/// the session's last mission read, else the newest). With an upstream link it is
/// forwarded to the judges' server.
#[utoipa::path(post, path = "/api/telemetry", tag = "interop",
    request_body(content = InteropTelemetry, description = "JSON (2019+) or form-encoded (2017/2018)", content_type = "application/json"),
    responses(
        (status = 200, description = "Stored", body = String, content_type = "text/plain"),
        (status = 400, description = "Malformed body", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No mission to store it in", body = Problem, content_type = "application/problem+json"),
        (status = 415, description = "Neither JSON nor form-encoded", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "Invalid sample, the field named", body = Problem, content_type = "application/problem+json"),
    ))]
async fn interop_post_telemetry(
    State(state): State<AppState>,
    headers: HeaderMap,
    Body(body): Body,
) -> Result<Response, ApiError> {
    let received = now_s();
    let rows = crate::api::telemetry::telemetry_rows(
        &state,
        &headers,
        &body,
        received,
        "interop telemetry is application/json (2019+) or application/x-www-form-urlencoded (2017/2018)",
    )?;
    let s = session(&state, &headers).map(|(_, s)| s);
    let mission = active_mission(&state, s.as_ref()).await?;
    state
        .store
        .insert_telemetry(&mission.id, &rows, received)
        .await?
        .ok_or_else(|| ApiError::not_found("mission", &mission.id))?;
    state.interop.telemetry_accepted.notify_one();
    Ok(text(StatusCode::OK, "UAS Telemetry Successfully Posted."))
}

/// Obstacles (interop 2017/2018).
///
/// The active mission's obstacles in the 2017/2018 `GET /api/obstacles` form (feet): each
/// moving obstacle at its newest observation from the live state (ordered by id), then
/// the mission's stationary cylinders.
#[utoipa::path(get, path = "/api/obstacles", tag = "interop",
    responses(
        (status = 200, description = "`moving_obstacles` and `stationary_obstacles`, feet", body = Object),
        (status = 404, description = "No mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn interop_get_obstacles(
    State(state): State<AppState>,
    headers: HeaderMap,
) -> Result<axum::Json<serde_json::Value>, ApiError> {
    let s = session(&state, &headers).map(|(_, s)| s);
    let mission = active_mission(&state, s.as_ref()).await?;
    let view = state.live.predictor_view(&state, &mission).await?;
    let mut moving: Vec<(String, MovingPosition)> = view
        .predictor
        .obstacles()
        .map(|o| {
            let (lat, lon) = view.frame.to_geodetic(o.last_observation.p_m);
            (
                o.id.clone(),
                MovingPosition {
                    lat,
                    lon,
                    alt_msl_m: o.last_observation.alt_m,
                    radius_m: o.last_observation.radius_m,
                },
            )
        })
        .collect();
    // Numeric ids ("0", "1", ...: indices in the judges' list) in numeric order.
    moving.sort_by(|(a, _), (b, _)| {
        (a.parse::<u64>().ok(), a.as_str()).cmp(&(b.parse::<u64>().ok(), b.as_str()))
    });
    let moving: Vec<MovingPosition> = moving.into_iter().map(|(_, p)| p).collect();
    Ok(axum::Json(render_obstacles_2018(
        &moving,
        &mission.content.stationary_obstacles,
    )))
}

/// A team's status (interop 2019+ `TeamStatus`).
#[derive(Debug, Serialize, ToSchema)]
#[serde(rename_all = "camelCase")]
pub struct TeamStatus {
    /// The team: this client's user name.
    pub team: Team,
    /// True when the newest telemetry is less than 10 s old.
    pub in_air: bool,
    /// The newest telemetry (feet MSL), when any.
    pub telemetry: Option<TeamTelemetry>,
    /// Id of the newest telemetry: its time in Unix microseconds.
    pub telemetry_id: Option<i64>,
    /// Age of the newest telemetry, seconds.
    pub telemetry_age_sec: Option<f64>,
    /// Time of the newest telemetry (RFC 3339).
    pub telemetry_timestamp: Option<String>,
}

/// A team's identity.
#[derive(Debug, Serialize, ToSchema)]
pub struct Team {
    /// Always 1 (jink serves one team).
    pub id: i64,
    /// The logged-in user name (`local` without a session).
    pub username: String,
    /// Same as `username`.
    pub name: String,
    /// Empty.
    pub university: String,
}

/// Telemetry as the 2019+ server reported it.
#[derive(Debug, Serialize, ToSchema)]
pub struct TeamTelemetry {
    /// Latitude, degrees.
    pub latitude: f64,
    /// Longitude, degrees.
    pub longitude: f64,
    /// Altitude, feet MSL.
    pub altitude: f64,
    /// Heading, degrees.
    pub heading: f64,
}

/// Teams (interop 2019+).
///
/// One team: this client (its login name), with the active mission's newest telemetry.
#[utoipa::path(get, path = "/api/teams", tag = "interop",
    responses(
        (status = 200, description = "This client's team status", body = [TeamStatus]),
    ))]
async fn interop_get_teams(
    State(state): State<AppState>,
    headers: HeaderMap,
) -> Result<axum::Json<Vec<TeamStatus>>, ApiError> {
    let s = session(&state, &headers).map(|(_, s)| s);
    let username = s
        .as_ref()
        .map_or_else(crate::auth::writer, |s| s.username.clone());
    let newest = match active_mission(&state, s.as_ref()).await {
        Ok(m) => state.store.list_telemetry(&m.id, Some(1)).await?.pop(),
        Err(ApiError::NotFound { .. }) => None,
        Err(e) => return Err(e),
    };
    let age = newest.as_ref().map(|t| (now_s() - t.t_s).max(0.0));
    Ok(axum::Json(vec![TeamStatus {
        team: Team {
            id: 1,
            username: username.clone(),
            name: username,
            university: String::new(),
        },
        in_air: age.is_some_and(|a| a < 10.0),
        telemetry: newest.as_ref().map(|t| TeamTelemetry {
            latitude: t.lat_deg,
            longitude: t.lon_deg,
            altitude: m_to_ft(t.alt_msl_m),
            heading: t.heading_deg,
        }),
        telemetry_id: newest.as_ref().map(|t| crate::time::to_us(t.t_s)),
        telemetry_age_sec: age,
        telemetry_timestamp: newest.map(|t| format_rfc3339(t.t_s)),
    }]))
}

/// Completes the OpenAPI document for the interop paths: the 2017/2018 form bodies next
/// to the JSON ones, and the judges' mission schemas (`Interop2018Mission`,
/// `Interop2019Mission`, described by [`crate::api::doc`]) as the mission answers.
pub fn complete_doc(doc: &mut serde_json::Value) {
    use serde_json::json;
    let deg = |min: i32, max: i32, what: &str| json!({"type": "number", "minimum": min, "maximum": max, "description": what});
    let forms = [
        (
            "/api/login",
            json!({"$ref": "#/components/schemas/Credentials"}),
        ),
        (
            "/api/telemetry",
            json!({
                "type": "object",
                "title": "Interop2018Telemetry",
                "description": "2017/2018 aircraft telemetry",
                "required": ["latitude", "longitude", "altitude_msl", "uas_heading"],
                "properties": {
                    "latitude": deg(-90, 90, "Latitude, degrees"),
                    "longitude": deg(-180, 180, "Longitude, degrees"),
                    "altitude_msl": {"type": "number", "description": "Altitude, feet MSL"},
                    "uas_heading": deg(0, 360, "Heading, degrees true"),
                }
            }),
        ),
    ];
    for (path, schema) in forms {
        let content = &mut doc["paths"][path]["post"]["requestBody"]["content"];
        if content.is_object() {
            content["application/x-www-form-urlencoded"] = json!({ "schema": schema });
        }
    }
    let mission = json!({"anyOf": [
        {"$ref": "#/components/schemas/Interop2018Mission"},
        {"$ref": "#/components/schemas/Interop2019Mission"},
        {"$ref": "#/components/schemas/Mission"},
    ]});
    let one = &mut doc["paths"]["/api/missions/{id}"]["get"]["responses"]["200"]["content"]["application/json"];
    if one.is_object() {
        one["schema"] = mission.clone();
    }
    let all = &mut doc["paths"]["/api/missions"]["get"]["responses"]["200"]["content"]["application/json"];
    if all.is_object() {
        all["schema"] = json!({"type": "array", "items": mission});
    }
}

/// The interop routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(interop_login))
        .routes(routes!(interop_list_missions))
        .routes(routes!(interop_get_mission))
        .routes(routes!(interop_post_telemetry))
        .routes(routes!(interop_get_obstacles))
        .routes(routes!(interop_get_teams))
}
