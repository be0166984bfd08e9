//! `jink serve`: configuration (flags with environment fallbacks) and start-up.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use tracing_subscriber::EnvFilter;

use crate::app::{AccessSettings, AppState, Settings};
use crate::auth::AuthMode;
use crate::net::NetOptions;
use crate::store::Store;

/// Log line format.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum LogFormat {
    /// Human-readable lines.
    Text,
    /// One JSON object per line, for log collectors.
    Json,
}

/// Flags of `jink serve`. Each has an environment-variable fallback.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Address and port to listen on. Use port 0 for any free port; the bound address is
    /// printed on stdout as `jink listening on http://ADDR`.
    #[arg(long, env = "JINK_BIND", default_value = "127.0.0.1:8080")]
    pub bind: SocketAddr,

    /// Database URL: `sqlite://FILE` (created and migrated at start; the default is
    /// `jink.sqlite` in the working directory) or `postgres://USER@HOST:PORT/DB` (for
    /// several replicas sharing one database).
    #[arg(
        long,
        env = "JINK_DATABASE_URL",
        default_value = "sqlite://jink.sqlite"
    )]
    pub database_url: String,

    /// Largest request body accepted, in bytes; larger bodies get 413.
    #[arg(long, env = "JINK_MAX_BODY_BYTES", default_value_t = 2 * 1024 * 1024)]
    pub max_body_bytes: usize,

    /// A mission's live state (predictor and risk map) unused for this many seconds is
    /// dropped from memory; its next use rebuilds it from the database.
    #[arg(long, env = "JINK_LIVE_IDLE_S", default_value_t = 600)]
    pub live_idle_s: u64,

    /// At most this many missions are kept live; the least recently used is dropped first.
    #[arg(long, env = "JINK_LIVE_MAX_MISSIONS", default_value_t = 1000)]
    pub live_max_missions: usize,

    /// A mission's risk map not read by a plan or `GET .../risk` for this many seconds is
    /// dropped and no longer rebuilt after each observation batch (the predictor stays).
    #[arg(long, env = "JINK_LIVE_MAP_IDLE_S", default_value_t = 10)]
    pub live_map_idle_s: u64,

    /// At most this many missions keep a risk map in memory (about 6 MB each); the least
    /// recently read is dropped first and rebuilt when next needed.
    #[arg(long, env = "JINK_LIVE_MAX_MAPS", default_value_t = crate::live::DEFAULT_MAX_MAPS)]
    pub live_max_maps: usize,

    /// A plan uses the mission's last published risk map while the oldest observation
    /// batch it lacks was accepted at most this many milliseconds ago (its rebuild is then
    /// under way), instead of waiting for it, unless those batches bring a new obstacle;
    /// 0 makes every plan wait (read your writes). A plan request's `max_map_age_ms`
    /// overrides it.
    #[arg(long, env = "JINK_PLAN_MAP_MAX_AGE_MS", default_value_t = crate::live::DEFAULT_PLAN_MAP_MAX_AGE_MS)]
    pub plan_map_max_age_ms: u64,

    /// Share each risk-map build with a helper thread at the lowest priority (SCHED_IDLE),
    /// which uses the core kept for the runtime while it is idle: the same map, sooner.
    /// Default: on with two or more cores.
    #[arg(long, env = "JINK_LIVE_MAP_HELPER", action = clap::ArgAction::Set)]
    pub live_map_helper: Option<bool>,

    /// How much lower the scheduling priority of plan and risk-map threads is than the
    /// server's (nice increment, 0-19; Linux): ingest keeps precedence on a busy machine.
    /// 0 runs them at the server's priority.
    #[arg(long, env = "JINK_CPU_JOB_NICE", default_value_t = crate::limits::CPU_JOB_NICE)]
    pub cpu_job_nice: i32,

    /// Threads of the async runtime, which answer every request (HTTP, ingest, the hops to
    /// the database and to the CPU jobs). Default: the cores `--cpu-workers` leaves, at
    /// least 1 (on two cores, one). More threads than that share the cores with the CPU jobs
    /// and hand each other work: on two cores, two runtime threads gave ingest a p99 of
    /// 3.4-4.6 ms at a flight's load where one gives 1.2-1.7 in most runs (README, "One
    /// runtime thread on two cores").
    #[arg(long, env = "JINK_RUNTIME_WORKERS")]
    pub runtime_workers: Option<usize>,

    /// At most this many glibc malloc arenas (Linux with glibc): memory freed by one
    /// thread is then reused by the others instead of staying in its own arena, which
    /// keeps resident memory bounded under load. 0 leaves glibc's default (8 per core).
    /// Applied by re-executing `serve` once at start with `GLIBC_TUNABLES`; an arena limit
    /// already in the environment (`GLIBC_TUNABLES`, `MALLOC_ARENA_MAX`) wins.
    #[arg(long, env = "JINK_MALLOC_ARENA_MAX", default_value_t = DEFAULT_MALLOC_ARENA_MAX)]
    pub malloc_arena_max: usize,

    /// Log format on stderr. Levels come from `RUST_LOG` (default `info`).
    #[arg(long, env = "JINK_LOG_FORMAT", value_enum, default_value = "text")]
    pub log_format: LogFormat,

    #[command(flatten)]
    pub access: AccessArgs,

    /// The format `GET /api/missions[/{id}]` (the interop surface) renders missions in:
    /// `auto` (each mission's source format; native missions as 2019+), `2018` or `2019`.
    #[arg(long, env = "JINK_INTEROP_FORMAT", value_enum, default_value = "auto")]
    pub interop_format: crate::interop::FormatFlag,

    /// The upstream link to the judges' interop server (see the README's "At the
    /// competition").
    #[command(flatten)]
    pub interop: super::interop::LinkArgs,
}

/// Whether requests need a token.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AuthFlag {
    /// Tokens required unless bound to a loopback address.
    Auto,
    /// Tokens required, also on loopback.
    On,
    /// No token required (a token sent is still checked and recorded as the writer).
    Off,
}

/// Access control, TLS and overload flags of `jink serve` (see the README's "Running at
/// the field").
#[derive(Debug, Args)]
pub struct AccessArgs {
    /// `auto`: requests need a bearer token unless `--bind` is a loopback address; `on`:
    /// always; `off`: never. With tokens required, `serve` refuses to start until a token
    /// exists (`jink token create`).
    #[arg(long, env = "JINK_AUTH", value_enum, default_value = "auto")]
    pub auth: AuthFlag,

    /// PEM certificate chain: serve HTTPS (with `--tls-key`).
    #[arg(long, env = "JINK_TLS_CERT", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,

    /// PEM private key of `--tls-cert`.
    #[arg(long, env = "JINK_TLS_KEY", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,

    /// CPU jobs run at once: plan computations, risk-map builds, replays and pictures
    /// together (default: one core less than the machine has, at least 1, so that the
    /// server's own threads, which answer ingest, always keep a core). Plans and the maps
    /// requests wait for go before maps rebuilt ahead of time, and while every slot rebuilds
    /// a map ahead of time, one of them at a time runs beside those builds instead of
    /// waiting.
    #[arg(long, env = "JINK_CPU_WORKERS")]
    pub cpu_workers: Option<usize>,

    /// Plan computations run at once (default: one core less than the machine has, at
    /// least 1); they also need a `--cpu-workers` slot.
    #[arg(long, env = "JINK_PLAN_WORKERS")]
    pub plan_workers: Option<usize>,

    /// Plan requests admitted to wait for a worker; beyond them, 503 with Retry-After.
    #[arg(long, env = "JINK_PLAN_QUEUE", default_value_t = 16)]
    pub plan_queue: usize,

    /// Ingest requests (telemetry, obstacles) per second per token, sustained (0: no
    /// limit); over it, 429 with Retry-After. Requests without a token are not limited.
    #[arg(long, env = "JINK_RATE_INGEST_PER_S", default_value_t = 50.0)]
    pub rate_ingest_per_s: f64,

    /// Ingest requests a token may send in a burst.
    #[arg(long, env = "JINK_RATE_INGEST_BURST", default_value_t = 100.0)]
    pub rate_ingest_burst: f64,

    /// Other writes (plans, replays, missions) per second per token (0: no limit).
    #[arg(long, env = "JINK_RATE_WRITE_PER_S", default_value_t = 10.0)]
    pub rate_write_per_s: f64,

    /// Other writes a token may send in a burst.
    #[arg(long, env = "JINK_RATE_WRITE_BURST", default_value_t = 20.0)]
    pub rate_write_burst: f64,

    /// A request whose answer has not started after this many seconds gets 503.
    #[arg(long, env = "JINK_REQUEST_TIMEOUT_S", default_value_t = 90.0)]
    pub request_timeout_s: f64,

    /// A client must send a request's headers (and finish a TLS handshake) within this
    /// many seconds, or its connection is closed.
    #[arg(long, env = "JINK_HEADER_READ_TIMEOUT_S", default_value_t = 10.0)]
    pub header_read_timeout_s: f64,

    /// At SIGTERM/SIGINT, requests in flight get this many seconds to finish.
    #[arg(long, env = "JINK_SHUTDOWN_GRACE_S", default_value_t = 10.0)]
    pub shutdown_grace_s: f64,

    /// Seconds a token's check is remembered: a revocation reaches every replica within it.
    #[arg(long, env = "JINK_TOKEN_CACHE_S", default_value_t = 2.0)]
    pub token_cache_s: f64,

    /// Most observations in one batch (413 beyond).
    #[arg(long, env = "JINK_MAX_OBSERVATIONS", default_value_t = 1000)]
    pub max_observations: usize,

    /// Most waypoints in a mission (413 beyond).
    #[arg(long, env = "JINK_MAX_WAYPOINTS", default_value_t = 1000)]
    pub max_waypoints: usize,

    /// Most boundary points of one fly zone (413 beyond).
    #[arg(long, env = "JINK_MAX_FLY_ZONE_POINTS", default_value_t = 1000)]
    pub max_fly_zone_points: usize,

    /// Most items of any other list in a request body (413 beyond).
    #[arg(long, env = "JINK_MAX_LIST_ITEMS", default_value_t = 10_000)]
    pub max_list_items: usize,

    /// An origin allowed to call the API from a browser (CORS), e.g.
    /// `https://gcs.example:8443`; repeat for several, `*` for any. Off by default.
    #[arg(long = "cors-origin", env = "JINK_CORS_ORIGINS", value_delimiter = ',')]
    pub cors_origins: Vec<String>,
}

/// Seconds as a duration, at least a millisecond (a non-finite or negative value is 1 ms).
fn secs(s: f64) -> std::time::Duration {
    std::time::Duration::try_from_secs_f64(s.max(0.001))
        .unwrap_or(std::time::Duration::from_secs(1))
}

impl AccessArgs {
    /// CPU jobs run at once: `--cpu-workers`, else one core less than the machine has; at
    /// least 1.
    pub fn cpu_jobs(&self) -> usize {
        self.cpu_workers
            .unwrap_or_else(crate::cpu::CpuGate::default_slots)
            .max(1)
    }

    /// The auth mode for a service bound to `bind`.
    pub fn mode(&self, bind: &SocketAddr) -> AuthMode {
        match self.auth {
            AuthFlag::On => AuthMode::Required,
            AuthFlag::Off => AuthMode::Optional,
            AuthFlag::Auto if bind.ip().is_loopback() => AuthMode::Optional,
            AuthFlag::Auto => AuthMode::Required,
        }
    }

    /// The settings these flags give, for a service bound to `bind`.
    pub fn settings(&self, bind: &SocketAddr) -> AccessSettings {
        AccessSettings {
            auth: self.mode(bind),
            token_cache: secs(self.token_cache_s),
            rates: crate::auth::RateSettings {
                ingest_per_s: self.rate_ingest_per_s,
                ingest_burst: self.rate_ingest_burst,
                other_per_s: self.rate_write_per_s,
                other_burst: self.rate_write_burst,
            },
            items: crate::limits::ItemLimits {
                observations: self.max_observations,
                waypoints: self.max_waypoints,
                fly_zone_points: self.max_fly_zone_points,
                other: self.max_list_items,
            },
            cpu_workers: self.cpu_jobs(),
            plan_workers: self
                .plan_workers
                .unwrap_or_else(crate::limits::PlanPool::default_workers)
                .max(1),
            plan_queue: self.plan_queue,
            request_timeout: secs(self.request_timeout_s),
            cors_origins: self.cors_origins.clone(),
        }
    }

    /// The server loop's options (reads the TLS files).
    ///
    /// # Errors
    /// A message when the certificate or key cannot be used.
    pub fn net(&self) -> Result<NetOptions, String> {
        let tls = match (&self.tls_cert, &self.tls_key) {
            (Some(cert), Some(key)) => Some(crate::net::tls_config(cert, key)?),
            _ => None,
        };
        Ok(NetOptions {
            tls,
            header_read_timeout: secs(self.header_read_timeout_s),
            shutdown_grace: secs(self.shutdown_grace_s),
        })
    }
}

/// Initialises logging to stderr (stdout carries only the "listening" line).
pub fn init_logging(format: LogFormat) {
    init_logging_with(format, "info,sqlx=warn");
}

/// Initialises logging to stderr at `default_filter` unless `RUST_LOG` says otherwise.
pub fn init_logging_with(format: LogFormat, default_filter: &str) {
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default_filter));
    // Colour escapes only for a person at a terminal: log files and journald get plain text.
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr);
    let _ = match format {
        LogFormat::Text => builder.try_init(),
        LogFormat::Json => builder.json().try_init(),
    };
}

/// Default of `--malloc-arena-max`: in the overload benchmark 2 arenas held resident
/// memory to about half of glibc's default without slowing ingest (README, "Overload
/// benchmark").
pub const DEFAULT_MALLOC_ARENA_MAX: usize = 2;

/// Default of `--runtime-workers`: the `cores` that `cpu_jobs` CPU-job slots leave, at
/// least 1.
pub fn default_runtime_workers(cores: usize, cpu_jobs: usize) -> usize {
    cores.saturating_sub(cpu_jobs.max(1)).max(1)
}

/// Runs the service until a shutdown signal.
pub fn run(args: ServeArgs) -> ExitCode {
    // First, before any thread exists: this may re-execute the process.
    super::arenas::bound(args.malloc_arena_max);
    init_logging(args.log_format);
    let workers = args.runtime_workers.unwrap_or_else(|| {
        let cores = std::thread::available_parallelism().map_or(2, std::num::NonZero::get);
        default_runtime_workers(cores, args.access.cpu_jobs())
    });
    let mut builder = tokio::runtime::Builder::new_multi_thread();
    builder.worker_threads(workers.max(1));
    let Some(rt) = super::runtime(builder) else {
        return ExitCode::FAILURE;
    };
    let code = rt.block_on(async move {
        let link = match args.interop.config() {
            Ok(l) => l,
            Err(e) => {
                eprintln!("jink: {e}");
                return ExitCode::FAILURE;
            }
        };
        let net = match args.access.net() {
            Ok(n) => n,
            Err(e) => {
                eprintln!("jink: {e}");
                return ExitCode::FAILURE;
            }
        };
        let store = match Store::open(&args.database_url).await {
            Ok(s) => s,
            Err(e) => {
                eprintln!("jink: {e}");
                return ExitCode::FAILURE;
            }
        };
        let access = args.access.settings(&args.bind);
        if access.auth == AuthMode::Required {
            match store.count_valid_tokens().await {
                Ok(0) => {
                    eprintln!(
                        "jink: {} requires a token on every request, and no token is defined. Create one with\n    jink token create --name NAME --role admin --database-url {}\nor serve without tokens with --auth off (anyone who can reach the port can then steer the aircraft).",
                        if args.bind.ip().is_loopback() { "--auth on".to_string() } else { format!("a non-loopback bind ({})", args.bind) },
                        args.database_url
                    );
                    return ExitCode::FAILURE;
                }
                Ok(_) => {}
                Err(e) => {
                    eprintln!("jink: cannot read the tokens: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
        crate::limits::set_cpu_job_nice(args.cpu_job_nice);
        let state = AppState::new(
            store,
            Settings {
                max_body_bytes: args.max_body_bytes,
                live: crate::live::LiveConfig {
                    idle: std::time::Duration::from_secs(args.live_idle_s.max(1)),
                    max_missions: args.live_max_missions.max(1),
                    map_idle: std::time::Duration::from_secs(args.live_map_idle_s.max(1)),
                    max_maps: args.live_max_maps.max(1),
                    plan_map_max_age: std::time::Duration::from_millis(args.plan_map_max_age_ms),
                    map_helper: args
                        .live_map_helper
                        .unwrap_or(crate::live::LiveConfig::default().map_helper),
                },
                access,
            },
        );
        tracing::info!(
            runtime_workers = workers,
            cpu_workers = state.cpu.slots(),
            plan_workers = state.settings.access.plan_workers,
            "CPU budget"
        );
        state.interop.set_format(args.interop_format);
        if let Some(cfg) = link {
            match crate::interop::link::Upstream::new(cfg) {
                Ok(up) => {
                    tracing::info!(url = %up.cfg.url, mission = up.cfg.mission, "interop link starting");
                    tokio::spawn(crate::interop::link::run(state.clone(), std::sync::Arc::new(up)));
                }
                Err(e) => {
                    eprintln!("jink: cannot start the interop link: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
        if state.store.backend() == crate::store::Backend::Postgres {
            // Other replicas' batches reach this replica's live state.
            tokio::spawn(crate::live::notify::listen(
                state.clone(),
                args.database_url.clone(),
            ));
        }
        let listener = match tokio::net::TcpListener::bind(args.bind).await {
            Ok(l) => l,
            Err(e) => {
                eprintln!("jink: cannot serve on {}: {e}", args.bind);
                return ExitCode::FAILURE;
            }
        };
        match crate::net::serve_with(listener, state, net).await {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("jink: cannot serve on {}: {e}", args.bind);
                ExitCode::FAILURE
            }
        }
    });
    // Plan computations abandoned after the shutdown grace must not hold the exit.
    rt.shutdown_timeout(std::time::Duration::from_secs(1));
    code
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        access: AccessArgs,
    }

    fn settings(args: &[&str]) -> AccessSettings {
        let bind: SocketAddr = "127.0.0.1:0".parse().unwrap();
        Cli::try_parse_from(std::iter::once("jink").chain(args.iter().copied()))
            .unwrap()
            .access
            .settings(&bind)
    }

    #[test]
    fn the_runtime_takes_the_cores_the_cpu_jobs_leave_and_at_least_one() {
        assert_eq!(default_runtime_workers(2, 1), 1);
        assert_eq!(default_runtime_workers(8, 7), 1);
        assert_eq!(default_runtime_workers(8, 4), 4);
        assert_eq!(default_runtime_workers(1, 1), 1, "one core: one of each");
        assert_eq!(default_runtime_workers(4, 9), 1, "more jobs than cores");
        assert_eq!(default_runtime_workers(4, 0), 3, "a job slot is at least 1");
        #[derive(Parser)]
        struct Serve {
            #[command(flatten)]
            serve: ServeArgs,
        }
        let parse = |args: &[&str]| {
            Serve::try_parse_from(std::iter::once("jink").chain(args.iter().copied()))
                .unwrap()
                .serve
                .runtime_workers
        };
        assert_eq!(parse(&[]), None, "computed at start from the machine");
        assert_eq!(parse(&["--runtime-workers", "3"]), Some(3));
    }

    #[test]
    fn the_cpu_budget_leaves_a_core_by_default_and_takes_at_least_one_job() {
        assert_eq!(
            settings(&[]).cpu_workers,
            crate::cpu::CpuGate::default_slots()
        );
        assert_eq!(settings(&["--cpu-workers", "3"]).cpu_workers, 3);
        assert_eq!(settings(&["--cpu-workers", "0"]).cpu_workers, 1);
    }
}
