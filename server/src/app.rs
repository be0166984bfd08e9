//! The application: shared state, the router with its middleware, and the server loop.

use std::sync::Arc;
use std::time::Instant;

use axum::Router;
use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::http::StatusCode;
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use tower_http::catch_panic::CatchPanicLayer;
use tower_http::trace::TraceLayer;

use crate::error::{ApiError, InternalCause};
use crate::metrics::Metrics;
use crate::store::Store;

/// Settings the handlers need at run time.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Largest accepted request body, bytes.
    pub(crate) max_body_bytes: usize,
    /// Limits of the live mission state.
    pub(crate) live: crate::live::LiveConfig,
    /// Access control, overload limits and CORS (issue 12).
    pub(crate) access: AccessSettings,
}

/// Access control, overload limits and CORS (see [`crate::auth`] and [`crate::limits`]).
#[derive(Debug, Clone)]
pub struct AccessSettings {
    /// Whether requests need a token.
    pub(crate) auth: crate::auth::AuthMode,
    /// How long a token's verdict is remembered (revocations take this long to reach
    /// every replica).
    pub(crate) token_cache: std::time::Duration,
    /// Per-token write rates.
    pub(crate) rates: crate::auth::RateSettings,
    /// Items per request.
    pub(crate) items: crate::limits::ItemLimits,
    /// CPU jobs (plans, map builds, replays, pictures) at a time (see [`crate::cpu`]).
    pub(crate) cpu_workers: usize,
    /// Plan computations at a time, and admitted plans waiting for one.
    pub(crate) plan_workers: usize,
    pub(crate) plan_queue: usize,
    /// Longest time before a request's answer starts.
    pub(crate) request_timeout: std::time::Duration,
    /// Origins allowed by CORS (none: no CORS headers; `*`: any).
    pub(crate) cors_origins: Vec<String>,
}

impl Default for AccessSettings {
    fn default() -> Self {
        Self {
            auth: crate::auth::AuthMode::Optional,
            token_cache: std::time::Duration::from_secs(2),
            rates: crate::auth::RateSettings::default(),
            items: crate::limits::ItemLimits::default(),
            cpu_workers: crate::cpu::CpuGate::default_slots(),
            plan_workers: crate::limits::PlanPool::default_workers(),
            plan_queue: 16,
            request_timeout: crate::limits::DEFAULT_REQUEST_TIMEOUT,
            cors_origins: Vec::new(),
        }
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            max_body_bytes: 2 * 1024 * 1024,
            live: crate::live::LiveConfig::default(),
            access: AccessSettings::default(),
        }
    }
}

/// State shared by every handler (cheap to clone).
#[derive(Clone, Debug)]
pub struct AppState {
    /// The database.
    pub(crate) store: Store,
    /// Request metrics.
    pub(crate) metrics: Arc<Metrics>,
    /// Run-time settings.
    pub(crate) settings: Arc<Settings>,
    /// Bounds concurrent CPU-heavy jobs (planning, risk maps) run with `spawn_blocking`,
    /// foreground ones first.
    pub(crate) cpu: Arc<crate::cpu::CpuGate>,
    /// Per-mission live state: predictor and risk-map snapshots (built lazily from the
    /// store).
    pub(crate) live: Arc<crate::live::LiveStates>,
    /// The bounded pool plan computations run on.
    pub(crate) plans: Arc<crate::limits::PlanPool>,
    /// Token cache and per-token rate buckets.
    pub(crate) guard: Arc<crate::auth::Guard>,
    /// Interop sessions and the upstream link's status (issue 15).
    pub(crate) interop: Arc<crate::interop::InteropState>,
}

impl AppState {
    /// State over `store` with default settings.
    pub fn new(store: Store, settings: Settings) -> Self {
        let settings_live = settings.live;
        Self {
            store,
            metrics: Arc::new(Metrics::default()),
            cpu: crate::cpu::CpuGate::new(settings.access.cpu_workers),
            live: Arc::new(crate::live::LiveStates::new(settings_live)),
            plans: Arc::new(crate::limits::PlanPool::new(
                settings.access.plan_workers,
                settings.access.plan_queue,
            )),
            guard: Arc::new(crate::auth::Guard::new(
                settings.access.token_cache,
                settings.access.rates,
            )),
            settings: Arc::new(settings),
            interop: Arc::default(),
        }
    }

    /// Runs CPU-heavy `f` off the async runtime once a slot of the CPU budget is free
    /// (a request waits for it: [`crate::cpu::Priority::Foreground`]).
    ///
    /// # Errors
    /// An internal error if the job panicked.
    pub async fn run_cpu<T: Send + 'static>(
        &self,
        f: impl FnOnce() -> T + Send + 'static,
    ) -> Result<T, ApiError> {
        let permit = self.cpu.acquire(crate::cpu::Priority::Foreground).await;
        run_with(permit, f).await
    }
}

/// Runs CPU-heavy `f` off the async runtime in the slot `permit` holds (released when `f`
/// returns or panics).
///
/// # Errors
/// An internal error if the job panicked.
pub(crate) async fn run_with<T: Send + 'static>(
    permit: crate::cpu::CpuPermit,
    f: impl FnOnce() -> T + Send + 'static,
) -> Result<T, ApiError> {
    Ok(tokio::task::spawn_blocking(move || {
        let _permit = permit;
        crate::limits::background_priority();
        f()
    })
    .await?)
}

/// The complete router: API routes (all in the OpenAPI document), docs, fallbacks and
/// middleware.
pub fn router(state: AppState) -> Router {
    let max_body = state.settings.max_body_bytes;
    let api: Router<AppState> = crate::api::router().into();
    let docs: Router = utoipa_swagger_ui::SwaggerUi::new("/docs")
        .url("/docs/openapi.json", crate::api::openapi())
        .into();
    let routes = api
        .fallback(no_such_route)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(DefaultBodyLimit::max(max_body))
        .with_state(state.clone())
        .merge(docs);
    with_middleware(crate::limits::guarded(routes, &state), state)
}

/// Wraps `routes` in the service middleware, innermost first: a panic in a handler becomes
/// a 500 problem+json (its message logged by `observe`, never returned), then metrics and
/// the request log, then the tracing span.
fn with_middleware(routes: Router, state: AppState) -> Router {
    routes
        .layer(CatchPanicLayer::custom(panic_response))
        .layer(middleware::from_fn_with_state(state, observe))
        .layer(TraceLayer::new_for_http().make_span_with(|req: &Request| {
            let route = req
                .extensions()
                .get::<MatchedPath>()
                .map_or("-", MatchedPath::as_str);
            tracing::info_span!("request", method = %req.method(), path = %req.uri().path(), route)
        })
        .on_failure(log_failure))
}

/// Logs a failed response at ERROR, except 503: an overloaded plan pool answers 503 with
/// `Retry-After` by design, and one ERROR line per refusal cost CPU and buried real errors
/// during a flood (they are still counted in `/metrics`).
fn log_failure(
    class: tower_http::classify::ServerErrorsFailureClass,
    latency: std::time::Duration,
    _span: &tracing::Span,
) {
    use tower_http::classify::ServerErrorsFailureClass as Class;
    if matches!(class, Class::StatusCode(s) if s == axum::http::StatusCode::SERVICE_UNAVAILABLE) {
        return;
    }
    tracing::error!(classification = %class, latency_ms = latency.as_millis(), "response failed");
}

/// The answer to a request whose handler panicked: a 500 problem document whose hidden
/// cause (the panic message) the logging middleware logs.
fn panic_response(payload: Box<dyn std::any::Any + Send + 'static>) -> Response {
    let message = payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
        .unwrap_or("a panic with a non-string payload");
    ApiError::Internal(format!("panic: {message}")).into_response()
}

async fn no_such_route(req: Request) -> ApiError {
    ApiError::Route {
        status: StatusCode::NOT_FOUND,
        detail: format!(
            "no route answers {} (see /openapi.json or /docs)",
            req.uri().path()
        ),
    }
}

async fn method_not_allowed(req: Request) -> ApiError {
    ApiError::Route {
        status: StatusCode::METHOD_NOT_ALLOWED,
        detail: format!("{} is not allowed on {}", req.method(), req.uri().path()),
    }
}

/// Records metrics and logs each request once, with internal failures' causes.
async fn observe(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let start = Instant::now();
    let method = req.method().to_string();
    let path = req.uri().path().to_string();
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|m| m.as_str().to_string());
    let mut resp = next.run(req).await;
    let elapsed = start.elapsed();
    crate::timing::add_total(&mut resp, elapsed);
    let status = resp.status();
    // Unmatched paths share one label so that scanners cannot blow up the label set.
    let route = route.unwrap_or_else(|| {
        if path.starts_with("/docs") {
            "/docs".into()
        } else {
            "unmatched".into()
        }
    });
    state
        .metrics
        .record(&method, &route, status.as_u16(), elapsed);
    if let Some(InternalCause(cause)) = resp.extensions().get::<InternalCause>() {
        tracing::error!(%method, %path, %route, status = status.as_u16(), %cause, "request failed");
    } else {
        tracing::info!(%method, %path, %route, status = status.as_u16(), ms = elapsed.as_secs_f64() * 1e3, "request");
    }
    resp
}

/// Serves `state` on a bound `listener` until Ctrl-C / SIGTERM (what [`serve`] does after
/// binding; `jink demo` binds first to learn its address).
///
/// # Errors
/// When the listener's address cannot be read.
pub async fn serve_on(listener: tokio::net::TcpListener, state: AppState) -> std::io::Result<()> {
    crate::net::serve_with(listener, state, crate::net::NetOptions::default()).await
}

/// Resolves on Ctrl-C or SIGTERM, after which event streams end (see [`crate::net`]).
pub(crate) async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        if let Ok(mut s) = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        {
            s.recv().await;
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {},
        () = term => {},
    }
    tracing::info!("shutting down");
    // Open pages' event streams never end by themselves.
    crate::page::shut_down();
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::body::Body;
    use axum::routing::get;
    use tower::ServiceExt;

    async fn state() -> (AppState, tempfile::TempDir) {
        let dir = tempfile::tempdir().unwrap();
        let url = format!("sqlite://{}", dir.path().join("t.sqlite").display());
        let store = Store::open(&url).await.unwrap();
        (AppState::new(store, Settings::default()), dir)
    }

    #[tokio::test]
    async fn a_panicking_handler_answers_500_problem_json_without_its_message() {
        let (state, _dir) = state().await;
        let routes = Router::new().route(
            "/boom",
            get(|| async {
                let secret = "the secret cause";
                if !secret.is_empty() {
                    panic!("{secret}");
                }
                "unreachable"
            }),
        );
        let app = with_middleware(routes, state.clone());
        let resp = app
            .oneshot(Request::get("/boom").body(Body::empty()).unwrap())
            .await
            .unwrap();
        assert_eq!(resp.status(), StatusCode::INTERNAL_SERVER_ERROR);
        assert_eq!(
            resp.headers()[axum::http::header::CONTENT_TYPE],
            crate::error::PROBLEM_JSON
        );
        // The cause travels to the logging middleware in the response extensions.
        let cause = resp.extensions().get::<InternalCause>().cloned();
        assert_eq!(
            cause.map(|c| c.0).as_deref(),
            Some("panic: the secret cause")
        );
        let body = axum::body::to_bytes(resp.into_body(), 1 << 16)
            .await
            .unwrap();
        let problem: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(problem["status"], 500);
        assert_eq!(problem["type"], "urn:jink:problem:internal");
        assert!(!String::from_utf8_lossy(&body).contains("secret"));
        // ... and the panic was counted as a 500 by the metrics.
        let text = state.metrics.render();
        assert!(
            text.contains(r#"route="/boom",method="GET",status="500""#),
            "metrics do not show the 500:\n{text}"
        );
    }
}
