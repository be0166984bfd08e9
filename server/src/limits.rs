//! Overload protection (issue 12): the bounded plan pool, items per request, the
//! per-request timeout, and the HTML pages' security headers.
//!
//! - **Plan pool** ([`PlanPool`]): plan computations (create and replay) run with
//!   `spawn_blocking`, at most `workers` at a time (default: one core less than the
//!   machine has, at least one), with at most `queue` more admitted and waiting. A plan
//!   request beyond that is refused at once, before any work, with 503 and `Retry-After`
//!   (the expected wait for the queue to drain, from the recent plan durations). Ingest
//!   never goes through this pool. A plan also takes a slot of the CPU budget
//!   ([`crate::cpu`]) that it shares with risk-map builds, so that plans and maps
//!   together leave a core to the runtime.
//! - **Priority**: CPU jobs (plans and risk-map builds, [`PlanTicket::run`] and
//!   `AppState::run_cpu`) run at a lower scheduling priority than the
//!   async runtime's threads (nice + [`CPU_JOB_NICE`]), so on a saturated machine the kernel runs ingest first and
//!   plans take what is left (Linux; elsewhere a no-op).
//! - **Items per request** ([`check_items`]): observations per batch, waypoints, fly-zone
//!   boundary points, and any other list, counted in the JSON before it is parsed into
//!   missions or observations (whose validation costs grow with them); 413 naming the list
//!   by its JSON pointer.
//! - **Per-request timeout** ([`timeout`]): a request whose answer has not started within
//!   the limit gets 503 `timeout` with `Retry-After`; its handler is dropped, which cancels
//!   a plan computation in flight. A streamed body (the pages' event streams) is not
//!   covered once it has started.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use axum::extract::{Request, State};
use axum::http::{HeaderValue, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use serde_json::Value;
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use crate::app::AppState;
use crate::error::ApiError;

/// Default of how much nicer the threads CPU jobs run on are than the process
/// (`--cpu-job-nice`): at +10 a busy job thread gets about a tenth of the CPU of a
/// runtime thread that wants it.
pub const CPU_JOB_NICE: i32 = 10;

static JOB_NICE: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(CPU_JOB_NICE);

/// Sets how much nicer CPU-job threads started from now on are (0: as the process).
pub fn set_cpu_job_nice(nice: i32) {
    JOB_NICE.store(nice.clamp(0, 19), Ordering::Relaxed);
}

/// Lowers the calling thread's scheduling priority by [`CPU_JOB_NICE`] (to at most 19),
/// once per thread.
/// Called first thing by every job on tokio's blocking pool, which only CPU jobs use in
/// this server; a thread's nice value is per thread on Linux. Failure is harmless (the
/// job runs at the normal priority) and not reported.
pub fn background_priority() {
    thread_local!(static LOWERED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) });
    LOWERED.with(|done| {
        if !done.replace(true) {
            #[cfg(target_os = "linux")]
            {
                let by = JOB_NICE.load(Ordering::Relaxed);
                let tid = Some(rustix::thread::gettid());
                if by > 0
                    && let Ok(now) = rustix::process::getpriority_process(tid)
                {
                    let _ = rustix::process::setpriority_process(tid, (now + by).min(19));
                }
            }
        }
    });
}

/// The bounded pool of plan computations.
#[derive(Debug)]
pub struct PlanPool {
    workers: Arc<Semaphore>,
    admitted: Arc<Semaphore>,
    n_workers: usize,
    queue: usize,
    /// Recent plan durations, exponentially averaged, milliseconds.
    avg_ms: AtomicU64,
}

/// A plan admitted to the pool (holding its place until dropped).
#[derive(Debug)]
pub struct PlanTicket {
    _slot: OwnedSemaphorePermit,
    pool: Arc<PlanPool>,
}

impl PlanPool {
    /// A pool of `workers` (at least 1) concurrent computations and `queue` waiting ones.
    pub fn new(workers: usize, queue: usize) -> Self {
        let workers = workers.max(1);
        Self {
            workers: Arc::new(Semaphore::new(workers)),
            admitted: Arc::new(Semaphore::new(workers + queue)),
            n_workers: workers,
            queue,
            avg_ms: AtomicU64::new(500),
        }
    }

    /// The default worker count: the CPU budget's default, one core less than the machine
    /// has, at least one.
    pub fn default_workers() -> usize {
        crate::cpu::CpuGate::default_slots()
    }

    /// Admits one plan, or refuses it at once.
    ///
    /// # Errors
    /// 503 with `Retry-After` when `workers + queue` plans are already admitted.
    pub fn admit(self: &Arc<Self>) -> Result<PlanTicket, ApiError> {
        match self.admitted.clone().try_acquire_owned() {
            Ok(slot) => Ok(PlanTicket {
                _slot: slot,
                pool: self.clone(),
            }),
            Err(_) => {
                let avg_s = self.avg_ms.load(Ordering::Relaxed) as f64 / 1000.0;
                let drain_s = avg_s * (self.n_workers + self.queue) as f64 / self.n_workers as f64;
                let retry_after_s = drain_s.ceil().clamp(1.0, 60.0) as u64;
                Err(ApiError::Unavailable {
                    slug: "plan-pool-full",
                    detail: format!(
                        "the plan pool is full ({} computing, {} waiting); retry after {retry_after_s} s",
                        self.n_workers, self.queue
                    ),
                    retry_after_s,
                })
            }
        }
    }
}

impl PlanTicket {
    /// Runs the CPU-bound `f` off the async runtime once a worker and a slot of the CPU
    /// budget `cpu` are free.
    ///
    /// # Errors
    /// An internal error if the job panicked.
    pub async fn run<T: Send + 'static>(
        self,
        cpu: &Arc<crate::cpu::CpuGate>,
        f: impl FnOnce() -> T + Send + 'static,
    ) -> Result<T, ApiError> {
        let _worker = self
            .pool
            .workers
            .clone()
            .acquire_owned()
            .await
            .map_err(|e| ApiError::Internal(e.to_string()))?;
        let start = Instant::now();
        let permit = cpu.acquire(crate::cpu::Priority::Foreground).await;
        let out = crate::app::run_with(permit, f).await?;
        let ms = start.elapsed().as_millis() as u64;
        let old = self.pool.avg_ms.load(Ordering::Relaxed);
        self.pool
            .avg_ms
            .store((old * 7 + ms) / 8, Ordering::Relaxed);
        Ok(out)
    }
}

/// Most items per request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ItemLimits {
    /// Observations in one batch (`observations`, or `moving_obstacles` of a snapshot).
    pub observations: usize,
    /// Waypoints of a mission (`waypoints`, `mission_waypoints`).
    pub waypoints: usize,
    /// Boundary points of one fly zone (`boundary`, `boundary_pts`, `boundaryPoints`).
    pub fly_zone_points: usize,
    /// Any other list (telemetry samples, search grid points, cylinders, missions).
    pub other: usize,
}

impl Default for ItemLimits {
    fn default() -> Self {
        Self {
            observations: 1000,
            waypoints: 1000,
            fly_zone_points: 1000,
            other: 10_000,
        }
    }
}

impl ItemLimits {
    /// The limit of a list named `key` and its flag.
    fn of(&self, key: &str) -> (usize, &'static str) {
        match key {
            "observations" | "moving_obstacles" => (self.observations, "--max-observations"),
            "waypoints" | "mission_waypoints" => (self.waypoints, "--max-waypoints"),
            "boundary" | "boundary_pts" | "boundaryPoints" | "boundary_points" => {
                (self.fly_zone_points, "--max-fly-zone-points")
            }
            _ => (self.other, "--max-list-items"),
        }
    }
}

/// Checks every list in a JSON request body against `limits`.
///
/// # Errors
/// 413 naming the first list over its limit by its JSON pointer.
pub fn check_items(value: &Value, limits: &ItemLimits) -> Result<(), ApiError> {
    fn walk(
        v: &Value,
        key: &str,
        pointer: &mut String,
        limits: &ItemLimits,
    ) -> Result<(), ApiError> {
        match v {
            Value::Array(items) => {
                let (max, _) = limits.of(key);
                if items.len() > max {
                    return Err(ApiError::TooManyItems {
                        pointer: if pointer.is_empty() {
                            "/".into()
                        } else {
                            pointer.clone()
                        },
                        count: items.len(),
                        max,
                    });
                }
                for (i, item) in items.iter().enumerate() {
                    let len = pointer.len();
                    pointer.push_str(&format!("/{i}"));
                    // Items of a top-level list (a list of missions) are judged by their
                    // own keys; nested lists keep the list's name.
                    walk(item, key, pointer, limits)?;
                    pointer.truncate(len);
                }
                Ok(())
            }
            Value::Object(map) => {
                for (k, item) in map {
                    let len = pointer.len();
                    pointer.push('/');
                    pointer.push_str(&k.replace('~', "~0").replace('/', "~1"));
                    walk(item, k, pointer, limits)?;
                    pointer.truncate(len);
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
    walk(value, "", &mut String::new(), limits)
}

/// The per-request timeout middleware (see the module documentation).
pub async fn timeout(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let limit = state.settings.access.request_timeout;
    match tokio::time::timeout(limit, next.run(req)).await {
        Ok(resp) => resp,
        Err(_) => ApiError::Unavailable {
            slug: "timeout",
            detail: format!(
                "the request took longer than {} s (--request-timeout-s) and was abandoned; retry later, or with a smaller deadline_ms",
                limit.as_secs_f64()
            ),
            retry_after_s: 1,
        }
        .into_response(),
    }
}

/// The policy of the HTML pages: their own inline style and script, images drawn or
/// fetched from this origin, data from this origin, no framing.
const HTML_CSP: &str = "default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; \
img-src 'self' data: blob:; connect-src 'self'; font-src 'self' data:; frame-ancestors 'none'; base-uri 'none'; form-action 'self'";

/// Adds `X-Content-Type-Options: nosniff` to every answer, and to HTML pages a content
/// security policy, `X-Frame-Options: DENY` and `Referrer-Policy: no-referrer`.
pub async fn security_headers(req: Request, next: Next) -> Response {
    let mut resp = next.run(req).await;
    let h = resp.headers_mut();
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    let html = h
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("text/html"));
    if html {
        h.insert(
            header::CONTENT_SECURITY_POLICY,
            HeaderValue::from_static(HTML_CSP),
        );
        h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
        h.insert(
            header::REFERRER_POLICY,
            HeaderValue::from_static("no-referrer"),
        );
    }
    resp
}

/// Wraps `routes` in the access and overload middleware, innermost first: the guard
/// (tokens, roles, rates; [`crate::auth::guard`]), the per-request [`timeout`], the
/// [`security_headers`], and CORS when origins are configured (outermost, so that a
/// preflight is answered without a token).
pub fn guarded(routes: axum::Router, state: &AppState) -> axum::Router {
    let routes = routes
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            crate::auth::guard,
        ))
        .layer(axum::middleware::from_fn_with_state(state.clone(), timeout))
        .layer(axum::middleware::from_fn(security_headers));
    match cors(&state.settings.access.cors_origins) {
        Some(layer) => routes.layer(layer),
        None => routes,
    }
}

/// The CORS layer for `origins` (`*` allows any); `None` when there are none (CORS off,
/// the default). Browsers may send `Authorization` and `Content-Type` and read `Location`
/// and `Retry-After`; no cookies are involved, so no credentials mode.
fn cors(origins: &[String]) -> Option<tower_http::cors::CorsLayer> {
    use axum::http::Method;
    use tower_http::cors::{AllowOrigin, CorsLayer};
    if origins.is_empty() {
        return None;
    }
    let allow = if origins.iter().any(|o| o == "*") {
        AllowOrigin::any()
    } else {
        AllowOrigin::list(
            origins
                .iter()
                .filter_map(|o| HeaderValue::from_str(o.trim_end_matches('/')).ok()),
        )
    };
    Some(
        CorsLayer::new()
            .allow_origin(allow)
            .allow_methods([Method::GET, Method::POST, Method::DELETE])
            .allow_headers([header::AUTHORIZATION, header::CONTENT_TYPE])
            .expose_headers([header::LOCATION, header::RETRY_AFTER])
            .max_age(Duration::from_secs(600)),
    )
}

/// How long a request may take before its answer starts, by default.
pub const DEFAULT_REQUEST_TIMEOUT: Duration = Duration::from_secs(90);

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[cfg(target_os = "linux")]
    #[tokio::test]
    async fn a_plan_runs_on_a_thread_of_lower_priority_than_the_runtime() {
        let nice = || rustix::process::getpriority_process(Some(rustix::thread::gettid()));
        let runtime = nice().expect("getpriority");
        let pool = Arc::new(PlanPool::new(1, 0));
        let job = pool
            .admit()
            .expect("admitted")
            .run(&crate::cpu::CpuGate::new(1), nice)
            .await
            .expect("job");
        assert_eq!(job.expect("getpriority"), (runtime + CPU_JOB_NICE).min(19));
        assert_eq!(
            nice().expect("getpriority"),
            runtime,
            "the runtime's own is unchanged"
        );
    }

    #[test]
    fn the_first_list_over_its_limit_is_named_by_its_pointer() {
        let limits = ItemLimits {
            observations: 2,
            waypoints: 3,
            fly_zone_points: 4,
            other: 5,
        };
        let ok = json!({"observations": [1, 2], "waypoints": [1, 2, 3]});
        check_items(&ok, &limits).unwrap();
        let e = check_items(&json!({"observations": [1, 2, 3]}), &limits).unwrap_err();
        let p = e.problem();
        assert_eq!(p.status, 413);
        assert_eq!(p.errors[0].pointer, "/observations");
        let zones = json!({"flyZones": [{"boundaryPoints": [1, 2, 3, 4]}, {"boundaryPoints": [1, 2, 3, 4, 5]}]});
        let e = check_items(&zones, &limits).unwrap_err();
        assert_eq!(e.problem().errors[0].pointer, "/flyZones/1/boundaryPoints");
        assert!(e.to_string().contains("at most 4"), "{e}");
    }

    #[tokio::test]
    async fn a_full_pool_refuses_at_once_with_a_retry_delay() {
        let pool = Arc::new(PlanPool::new(1, 1));
        let a = pool.admit().unwrap();
        let _b = pool.admit().unwrap();
        let e = pool.admit().unwrap_err();
        assert_eq!(e.status(), axum::http::StatusCode::SERVICE_UNAVAILABLE);
        assert_eq!(a.run(&crate::cpu::CpuGate::new(1), || 7).await.unwrap(), 7);
        // `a`'s place is free again.
        pool.admit().unwrap();
    }
}
