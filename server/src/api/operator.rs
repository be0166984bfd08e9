//! `GET /`: a landing page for people: the service's links and the stored missions, each
//! with its name, counts, last activity and links to its live page ([`crate::page`]).

use axum::extract::State;
use axum::response::Html;
use utoipa_axum::{router::OpenApiRouter, routes};

use crate::app::AppState;
use crate::error::ApiError;
use crate::page::esc;

/// The landing page: links to the API docs and, per mission, its name, counts, last
/// activity and links to its live page, data, latest plan and downloads.
#[utoipa::path(get, path = "/", tag = "service",
    responses((status = 200, description = "An HTML page for people", body = String, content_type = "text/html")))]
async fn index(State(state): State<AppState>) -> Result<Html<String>, ApiError> {
    let missions = state.store.list_missions().await?;
    let now = crate::time::now_s();
    let mut rows = String::new();
    for m in &missions {
        let id = esc(&m.id);
        let telemetry_t = state
            .store
            .list_telemetry(&m.id, Some(1))
            .await?
            .last()
            .map(|r| r.t_s);
        let revision = state.store.latest_plan_revision(&m.id).await?;
        let latest = match revision {
            0 => None,
            r => state.store.get_plan_by_revision(&m.id, r).await?,
        };
        // Obstacles seen: from the live state when the mission is live (no store read).
        let obstacles = state.live.cached(&m.id).map(|l| {
            let snap = l.published();
            (snap.predictor.obstacles().count(), snap.anchor_t_s)
        });
        let last = [
            telemetry_t,
            latest.as_ref().map(|p| p.created_at_s),
            obstacles.and_then(|o| o.1),
        ]
        .into_iter()
        .flatten()
        .reduce(f64::max);
        let plan_links = latest.as_ref().map_or_else(
            || "no plan yet".to_string(),
            |p| {
                let pid = esc(&p.id.to_string());
                format!(
                    "<a href=\"/api/v1/missions/{id}/plans/{pid}\">plan {r}</a> \
                     (<a href=\"/api/v1/missions/{id}/plans/{pid}/qgc-wpl\">WPL</a>, \
                     <a href=\"/api/v1/missions/{id}/plans/{pid}/qgc-plan\">.plan</a>)",
                    r = p.revision
                )
            },
        );
        rows.push_str(&format!(
            "<tr><td><a href=\"/missions/{id}\">{name}</a></td><td><code>{id}</code></td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td><td>{revision}</td><td>{}</td>\
             <td><a href=\"/missions/{id}\">live page</a> · <a href=\"/api/v1/missions/{id}\">mission</a> · \
             {plan_links} · <a href=\"/api/v1/missions/{id}/obstacles\">obstacles</a> · \
             <a href=\"/api/v1/missions/{id}/telemetry?last=100\">telemetry</a> · \
             <a href=\"/api/v1/missions/{id}/risk/png\">risk PNG</a></td></tr>",
            m.source_format.as_str(),
            m.content.waypoints.len(),
            m.content.stationary_obstacles.len(),
            obstacles.map_or("–".to_string(), |o| o.0.to_string()),
            last.map_or("none".to_string(), |t| ago(now - t)),
            name = esc(&crate::page::feed::display_name(m)),
        ));
    }
    if missions.is_empty() {
        rows.push_str("<tr><td colspan=9>No missions yet: POST one to /api/v1/missions, or run <code>jink demo</code>.</td></tr>");
    }
    Ok(Html(format!(
        "<!doctype html><html lang=en><head><meta charset=utf-8><title>jink</title>\
<style>body{{font-family:system-ui,sans-serif;margin:2rem;max-width:80rem}}table{{border-collapse:collapse}}\
td,th{{border-bottom:1px solid #ccc;padding:.3rem .8rem;text-align:left}}a:focus-visible{{outline:3px solid #1a73e8}}</style></head><body>\
<h1>jink</h1><p>Ground-station planning for fixed-wing UAVs. \
<a href=\"/docs/\">API docs</a> · <a href=\"/openapi.json\">OpenAPI</a> · <a href=\"/healthz\">health</a> · \
<a href=\"/metrics\">metrics</a></p><h2>Missions</h2><table><caption>Each mission's live page shows the flight, the \
predictions and the plan as they happen.</caption><tr><th>name</th><th>id</th><th>format</th>\
<th>waypoints</th><th>cylinders</th><th>moving obstacles</th><th>plans</th><th>last activity</th><th>links</th></tr>{rows}</table></body></html>"
    )))
}

/// "12 s ago", "3 min ago", ... for an age in seconds (mission clock against the server's).
fn ago(age_s: f64) -> String {
    match age_s {
        a if a < -5.0 => "in the future (clocks differ)".into(),
        a if a < 2.0 => "just now".into(),
        a if a < 90.0 => format!("{a:.0} s ago"),
        a if a < 5400.0 => format!("{:.0} min ago", a / 60.0),
        a if a < 172_800.0 => format!("{:.0} h ago", a / 3600.0),
        a => format!("{:.0} days ago", a / 86400.0),
    }
}

/// The landing page route.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new().routes(routes!(index))
}
