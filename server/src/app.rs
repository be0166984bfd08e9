//! The application: shared state, the router with its middleware, and the server loop.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Instant;

use axum::Router;
use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::http::StatusCode;
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use tokio::sync::Semaphore;
use tower_http::trace::TraceLayer;

use crate::error::{ApiError, InternalCause};
use crate::metrics::Metrics;
use crate::store::Store;

/// Settings the handlers need at run time.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Largest accepted request body, bytes.
    pub max_body_bytes: usize,
    /// Limits of the live mission state.
    pub live: crate::live::LiveConfig,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            max_body_bytes: 2 * 1024 * 1024,
            live: crate::live::LiveConfig::default(),
        }
    }
}

/// State shared by every handler (cheap to clone).
#[derive(Clone, Debug)]
pub struct AppState {
    /// The database.
    pub store: Store,
    /// Request metrics.
    pub metrics: Arc<Metrics>,
    /// Run-time settings.
    pub settings: Arc<Settings>,
    /// Bounds concurrent CPU-heavy jobs (planning, risk maps) run with `spawn_blocking`.
    pub cpu: Arc<Semaphore>,
    /// Per-mission live state: predictor and risk-map snapshots (built lazily from the
    /// store).
    pub live: Arc<crate::live::LiveStates>,
}

impl AppState {
    /// State over `store` with default settings.
    pub fn new(store: Store, settings: Settings) -> Self {
        let settings_live = settings.live;
        let cores = std::thread::available_parallelism().map_or(2, std::num::NonZero::get);
        Self {
            store,
            metrics: Arc::new(Metrics::default()),
            settings: Arc::new(settings),
            cpu: Arc::new(Semaphore::new(cores)),
            live: Arc::new(crate::live::LiveStates::new(settings_live)),
        }
    }

    /// Runs CPU-heavy `f` off the async runtime, at most one job per core at a time.
    ///
    /// # Errors
    /// An internal error if the job panicked.
    pub async fn run_cpu<T: Send + 'static>(
        &self,
        f: impl FnOnce() -> T + Send + 'static,
    ) -> Result<T, ApiError> {
        let _permit = self
            .cpu
            .acquire()
            .await
            .map_err(|e| ApiError::Internal(e.to_string()))?;
        Ok(tokio::task::spawn_blocking(f).await?)
    }
}

/// The complete router: API routes (all in the OpenAPI document), docs, fallbacks and
/// middleware.
pub fn router(state: AppState) -> Router {
    let max_body = state.settings.max_body_bytes;
    let (api, openapi) = crate::api::router().split_for_parts();
    let docs: Router = utoipa_swagger_ui::SwaggerUi::new("/docs")
        .url("/docs/openapi.json", openapi)
        .into();
    api.fallback(no_such_route)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(DefaultBodyLimit::max(max_body))
        .with_state(state.clone())
        .merge(docs)
        .layer(middleware::from_fn_with_state(state, observe))
        .layer(TraceLayer::new_for_http().make_span_with(|req: &Request| {
            let route = req
                .extensions()
                .get::<MatchedPath>()
                .map_or("-", MatchedPath::as_str);
            tracing::info_span!("request", method = %req.method(), path = %req.uri().path(), route)
        }))
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
    let resp = next.run(req).await;
    let elapsed = start.elapsed();
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

/// Serves `state` on `addr` until Ctrl-C / SIGTERM. Prints the bound address on stdout
/// (`jink listening on http://ADDR`) so scripts and tests can use port 0.
///
/// # Errors
/// When the address cannot be bound.
pub async fn serve(addr: SocketAddr, state: AppState) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await?;
    let local = listener.local_addr()?;
    println!("jink listening on http://{local}");
    tracing::info!(%local, backend = ?state.store.backend(), "serving");
    axum::serve(listener, router(state).into_make_service())
        .with_graceful_shutdown(shutdown_signal())
        .await
}

async fn shutdown_signal() {
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
}

/// Problem+json for a response produced outside the API (kept for symmetry with the
/// fallbacks; handlers return [`ApiError`] directly).
pub fn problem(status: StatusCode, detail: &str) -> Response {
    ApiError::Route {
        status,
        detail: detail.to_string(),
    }
    .into_response()
}
