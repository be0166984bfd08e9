//! The interop gateway (issue 15): jink as the judges' interoperability server for a
//! team's existing tools, and as a client of the real one.
//!
//! - [`api`]: the interop-compatible surface (`/api/login`, `/api/missions`,
//!   `/api/missions/{id}`, `/api/telemetry`, `/api/obstacles`, `/api/teams`) in the
//!   judges' formats (feet), with sessions ([`Sessions`]) mapped onto jink's tokens.
//! - [`link`]: the upstream link of `jink serve --interop-url ...`: logs in to the judges'
//!   server, mirrors the mission, polls the moving obstacles (2017/2018 API) and forwards
//!   accepted aircraft telemetry through a persistent queue ([`store`]).
//! - [`store`]: the gateway's tables.
//!
//! # Which mission
//! The interop API has no mission in its telemetry and obstacle paths. jink answers them
//! for the *active* mission: the linked mission when an upstream link runs, else the
//! mission the session last read with `GET /api/missions/{id}`, else the newest mission.
//!
//! # Mission ids
//! Interop mission ids are integers: a mission's `interop_id` (what the judges' server
//! called it), else a number above [`store::NUMBER_BASE`] given on first use.
//! `GET /api/missions/{id}` also accepts a jink mission id.

use std::collections::HashMap;
use std::sync::Mutex;

use serde::Serialize;
use utoipa::ToSchema;

use crate::app::AppState;
use crate::error::ApiError;
use crate::mission::{Mission, SourceFormat};
use wire::ids::MissionId;

pub mod api;
pub mod link;
pub mod store;

/// The session cookie's name (what the judges' Django server called it).
pub const SESSION_COOKIE: &str = "sessionid";

/// Most sessions kept; beyond it the oldest half is forgotten (their clients log in again).
const SESSIONS_MAX: usize = 10_000;

/// Which generation of the judges' formats the surface renders missions in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum FormatFlag {
    /// The mission's own source format (2017/2018 missions as 2018, others as 2019+).
    #[default]
    Auto,
    /// 2017/2018 JSON.
    #[value(name = "2018")]
    V2018,
    /// 2019+ protobuf-JSON.
    #[value(name = "2019")]
    V2019,
}

impl FormatFlag {
    /// The format `mission` is rendered in.
    pub fn for_mission(self, mission: &Mission) -> SourceFormat {
        match self {
            Self::V2018 => SourceFormat::Interop2018,
            Self::V2019 => SourceFormat::Interop2019,
            Self::Auto if mission.source_format == SourceFormat::Interop2018 => {
                SourceFormat::Interop2018
            }
            Self::Auto => SourceFormat::Interop2019,
        }
    }
}

/// One logged-in interop client.
#[derive(Debug, Clone)]
pub struct Session {
    /// The token it logged in with (`None`: the trusted `local` user of an open bind).
    pub token: Option<String>,
    /// Its user name.
    pub username: String,
    /// The mission it last read.
    pub mission: Option<MissionId>,
    /// Creation order, for eviction.
    serial: u64,
}

/// Interop sessions by cookie value (in memory: a restart logs clients out).
#[derive(Debug, Default)]
pub struct Sessions {
    inner: Mutex<(HashMap<String, Session>, u64)>,
}

impl Sessions {
    fn lock(&self) -> std::sync::MutexGuard<'_, (HashMap<String, Session>, u64)> {
        self.inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Opens a session; returns its cookie value (256 random bits, hex).
    pub fn open(&self, username: String, token: Option<String>) -> String {
        let id = crate::auth::new_token()
            .trim_start_matches("jink_")
            .to_string();
        let mut g = self.lock();
        if g.0.len() >= SESSIONS_MAX {
            let mut serials: Vec<u64> = g.0.values().map(|s| s.serial).collect();
            serials.sort_unstable();
            let cut = serials[serials.len() / 2];
            g.0.retain(|_, s| s.serial >= cut);
        }
        g.1 += 1;
        let serial = g.1;
        g.0.insert(
            id.clone(),
            Session {
                token,
                username,
                mission: None,
                serial,
            },
        );
        id
    }

    /// The session of a cookie value.
    pub fn get(&self, id: &str) -> Option<Session> {
        self.lock().0.get(id).cloned()
    }

    /// Remembers the mission a session read.
    pub fn set_mission(&self, id: &str, mission: &MissionId) {
        if let Some(s) = self.lock().0.get_mut(id) {
            s.mission = Some(mission.clone());
        }
    }
}

/// The session cookie's value in `headers`, if any.
pub fn session_cookie(headers: &axum::http::HeaderMap) -> Option<String> {
    headers
        .get_all(axum::http::header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .find_map(|kv| {
            let (k, v) = kv.trim().split_once('=')?;
            (k == SESSION_COOKIE).then(|| v.to_string())
        })
}

/// What the upstream link sees (in `/healthz`, `/metrics`, on the operator page and from
/// `jink interop status`).
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize, ToSchema)]
pub struct LinkStatus {
    /// The judges' server.
    pub url: String,
    /// The upstream mission id.
    pub upstream_mission: i64,
    /// True while the last exchange with the upstream server succeeded.
    pub connected: bool,
    /// `2018` or `2019`, once known (from the login or the mission).
    pub api: Option<String>,
    /// The jink mission mirroring the upstream one.
    pub mission_id: Option<String>,
    /// How often the upstream mission changed while linked (each change is a new jink
    /// mission).
    pub mission_changes: u64,
    /// Time of the last successful exchange (RFC 3339).
    pub last_success: Option<String>,
    /// The last failure, as a sentence.
    pub last_error: Option<String>,
    /// Time of the last failure (RFC 3339).
    pub last_error_at: Option<String>,
    /// The most recent failures, oldest first (at most 16), each with its time.
    pub recent_errors: Vec<String>,
    /// Telemetry samples accepted but not yet acknowledged upstream.
    pub queue_depth: u64,
    /// Samples acknowledged upstream since start.
    pub forwarded: u64,
    /// Samples the upstream refused for good (400/422) since start; not sent again.
    pub rejected: u64,
    /// Obstacle snapshots stored since start (2017/2018 API).
    pub obstacle_polls: u64,
    /// Failed exchanges since start (each is retried after a back-off).
    pub errors: u64,
}

/// The gateway's shared state.
#[derive(Debug, Default)]
pub struct InteropState {
    /// Logged-in clients.
    pub sessions: Sessions,
    /// The mission format of the surface (`--interop-format`).
    format: Mutex<FormatFlag>,
    /// The upstream link's status, when a link runs.
    link: Mutex<Option<LinkStatus>>,
    /// Wakes the forwarder when telemetry was accepted.
    pub telemetry_accepted: tokio::sync::Notify,
}

impl InteropState {
    /// Sets the mission format of the surface.
    pub fn set_format(&self, f: FormatFlag) {
        *self.format.lock().unwrap_or_else(|e| e.into_inner()) = f;
    }

    /// The mission format of the surface.
    pub fn format(&self) -> FormatFlag {
        *self.format.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The link's status, when a link runs.
    pub fn link(&self) -> Option<LinkStatus> {
        self.link.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Changes the link's status.
    pub fn update_link(&self, f: impl FnOnce(&mut LinkStatus)) {
        let mut g = self.link.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = g.as_mut() {
            f(s);
        }
    }

    /// Starts reporting a link.
    pub fn start_link(&self, status: LinkStatus) {
        *self.link.lock().unwrap_or_else(|e| e.into_inner()) = Some(status);
    }

    /// The link's metrics in the Prometheus text format (empty without a link).
    pub fn render_metrics(&self) -> String {
        use std::fmt::Write;
        let Some(s) = self.link() else {
            return String::new();
        };
        let mut out = String::new();
        let mut metric = |name: &str, kind: &str, help: &str, v: f64| {
            let _ = writeln!(out, "# HELP {name} {help}");
            let _ = writeln!(out, "# TYPE {name} {kind}");
            let _ = writeln!(out, "{name} {v}");
        };
        metric(
            "jink_interop_connected",
            "gauge",
            "1 while the last exchange with the judges' server succeeded.",
            f64::from(u8::from(s.connected)),
        );
        metric(
            "jink_interop_queue_depth",
            "gauge",
            "Aircraft telemetry samples not yet acknowledged by the judges' server.",
            s.queue_depth as f64,
        );
        metric(
            "jink_interop_forwarded_total",
            "counter",
            "Telemetry samples acknowledged by the judges' server.",
            s.forwarded as f64,
        );
        metric(
            "jink_interop_rejected_total",
            "counter",
            "Telemetry samples the judges' server refused for good (400/422).",
            s.rejected as f64,
        );
        metric(
            "jink_interop_obstacle_polls_total",
            "counter",
            "Obstacle snapshots pulled from the judges' server and stored.",
            s.obstacle_polls as f64,
        );
        metric(
            "jink_interop_errors_total",
            "counter",
            "Failed exchanges with the judges' server (each retried after a back-off).",
            s.errors as f64,
        );
        metric(
            "jink_interop_mission_changes_total",
            "counter",
            "Changes of the upstream mission noticed while linked.",
            s.mission_changes as f64,
        );
        out
    }
}

/// The active mission of a request (see the module docs): the linked mission, else the
/// session's last mission, else the newest mission.
///
/// # Errors
/// 404 when there is no mission at all; database failures.
pub async fn active_mission(
    state: &AppState,
    session: Option<&Session>,
) -> Result<Mission, ApiError> {
    let linked = state
        .interop
        .link()
        .and_then(|l| l.mission_id)
        .map(MissionId::from);
    for id in [linked, session.and_then(|s| s.mission.clone())]
        .into_iter()
        .flatten()
    {
        if let Some(m) = state.store.get_mission(&id).await? {
            return Ok(m);
        }
    }
    state
        .store
        .list_missions()
        .await?
        .into_iter()
        .last()
        .ok_or_else(|| ApiError::NotFound {
            what: "active mission",
            id: "(none: upload a mission first, or link to the judges' server with --interop-url)"
                .into(),
        })
}

/// The interop id of `mission`.
///
/// # Errors
/// Database failures.
pub async fn number_of(state: &AppState, mission: &Mission) -> Result<i64, ApiError> {
    match mission.content.interop_id {
        Some(n) => Ok(n),
        None => Ok(state.store.interop_number(&mission.id).await?),
    }
}

/// The mission an interop path names: an interop id (the newest mission carrying it, then
/// a number jink gave), else a jink mission id.
///
/// # Errors
/// 404 when none matches; database failures.
pub async fn mission_named(state: &AppState, name: &str) -> Result<Mission, ApiError> {
    if let Ok(n) = name.parse::<i64>() {
        let linked = match state.interop.link() {
            Some(l) if l.upstream_mission == n => l.mission_id.map(MissionId::from),
            _ => None,
        };
        if let Some(id) = linked
            && let Some(m) = state.store.get_mission(&id).await?
        {
            return Ok(m);
        }
        let all = state.store.list_missions().await?;
        if let Some(m) = all
            .into_iter()
            .rev()
            .find(|m| m.content.interop_id == Some(n))
        {
            return Ok(m);
        }
        if let Some(id) = state.store.mission_of_number(n).await?
            && let Some(m) = state.store.get_mission(&id).await?
        {
            return Ok(m);
        }
    }
    state
        .store
        .get_mission(&MissionId::from(name.to_string()))
        .await?
        .ok_or_else(|| ApiError::not_found("mission", name))
}
