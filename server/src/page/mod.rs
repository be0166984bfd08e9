//! The operator's live mission page (`GET /missions/{id}`): one HTML document with its
//! style and script inline (every asset in the binary; no CDN, no map tiles), fed by
//! server-sent events (`GET /missions/{id}/events`) from the mission's live state
//! ([`feed`]) and by the risk layer (`GET /missions/{id}/risk-layer.png`), the live risk
//! map's slice at the look-ahead the page's slider chooses, drawn with the same colours as
//! the risk PNG ([`crate::render::heat`]). `GET /missions/{id}/replay` gives the page's
//! replay timeline ([`replay`]).
//!
//! The events: `mission` (the fixed geometry) first on every connection, then `state`
//! whenever the snapshot, the telemetry, the plans or the warnings change (checked every
//! [`TICK`]), and `gone` when the mission is deleted. Each event carries `retry: 1000`, so a
//! page whose server restarts reconnects within about a second of it coming back. The
//! streams end when the service shuts down ([`shut_down`]).

pub mod feed;
pub mod replay;

use std::convert::Infallible;
use std::time::Duration;

use axum::extract::{Path, State};
use axum::http::{HeaderValue, header};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use utoipa_axum::{router::OpenApiRouter, routes};

use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::ApiQuery;
use wire::ids::MissionId;

/// How often a connection looks for new data.
pub const TICK: Duration = Duration::from_millis(250);

/// Set when the service shuts down: event streams end, so that the graceful shutdown does
/// not wait forever for the pages still open. (One service per process.)
static SHUTDOWN: std::sync::LazyLock<tokio::sync::watch::Sender<bool>> =
    std::sync::LazyLock::new(|| tokio::sync::watch::channel(false).0);

/// Ends every page's event stream (the service is shutting down).
pub fn shut_down() {
    SHUTDOWN.send_replace(true);
}

/// Sleeps one [`TICK`]; false when the service shuts down meanwhile.
async fn tick(shutdown: &mut tokio::sync::watch::Receiver<bool>) -> bool {
    let slept = tokio::select! {
        () = tokio::time::sleep(TICK) => true,
        _ = shutdown.wait_for(|down| *down) => false,
    };
    slept && !*shutdown.borrow()
}

/// The page: HTML, style and script in one document.
const PAGE_HTML: &str = include_str!("page.html");

/// The colour scale of the legend as a CSS gradient, bottom (0) to top (1), from the same
/// [`crate::render::heat`] that colours the risk layer and the PNG.
fn legend_gradient() -> String {
    let stops: Vec<String> = (0..=20)
        .map(|k| {
            let p = f32::from(k as u8) / 20.0;
            let [r, g, b] = crate::render::heat(p.max(0.006));
            format!("rgb({r},{g},{b}) {}%", k * 5)
        })
        .collect();
    format!("linear-gradient(to top, {})", stops.join(", "))
}

/// The live page of a mission: its fly zone, waypoints and current plan, cylinders, moving
/// obstacles with their tracks and stages, the risk layer at a chosen look-ahead, the
/// aircraft, warnings and the plan history; it updates itself from `.../events`.
#[utoipa::path(get, path = "/missions/{id}", tag = "service",
    params(("id" = String, Path, description = "Mission id")),
    responses(
        (status = 200, description = "An HTML page for people", body = String, content_type = "text/html"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn mission_page(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
) -> Result<Html<String>, ApiError> {
    let mission = crate::api::missions::load(&state, &id).await?;
    let name = esc(&feed::display_name(&mission));
    Ok(Html(
        PAGE_HTML
            .replace("{{TITLE}}", &name)
            .replace("{{LEGEND_GRADIENT}}", &legend_gradient())
            // The look-ahead slider spans the live map's horizon.
            .replace(
                "{{HORIZON_S}}",
                &format!("{}", crate::live::snapshot::LIVE_HORIZON_S),
            )
            // One step a slice.
            .replace(
                "{{SLICE_DT_S}}",
                &format!("{}", crate::live::snapshot::SLICE_DT_S),
            ),
    ))
}

/// HTML-escapes text.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// One server-sent event as a client's parser sees it (documentation of the stream's
/// items: `event` names it, `data` is a JSON document, `retry` the reconnect delay in ms).
#[derive(utoipa::ToSchema)]
#[allow(dead_code)]
struct SseEvent {
    /// `mission`, `state` or `gone`.
    event: Option<String>,
    /// The event's JSON document, as text.
    data: String,
    /// Reconnect delay, milliseconds (on the first event).
    retry: Option<u64>,
    /// Event id, when set.
    id: Option<String>,
}

/// Server-sent events of a mission's live state, for the page.
///
/// `event: mission` (fixed geometry, ENU metres) on connecting, then `event: state`
/// (obstacles with tracks and stages, aircraft with its track, the current plan and its
/// last diff, plan history, warnings) within a quarter second of any change, and
/// `event: gone` if the mission is deleted.
#[utoipa::path(get, path = "/missions/{id}/events", tag = "service",
    params(("id" = String, Path, description = "Mission id")),
    responses(
        (status = 200, description = "A stream of server-sent events", body = SseEvent, content_type = "text/event-stream"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn mission_events(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
) -> Result<Response, ApiError> {
    let mission = crate::api::missions::load(&state, &id).await?;
    let first = Event::default()
        .event("mission")
        .retry(Duration::from_secs(1))
        .json_data(feed::mission_json(&mission))
        .map_err(|e| ApiError::Internal(e.to_string()))?;
    let feed = feed::Feed::new(mission);
    // The stream's state: the feed, and whether to wait a tick first (`Some(true)`), not
    // (`Some(false)`, the first update) or end (`None`, after `gone`).
    let updates = futures_util::stream::unfold(
        (feed, state, Some(false), SHUTDOWN.subscribe()),
        |(mut feed, state, wait, mut shutdown)| async move {
            let down = *shutdown.borrow();
            if down || (wait? && !tick(&mut shutdown).await) {
                return None;
            }
            loop {
                match feed.state_if_changed(&state).await {
                    Ok(Some(v)) => {
                        let ev = Event::default()
                            .event("state")
                            .retry(Duration::from_secs(1))
                            .json_data(v)
                            .unwrap_or_else(|_| Event::default().comment("unserializable"));
                        return Some((
                            Ok::<_, Infallible>(ev),
                            (feed, state, Some(true), shutdown),
                        ));
                    }
                    Ok(None) => {}
                    Err(ApiError::NotFound { .. }) => {
                        let ev = Event::default()
                            .event("gone")
                            .data("the mission was deleted");
                        return Some((Ok(ev), (feed, state, None, shutdown)));
                    }
                    Err(e) => {
                        tracing::warn!(mission = %feed.mission().id, error = %e, "page feed");
                    }
                }
                if !tick(&mut shutdown).await {
                    return None;
                }
            }
        },
    );
    let stream = futures_util::StreamExt::chain(
        futures_util::stream::once(async move { Ok::<_, Infallible>(first) }),
        updates,
    );
    let mut resp = Sse::new(stream)
        .keep_alive(KeepAlive::default())
        .into_response();
    resp.headers_mut()
        .insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    Ok(resp)
}

/// The risk layer of the page: the live risk map's slice `t` seconds ahead as a PNG of one
/// pixel per cell, north up, transparent where the probability is at most 0.005, in the
/// risk PNG's colours. Where it lies: `X-Jink-Risk-Grid: EAST NORTH CELL WIDTH HEIGHT`
/// (the south-west corner in the mission's ENU frame, metres; the cell size, metres; the
/// size in cells) and `X-Jink-Risk-T: T_AHEAD T` (seconds ahead of the anchor; Unix
/// seconds).
#[utoipa::path(get, path = "/missions/{id}/risk-layer.png", tag = "service",
    params(("id" = String, Path, description = "Mission id"), crate::api::risk::RiskPngParams),
    responses(
        (status = 200, description = "The slice as a transparent PNG, one pixel per cell", body = Vec<u8>, content_type = "image/png",
            headers(("X-Jink-Risk-Grid" = String, description = "EAST NORTH CELL WIDTH HEIGHT of the grid (metres, cells)"),
                    ("X-Jink-Risk-T" = String, description = "T_AHEAD T: seconds ahead of the anchor, Unix seconds"))),
        (status = 400, description = "Malformed query", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "t out of range", body = Problem, content_type = "application/problem+json"),
    ))]
async fn risk_layer(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiQuery(q): ApiQuery<crate::api::risk::RiskPngParams>,
) -> Result<Response, ApiError> {
    let (png, grid, t) = crate::api::risk::with_slice(&state, &id, q.t, |s| {
        let v = &s.slice;
        let png = crate::render::risk_layer_png(v)
            .map_err(|e| ApiError::Internal(format!("png: {e}")))?;
        let grid = format!(
            "{} {} {} {} {}",
            v.origin_m[0], v.origin_m[1], v.cell_m, v.width, v.height
        );
        Ok((png, grid, format!("{} {}", v.t_s - s.t0, v.t_s)))
    })
    .await?;
    let mut resp = png.into_response();
    let h = resp.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static("image/png"));
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    for (name, value) in [("x-jink-risk-grid", grid), ("x-jink-risk-t", t)] {
        h.insert(
            name,
            HeaderValue::from_str(&value).map_err(|e| ApiError::Internal(e.to_string()))?,
        );
    }
    Ok(resp)
}

/// The mission's recorded timeline for the page's replay: aircraft telemetry
/// `[t, [east, north], alt_msl_m, heading_deg]`, obstacle positions (every 0.5 s at most),
/// every plan (as the live state shows it, with its start time `start_t`), and the
/// judges' scoring of the flight by the simulator's scoring: the whole flight's scores,
/// hits, captured waypoints and smallest clearance, and per second the smallest clearance
/// and the obstacles hit. Positions are ENU metres in the mission's frame.
#[utoipa::path(get, path = "/missions/{id}/replay", tag = "service",
    params(("id" = String, Path, description = "Mission id")),
    responses(
        (status = 200, description = "The recorded timeline and its scoring", body = Object, content_type = "application/json"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
    ))]
async fn mission_replay(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
) -> Result<axum::Json<serde_json::Value>, ApiError> {
    let mission = crate::api::missions::load(&state, &id).await?;
    Ok(axum::Json(replay::replay_json(&state, &mission).await?))
}

/// The page's routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(mission_page))
        .routes(routes!(mission_events))
        .routes(routes!(risk_layer))
        .routes(routes!(mission_replay))
}
