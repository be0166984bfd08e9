//! The upstream link (`jink serve --interop-url URL --interop-username U
//! --interop-password P --interop-mission ID`): jink as a client of the judges' server.
//!
//! Three loops share one logged-in [`Upstream`] client:
//! - **mission**: pulls `GET /api/missions/{id}` at start and every `mission_poll`; a
//!   mission that differs from the one stored is stored as a new jink mission (a change is
//!   counted), an unchanged one is reused, so a restart continues with the same mission;
//! - **obstacles** (2017/2018 API only; the 2019+ API has no moving obstacles): polls
//!   `GET /api/obstacles` at `obstacle_hz` into the mission's observations and live state;
//! - **forwarder**: sends every accepted aircraft telemetry sample of linked missions
//!   upstream, in the order it was accepted, at most `telemetry_hz` per second. The queue
//!   is the telemetry table itself minus the `interop_forwarded` acknowledgements, so an
//!   outage or a jink restart loses nothing; a sample leaves the queue only when the
//!   upstream acknowledged it (2xx) or refused it for good (400/422, counted as rejected).
//!
//! Errors never stop a loop: each failure is reported in [`LinkStatus`] and retried after a
//! back-off doubling from 250 ms to 10 s (or the server's `Retry-After`, if longer). A 401
//! or 403 logs in again once. Everything the link stores is written by `interop`.
//!
//! Exactly once holds as long as the upstream answers: a sample whose request failed is
//! sent again, and a sample whose answer was lost after the upstream stored it (a timeout
//! or a jink crash in between) is sent again too; the interop API has no way to tell.
//!
//! [`LinkStatus`]: super::LinkStatus

use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::http::header;
use serde_json::Value;

use crate::app::AppState;
use crate::mission::{Mission, SourceFormat};
use crate::store::Store;
use crate::time::{format_rfc3339, now_s};
use wire::ids::MissionId;

use super::store::{Outcome, Pending};

/// Which generation of the judges' API the upstream speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum ApiFlag {
    /// Learned from the mission's format (logins try JSON, then a form).
    #[default]
    Auto,
    /// 2017/2018: form logins and telemetry, `/api/obstacles`.
    #[value(name = "2018")]
    V2018,
    /// 2019+: JSON logins and telemetry, no moving obstacles.
    #[value(name = "2019")]
    V2019,
}

/// The link's settings.
#[derive(Debug, Clone)]
pub struct LinkConfig {
    /// Base URL of the judges' server (no trailing slash).
    pub url: String,
    /// Interop user name.
    pub username: String,
    /// Interop password.
    pub password: String,
    /// Upstream mission id.
    pub mission: i64,
    /// Obstacle polls per second (0: none).
    pub obstacle_hz: f64,
    /// Most telemetry samples sent per second.
    pub telemetry_hz: f64,
    /// Seconds between mission pulls.
    pub mission_poll: Duration,
    /// Longest wait for one upstream answer.
    pub timeout: Duration,
    /// The upstream API generation.
    pub api: ApiFlag,
}

/// A failed exchange with the upstream server.
#[derive(Debug, Clone, thiserror::Error)]
pub enum LinkError {
    /// No answer (refused, reset, timed out); retried.
    #[error("cannot reach {url}: {detail}")]
    Transport { url: String, detail: String },
    /// An error status; 400/422 refusals of a sample are final, the rest retried.
    #[error("{url} answered {status}: {body}")]
    Status {
        url: String,
        status: u16,
        body: String,
        retry_after: Option<Duration>,
    },
    /// An answer that is not what the interop API sends; retried.
    #[error("{url} sent something that is not an interop answer: {detail}")]
    Malformed { url: String, detail: String },
    /// jink's own database failed; retried.
    #[error("database: {0}")]
    Store(String),
}

impl LinkError {
    /// True when the upstream refused a request for good (it must not be sent again).
    pub fn is_final(&self) -> bool {
        matches!(
            self,
            Self::Status {
                status: 400 | 422,
                ..
            }
        )
    }

    /// True when the server was not reachable or not well (the link is not connected).
    fn disconnects(&self) -> bool {
        match self {
            Self::Transport { .. } => true,
            Self::Status { status, .. } => *status >= 500 || *status == 429,
            Self::Malformed { .. } | Self::Store(_) => false,
        }
    }

    fn retry_after(&self) -> Option<Duration> {
        match self {
            Self::Status { retry_after, .. } => *retry_after,
            _ => None,
        }
    }
}

impl From<sqlx::Error> for LinkError {
    fn from(e: sqlx::Error) -> Self {
        Self::Store(e.to_string())
    }
}

/// Answers longer than this are refused (a mission is a few kilobytes).
const MAX_ANSWER_BYTES: usize = 8 * 1024 * 1024;

/// A logged-in client of the judges' server.
#[derive(Debug)]
pub struct Upstream {
    http: reqwest::Client,
    /// The settings.
    pub cfg: LinkConfig,
    cookie: Mutex<Option<String>>,
    api: Mutex<Option<SourceFormat>>,
}

impl Upstream {
    /// A client for `cfg` (nothing is sent yet).
    ///
    /// # Errors
    /// When the HTTP client cannot be built.
    pub fn new(mut cfg: LinkConfig) -> Result<Self, String> {
        cfg.url = cfg.url.trim_end_matches('/').to_string();
        let http = reqwest::Client::builder()
            .timeout(cfg.timeout)
            .connect_timeout(cfg.timeout.min(Duration::from_secs(3)))
            .build()
            .map_err(|e| e.to_string())?;
        let api = match cfg.api {
            ApiFlag::Auto => None,
            ApiFlag::V2018 => Some(SourceFormat::Interop2018),
            ApiFlag::V2019 => Some(SourceFormat::Interop2019),
        };
        Ok(Self {
            http,
            cfg,
            cookie: Mutex::new(None),
            api: Mutex::new(api),
        })
    }

    /// The upstream API generation, once known (`2018` or `2019`).
    pub fn api(&self) -> Option<SourceFormat> {
        *self.api.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn set_api(&self, f: SourceFormat) {
        if self.cfg.api == ApiFlag::Auto {
            *self.api.lock().unwrap_or_else(|e| e.into_inner()) = Some(f);
        }
    }

    fn cookie(&self) -> Option<String> {
        self.cookie
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    fn url(&self, path: &str) -> String {
        format!("{}{path}", self.cfg.url)
    }

    /// Sends one request, reads the answer; an error status is an error.
    async fn exchange(
        &self,
        req: reqwest::RequestBuilder,
        url: &str,
    ) -> Result<(u16, Vec<u8>, Vec<String>), LinkError> {
        let transport = |e: reqwest::Error| LinkError::Transport {
            url: url.to_string(),
            detail: if e.is_timeout() {
                format!("no answer within {:?}", self.cfg.timeout)
            } else {
                e.to_string()
            },
        };
        let resp = req.send().await.map_err(transport)?;
        let status = resp.status().as_u16();
        let cookies: Vec<String> = resp
            .headers()
            .get_all(header::SET_COOKIE)
            .iter()
            .filter_map(|v| v.to_str().ok())
            .filter_map(|v| v.split(';').next())
            .map(|kv| kv.trim().to_string())
            .collect();
        let retry_after = resp
            .headers()
            .get(header::RETRY_AFTER)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.trim().parse::<f64>().ok())
            .and_then(|s| Duration::try_from_secs_f64(s.clamp(0.0, 300.0)).ok());
        if resp
            .content_length()
            .is_some_and(|n| n > MAX_ANSWER_BYTES as u64)
        {
            return Err(LinkError::Malformed {
                url: url.to_string(),
                detail: "the answer is larger than 8 MiB".into(),
            });
        }
        let body = resp.bytes().await.map_err(transport)?.to_vec();
        if !(200..300).contains(&status) {
            let mut text = String::from_utf8_lossy(&body).into_owned();
            text.truncate(300);
            return Err(LinkError::Status {
                url: url.to_string(),
                status,
                body: text,
                retry_after,
            });
        }
        Ok((status, body, cookies))
    }

    /// Logs in: JSON (2019+) first unless the API is known to be 2017/2018, then a form.
    ///
    /// # Errors
    /// The last failure.
    pub async fn login(&self) -> Result<(), LinkError> {
        let url = self.url("/api/login");
        let creds = [
            ("username", self.cfg.username.as_str()),
            ("password", self.cfg.password.as_str()),
        ];
        let json =
            serde_json::json!({ "username": self.cfg.username, "password": self.cfg.password });
        let attempt_json = self.api() != Some(SourceFormat::Interop2018);
        let mut result = if attempt_json {
            self.exchange(self.http.post(&url).json(&json), &url).await
        } else {
            self.exchange(self.http.post(&url).form(&creds), &url).await
        };
        // A 2017/2018 server answers a JSON login with 400 (it reads form fields only).
        if attempt_json
            && self.api().is_none()
            && matches!(
                result,
                Err(LinkError::Status {
                    status: 400 | 415,
                    ..
                })
            )
        {
            result = self.exchange(self.http.post(&url).form(&creds), &url).await;
        }
        let (_, _, cookies) = result?;
        *self.cookie.lock().unwrap_or_else(|e| e.into_inner()) = Some(cookies.join("; "));
        Ok(())
    }

    /// A request built by `build` with the session cookie; logs in first when there is no
    /// session, and once more after a 401/403.
    async fn send(
        &self,
        path: &str,
        build: impl Fn(&reqwest::Client, &str) -> reqwest::RequestBuilder,
    ) -> Result<Vec<u8>, LinkError> {
        if self.cookie().is_none() {
            self.login().await?;
        }
        let url = self.url(path);
        for attempt in 0..2 {
            let mut req = build(&self.http, &url);
            if let Some(c) = self.cookie().filter(|c| !c.is_empty()) {
                req = req.header(header::COOKIE, c);
            }
            match self.exchange(req, &url).await {
                Err(LinkError::Status {
                    status: 401 | 403, ..
                }) if attempt == 0 => self.login().await?,
                other => return other.map(|(_, body, _)| body),
            }
        }
        unreachable!("the loop returns on its second attempt")
    }

    /// Fetches the upstream mission, parsed and validated (its interop id set to the
    /// upstream id); learns the API generation from its format.
    ///
    /// # Errors
    /// Transport, status, or a document that is not a valid interop mission.
    pub async fn fetch_mission(
        &self,
    ) -> Result<
        (
            SourceFormat,
            crate::mission::MissionInput,
            crate::mission::Home,
        ),
        LinkError,
    > {
        let path = format!("/api/missions/{}", self.cfg.mission);
        let body = self.send(&path, |c, u| c.get(u)).await?;
        let malformed = |detail: String| LinkError::Malformed {
            url: self.url(&path),
            detail,
        };
        let value: Value =
            serde_json::from_slice(&body).map_err(|e| malformed(format!("not JSON: {e}")))?;
        if !value.is_object() {
            return Err(malformed("a mission is a JSON object".into()));
        }
        let read = wire::domain::read_missions(value, None).map_err(|e| {
            malformed(match e {
                wire::WireError::Validation(errs) => errs
                    .iter()
                    .map(|e| format!("{}: {}", e.pointer, e.detail))
                    .collect::<Vec<_>>()
                    .join("; "),
                other => other.to_string(),
            })
        })?;
        if read.format == SourceFormat::Native {
            return Err(malformed(
                "not an interop mission (no interop fields)".into(),
            ));
        }
        self.set_api(read.format);
        let (mut content, home) = read
            .missions
            .into_iter()
            .next()
            .ok_or_else(|| malformed("no mission".into()))?;
        content.interop_id = Some(self.cfg.mission);
        Ok((read.format, content, home))
    }

    /// Sends one telemetry sample in the upstream's format.
    ///
    /// # Errors
    /// Transport or status (see [`LinkError::is_final`]).
    pub async fn post_telemetry(&self, s: &crate::store::TelemetryRow) -> Result<(), LinkError> {
        let sent = if self.api() == Some(SourceFormat::Interop2018) {
            let form = wire::interop::render_telemetry_2018_form(s);
            self.send("/api/telemetry", |c, u| {
                c.post(u)
                    .header(header::CONTENT_TYPE, "application/x-www-form-urlencoded")
                    .body(form.clone())
            })
            .await
        } else {
            let json = wire::interop::render_telemetry_2019(s);
            self.send("/api/telemetry", |c, u| c.post(u).json(&json))
                .await
        };
        sent.map(|_| ())
    }

    /// Fetches a 2017/2018 obstacle snapshot.
    ///
    /// # Errors
    /// Transport, status, or an answer that is not JSON.
    pub async fn fetch_obstacles(&self) -> Result<Value, LinkError> {
        let body = self.send("/api/obstacles", |c, u| c.get(u)).await?;
        serde_json::from_slice(&body).map_err(|e| LinkError::Malformed {
            url: self.url("/api/obstacles"),
            detail: format!("not JSON: {e}"),
        })
    }
}

/// Stores the upstream mission unless the newest mission linked to it is the same:
/// returns the jink mission id and whether it was stored now.
///
/// # Errors
/// Database failures.
pub async fn store_mission(
    store: &Store,
    up: &Upstream,
    format: SourceFormat,
    content: crate::mission::MissionInput,
    home: crate::mission::Home,
) -> Result<(MissionId, bool), LinkError> {
    if let Some(id) = store.linked_mission(up.cfg.mission).await?
        && let Some(m) = store.get_mission(&id).await?
        && m.content == content
        && m.home == home
    {
        return Ok((id, false));
    }
    let now = now_s();
    let mission = Mission {
        id: format!("{:016x}", rand::random::<u64>()).into(),
        source_format: format,
        created_at: format_rfc3339(now),
        home,
        content,
    };
    store
        .insert_missions(std::slice::from_ref(&mission), now)
        .await?;
    store
        .insert_link(&mission.id, &up.cfg.url, up.cfg.mission, now)
        .await?;
    Ok((mission.id, true))
}

/// Back-off between retries: 250 ms doubling to 10 s.
#[derive(Debug)]
struct Backoff(Duration);

impl Backoff {
    const FIRST: Duration = Duration::from_millis(250);
    const MAX: Duration = Duration::from_secs(10);

    fn new() -> Self {
        Self(Self::FIRST)
    }

    fn reset(&mut self) {
        self.0 = Self::FIRST;
    }

    /// The wait before the next retry (at least `retry_after`).
    fn next(&mut self, retry_after: Option<Duration>) -> Duration {
        let wait = self.0.max(retry_after.unwrap_or_default());
        self.0 = (self.0 * 2).min(Self::MAX);
        wait
    }
}

fn succeeded(state: &AppState) {
    state.interop.update_link(|s| {
        s.connected = true;
        s.last_success = Some(format_rfc3339(now_s()));
    });
}

fn failed(state: &AppState, what: &str, e: &LinkError) {
    tracing::warn!(error = %e, "interop link: {what} failed");
    state.interop.update_link(|s| {
        if e.disconnects() {
            s.connected = false;
        }
        s.errors += 1;
        let at = format_rfc3339(now_s());
        let line = format!("{what}: {e}");
        if s.recent_errors.len() >= 16 {
            s.recent_errors.remove(0);
        }
        s.recent_errors.push(format!("{at} {line}"));
        s.last_error = Some(line);
        s.last_error_at = Some(at);
    });
}

fn api_name(f: Option<SourceFormat>) -> Option<String> {
    match f {
        Some(SourceFormat::Interop2018) => Some("2018".into()),
        Some(SourceFormat::Interop2019) => Some("2019".into()),
        _ => None,
    }
}

/// Runs the link until the process ends (never returns an error: failures are reported
/// in the status and retried).
pub async fn run(state: AppState, up: Arc<Upstream>) {
    // A restart continues with the mission linked before (and its API generation) while
    // the judges' server cannot be reached: telemetry keeps its mission and its queue.
    let linked = match state.store.linked_mission(up.cfg.mission).await {
        Ok(Some(id)) => state.store.get_mission(&id).await.ok().flatten(),
        _ => None,
    };
    if let Some(m) = &linked {
        up.set_api(m.source_format);
    }
    state.interop.start_link(super::LinkStatus {
        url: up.cfg.url.clone(),
        upstream_mission: up.cfg.mission,
        api: api_name(up.api()),
        mission_id: linked.map(|m| m.id.to_string()),
        ..Default::default()
    });
    let writer: Arc<str> = Arc::from("interop");
    let work = async {
        tokio::join!(
            mission_loop(&state, &up),
            obstacle_loop(&state, &up),
            forward_loop(&state, &up)
        );
    };
    crate::auth::WRITER.scope(writer, work).await;
}

/// Pulls the mission at start and every `mission_poll`.
async fn mission_loop(state: &AppState, up: &Upstream) {
    let mut backoff = Backoff::new();
    loop {
        let pulled = async {
            let (format, content, home) = up.fetch_mission().await?;
            store_mission(&state.store, up, format, content, home).await
        }
        .await;
        match pulled {
            Ok((id, stored)) => {
                succeeded(state);
                let api = api_name(up.api());
                state.interop.update_link(|s| {
                    if stored && s.mission_id.is_some() {
                        s.mission_changes += 1;
                    }
                    s.mission_id = Some(id.to_string());
                    s.api = api;
                });
                if stored {
                    tracing::info!(mission = %id, upstream = up.cfg.mission, "interop link: mission stored");
                }
                backoff.reset();
                tokio::time::sleep(up.cfg.mission_poll).await;
            }
            Err(e) => {
                failed(state, "mission pull", &e);
                tokio::time::sleep(
                    backoff
                        .next(e.retry_after())
                        .min(up.cfg.mission_poll.max(Backoff::FIRST)),
                )
                .await;
            }
        }
    }
}

/// Polls moving obstacles (2017/2018 API) into the linked mission.
async fn obstacle_loop(state: &AppState, up: &Upstream) {
    if up.cfg.obstacle_hz <= 0.0 || !up.cfg.obstacle_hz.is_finite() {
        return;
    }
    let period = Duration::from_secs_f64((1.0 / up.cfg.obstacle_hz).max(0.01));
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut backoff = Backoff::new();
    loop {
        tick.tick().await;
        let mission = state.interop.link().and_then(|l| l.mission_id);
        let (Some(mission), Some(SourceFormat::Interop2018)) = (mission, up.api()) else {
            continue;
        };
        let mission = MissionId::from(mission);
        let polled = async {
            let value = up.fetch_obstacles().await?;
            let received = now_s();
            let rows = wire::telemetry::parse_observations(value, None, received).map_err(|e| {
                LinkError::Malformed {
                    url: up.url("/api/obstacles"),
                    detail: e.to_string(),
                }
            })?;
            let batch = state
                .store
                .insert_observations(&mission, &rows, received)
                .await?;
            if let Some(batch) = batch {
                state.live.apply(state, &mission, &batch).await;
            }
            Ok::<(), LinkError>(())
        }
        .await;
        match polled {
            Ok(()) => {
                succeeded(state);
                state.interop.update_link(|s| s.obstacle_polls += 1);
                backoff.reset();
            }
            Err(e) => {
                failed(state, "obstacle poll", &e);
                tokio::time::sleep(backoff.next(e.retry_after())).await;
            }
        }
    }
}

/// Forwards accepted telemetry of linked missions upstream, in order.
async fn forward_loop(state: &AppState, up: &Upstream) {
    let gap = Duration::from_secs_f64(1.0 / up.cfg.telemetry_hz.clamp(0.01, 1000.0));
    let mut backoff = Backoff::new();
    let mut last_sent: Option<tokio::time::Instant> = None;
    loop {
        let queued = async {
            let depth = state.store.pending_count().await?;
            state
                .interop
                .update_link(|s| s.queue_depth = u64::try_from(depth).unwrap_or(0));
            if depth == 0 || up.api().is_none() {
                return Ok::<Vec<Pending>, LinkError>(Vec::new());
            }
            Ok(state.store.pending_telemetry(100).await?)
        }
        .await;
        let batch = match queued {
            Ok(b) => b,
            Err(e) => {
                failed(state, "telemetry queue", &e);
                tokio::time::sleep(backoff.next(None)).await;
                continue;
            }
        };
        if batch.is_empty() {
            tokio::select! {
                () = state.interop.telemetry_accepted.notified() => {}
                () = tokio::time::sleep(Duration::from_millis(250)) => {}
            }
            continue;
        }
        for p in batch {
            if let Some(t) = last_sent {
                tokio::time::sleep_until(t + gap).await;
            }
            last_sent = Some(tokio::time::Instant::now());
            let sent = up.post_telemetry(&p.sample).await;
            let outcome = match &sent {
                Ok(()) => Outcome::Sent,
                Err(e) if e.is_final() => Outcome::Rejected,
                Err(e) => {
                    failed(state, "telemetry forward", e);
                    tokio::time::sleep(backoff.next(e.retry_after())).await;
                    break;
                }
            };
            if let Err(e) = state.store.mark_forwarded(&p, outcome, now_s()).await {
                // The sample stays queued and goes again: a duplicate upstream, not a loss.
                failed(state, "telemetry acknowledgement", &LinkError::from(e));
                break;
            }
            backoff.reset();
            match sent {
                Ok(()) => {
                    succeeded(state);
                    state.interop.update_link(|s| {
                        s.forwarded += 1;
                        s.queue_depth = s.queue_depth.saturating_sub(1);
                    });
                }
                Err(e) => {
                    failed(state, "telemetry forward (refused, not sent again)", &e);
                    state.interop.update_link(|s| {
                        s.rejected += 1;
                        s.queue_depth = s.queue_depth.saturating_sub(1);
                    });
                }
            }
        }
    }
}
