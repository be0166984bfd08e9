//! `jink interop status` and `jink interop pull`, and the upstream-link flags they share
//! with `jink serve` (each with an environment fallback).

use std::process::ExitCode;
use std::time::Duration;

use clap::{Args, Subcommand};

use crate::interop::link::{ApiFlag, LinkConfig, Upstream, store_mission};
use crate::store::Store;

/// The judges' server and how to talk to it.
#[derive(Debug, Clone, Args)]
pub struct LinkArgs {
    /// Base URL of the judges' interop server, e.g. `http://10.10.130.10:80`. With it,
    /// `jink serve` links upstream: it mirrors the mission, polls moving obstacles and
    /// forwards accepted aircraft telemetry (plain HTTP, as the judges serve it).
    #[arg(long, env = "JINK_INTEROP_URL")]
    pub interop_url: Option<String>,

    /// Interop user name (the team's login at the judges' server).
    #[arg(long, env = "JINK_INTEROP_USERNAME", requires = "interop_url")]
    pub interop_username: Option<String>,

    /// Interop password.
    #[arg(
        long,
        env = "JINK_INTEROP_PASSWORD",
        hide_env_values = true,
        requires = "interop_url"
    )]
    pub interop_password: Option<String>,

    /// The upstream mission id (an integer, as the judges announce it).
    #[arg(long, env = "JINK_INTEROP_MISSION", requires = "interop_url")]
    pub interop_mission: Option<i64>,

    /// Obstacle polls per second (2017/2018 API; the 2019+ API has no moving obstacles);
    /// 0 turns polling off.
    #[arg(long, env = "JINK_INTEROP_OBSTACLE_HZ", default_value_t = 5.0)]
    pub interop_obstacle_hz: f64,

    /// Most telemetry samples forwarded per second (a backlog after an outage drains at
    /// this rate, never as a burst).
    #[arg(long, env = "JINK_INTEROP_TELEMETRY_HZ", default_value_t = 10.0)]
    pub interop_telemetry_hz: f64,

    /// Seconds between mission pulls (a changed mission is stored as a new jink mission).
    #[arg(long, env = "JINK_INTEROP_MISSION_POLL_S", default_value_t = 10.0)]
    pub interop_mission_poll_s: f64,

    /// Longest wait for one answer of the judges' server, seconds.
    #[arg(long, env = "JINK_INTEROP_TIMEOUT_S", default_value_t = 5.0)]
    pub interop_timeout_s: f64,

    /// The judges' API generation: `auto` (learned from the mission), `2018` or `2019`.
    #[arg(long, env = "JINK_INTEROP_API", value_enum, default_value = "auto")]
    pub interop_api: ApiFlag,
}

fn secs(s: f64) -> Duration {
    Duration::try_from_secs_f64(s.max(0.01)).unwrap_or(Duration::from_secs(5))
}

impl LinkArgs {
    /// The link's settings; `Ok(None)` without `--interop-url`.
    ///
    /// # Errors
    /// A message naming the missing flag.
    pub fn config(&self) -> Result<Option<LinkConfig>, String> {
        let Some(url) = self.interop_url.clone() else {
            return Ok(None);
        };
        let need = |v: &Option<String>, flag: &str| {
            v.clone()
                .ok_or_else(|| format!("--interop-url needs {flag} too"))
        };
        Ok(Some(LinkConfig {
            url,
            username: need(&self.interop_username, "--interop-username")?,
            password: need(&self.interop_password, "--interop-password")?,
            mission: self
                .interop_mission
                .ok_or("--interop-url needs --interop-mission too")?,
            obstacle_hz: self.interop_obstacle_hz,
            telemetry_hz: self.interop_telemetry_hz,
            mission_poll: secs(self.interop_mission_poll_s),
            timeout: secs(self.interop_timeout_s),
            api: self.interop_api,
        }))
    }
}

/// `jink interop ...`.
#[derive(Debug, Args)]
pub struct InteropArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: InteropCommand,
}

/// The interop subcommands.
#[derive(Debug, Subcommand)]
pub enum InteropCommand {
    /// Log in to the judges' server and report what the link sees (login, API generation,
    /// mission, obstacles) as JSON, with the local forwarding queue when `--database-url`
    /// is given. Exit status 1 when the server cannot be used.
    Status {
        /// The judges' server.
        #[command(flatten)]
        link: LinkArgs,
        /// A jink database whose linked missions and forwarding queue to report.
        #[arg(long, env = "JINK_DATABASE_URL")]
        database_url: Option<String>,
    },
    /// Fetch the mission from the judges' server once and store it (unless the stored one
    /// is the same); prints the jink mission id on stdout.
    Pull {
        /// The judges' server.
        #[command(flatten)]
        link: LinkArgs,
        /// The database to store it in.
        #[arg(
            long,
            env = "JINK_DATABASE_URL",
            default_value = "sqlite://jink.sqlite"
        )]
        database_url: String,
    },
}

/// Runs `jink interop ...`.
pub fn run(args: InteropArgs) -> ExitCode {
    super::serve::init_logging_with(super::serve::LogFormat::Text, "warn");
    let Some(rt) = super::runtime(tokio::runtime::Builder::new_current_thread()) else {
        return ExitCode::FAILURE;
    };
    rt.block_on(async move {
        match args.command {
            InteropCommand::Status { link, database_url } => status(link, database_url).await,
            InteropCommand::Pull { link, database_url } => pull(link, database_url).await,
        }
    })
}

fn upstream(link: &LinkArgs) -> Result<Upstream, String> {
    let cfg = link
        .config()?
        .ok_or("give the judges' server with --interop-url (or JINK_INTEROP_URL)")?;
    Upstream::new(cfg)
}

async fn status(link: LinkArgs, database_url: Option<String>) -> ExitCode {
    let up = match upstream(&link) {
        Ok(u) => u,
        Err(e) => {
            eprintln!("jink: {e}");
            return ExitCode::from(2);
        }
    };
    let mut ok = true;
    let mut out = serde_json::json!({ "url": up.cfg.url, "upstream_mission": up.cfg.mission });
    match up.login().await {
        Ok(()) => out["login"] = "ok".into(),
        Err(e) => {
            ok = false;
            out["login"] = e.to_string().into();
        }
    }
    if ok {
        match up.fetch_mission().await {
            Ok((format, m, _home)) => {
                out["api"] = (if format == crate::mission::SourceFormat::Interop2018 {
                    "2018"
                } else {
                    "2019"
                })
                .into();
                out["mission"] = serde_json::json!({
                    "fly_zones": m.fly_zones.len(),
                    "waypoints": m.waypoints.len(),
                    "search_grid_points": m.search_grid.len(),
                    "stationary_obstacles": m.stationary_obstacles.len(),
                    "moving_obstacles": m.moving_obstacles.len(),
                });
                if format == crate::mission::SourceFormat::Interop2018 {
                    out["obstacles"] = match up.fetch_obstacles().await {
                        Ok(v) => serde_json::json!({
                            "moving": v["moving_obstacles"].as_array().map_or(0, Vec::len),
                            "stationary": v["stationary_obstacles"].as_array().map_or(0, Vec::len),
                        }),
                        Err(e) => e.to_string().into(),
                    };
                }
            }
            Err(e) => {
                ok = false;
                out["mission"] = e.to_string().into();
            }
        }
    }
    if let Some(url) = database_url {
        out["local"] = match local(&url, up.cfg.mission).await {
            Ok(v) => v,
            Err(e) => e.into(),
        };
    }
    println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// The local side: the linked mission and the forwarding queue's depth.
async fn local(url: &str, upstream_mission: i64) -> Result<serde_json::Value, String> {
    let store = Store::open(url).await.map_err(|e| e.to_string())?;
    let linked = store
        .linked_mission(upstream_mission)
        .await
        .map_err(|e| e.to_string())?;
    let depth = store.pending_count().await.map_err(|e| e.to_string())?;
    store.close().await;
    Ok(serde_json::json!({
        "linked_mission": linked.map(|m| m.to_string()),
        "queue_depth": depth,
    }))
}

async fn pull(link: LinkArgs, database_url: String) -> ExitCode {
    let up = match upstream(&link) {
        Ok(u) => u,
        Err(e) => {
            eprintln!("jink: {e}");
            return ExitCode::from(2);
        }
    };
    let store = match Store::open(&database_url).await {
        Ok(s) => s,
        Err(e) => {
            eprintln!("jink: {e}");
            return ExitCode::FAILURE;
        }
    };
    let writer: std::sync::Arc<str> = std::sync::Arc::from("interop");
    let result = crate::auth::WRITER
        .scope(writer, async {
            let (format, content, home) = up.fetch_mission().await?;
            store_mission(&store, &up, format, content, home).await
        })
        .await;
    store.close().await;
    match result {
        Ok((id, stored)) => {
            eprintln!(
                "jink: upstream mission {} {} jink mission {id}",
                up.cfg.mission,
                if stored {
                    "stored as"
                } else {
                    "unchanged; it is"
                }
            );
            println!("{id}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("jink: {e}");
            ExitCode::FAILURE
        }
    }
}
