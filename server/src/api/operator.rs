//! `GET /`: a landing page for people: the service's links and the stored missions.

use axum::extract::State;
use axum::response::Html;
use utoipa_axum::{router::OpenApiRouter, routes};

use crate::app::AppState;
use crate::error::ApiError;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The landing page: links to the API docs and each mission's resources.
#[utoipa::path(get, path = "/", tag = "service",
    responses((status = 200, description = "An HTML page for people", body = String, content_type = "text/html")))]
async fn index(State(state): State<AppState>) -> Result<Html<String>, ApiError> {
    let missions = state.store.list_missions().await?;
    let mut rows = String::new();
    for m in &missions {
        let id = esc(&m.id);
        rows.push_str(&format!(
            "<tr><td><a href=\"/api/v1/missions/{id}\">{id}</a></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td><a href=\"/api/v1/missions/{id}/observations\">observations</a> · \
             <a href=\"/api/v1/missions/{id}/telemetry\">telemetry</a></td></tr>",
            esc(m.content.name.as_deref().unwrap_or("")),
            m.source_format.as_str(),
            m.content.waypoints.len(),
            m.content.stationary_obstacles.len(),
        ));
    }
    if missions.is_empty() {
        rows.push_str("<tr><td colspan=6>No missions yet: POST one to /api/v1/missions.</td></tr>");
    }
    Ok(Html(format!(
        "<!doctype html><html lang=en><head><meta charset=utf-8><title>jink</title>\
<style>body{{font-family:system-ui,sans-serif;margin:2rem;max-width:60rem}}table{{border-collapse:collapse}}\
td,th{{border-bottom:1px solid #ccc;padding:.3rem .8rem;text-align:left}}</style></head><body>\
<h1>jink</h1><p>Ground-station planning for fixed-wing UAVs. \
<a href=\"/docs/\">API docs</a> · <a href=\"/openapi.json\">OpenAPI</a> · <a href=\"/healthz\">health</a> · \
<a href=\"/metrics\">metrics</a></p><h2>Missions</h2><table><tr><th>id</th><th>name</th><th>format</th>\
<th>waypoints</th><th>cylinders</th><th>data</th></tr>{rows}</table></body></html>"
    )))
}

/// The landing page route.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new().routes(routes!(index))
}
