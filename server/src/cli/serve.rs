//! `jink serve`: configuration (flags with environment fallbacks) and start-up.

use std::net::SocketAddr;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use tracing_subscriber::EnvFilter;

use crate::app::{AppState, Settings};
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

    /// At most this many missions keep a risk map in memory (about 4 MB each); the least
    /// recently read is dropped first and rebuilt when next needed.
    #[arg(long, env = "JINK_LIVE_MAX_MAPS", default_value_t = 32)]
    pub live_max_maps: usize,

    /// Log format on stderr. Levels come from `RUST_LOG` (default `info`).
    #[arg(long, env = "JINK_LOG_FORMAT", value_enum, default_value = "text")]
    pub log_format: LogFormat,
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

/// Runs the service until a shutdown signal.
pub fn run(args: ServeArgs) -> ExitCode {
    init_logging(args.log_format);
    let rt = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("jink: cannot start the async runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    rt.block_on(async move {
        let store = match Store::open(&args.database_url).await {
            Ok(s) => s,
            Err(e) => {
                eprintln!("jink: {e}");
                return ExitCode::FAILURE;
            }
        };
        let state = AppState::new(
            store,
            Settings {
                max_body_bytes: args.max_body_bytes,
                live: crate::live::LiveConfig {
                    idle: std::time::Duration::from_secs(args.live_idle_s.max(1)),
                    max_missions: args.live_max_missions.max(1),
                    map_idle: std::time::Duration::from_secs(args.live_map_idle_s.max(1)),
                    max_maps: args.live_max_maps.max(1),
                },
            },
        );
        if state.store.backend() == crate::store::Backend::Postgres {
            // Other replicas' batches reach this replica's live state.
            tokio::spawn(crate::live::notify::listen(
                state.clone(),
                args.database_url.clone(),
            ));
        }
        match crate::app::serve(args.bind, state).await {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("jink: cannot serve on {}: {e}", args.bind);
                ExitCode::FAILURE
            }
        }
    })
}
