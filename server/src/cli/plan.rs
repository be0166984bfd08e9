//! `jink plan --mission M.json --obstacles O.json [--seed N]`: plan offline and print the
//! plan as JSON (the same document `POST /api/v1/missions/{id}/plan` answers).
//!
//! The mission file may be in any format the server accepts (native, interop 2017/2018,
//! interop 2019+; detected). The optional obstacles file is the native observation batch
//! `{"observations": [{"obstacle_id", "t", "lat", "lon", "alt_msl_m", "radius_m"}]}` with `t`
//! in Unix seconds. Without telemetry the start is the first waypoint (or the item before
//! `--current-index`) at the time of the newest observation.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use crate::api::plans::{
    ObservationUsed, PlanInputs, StrategyIn, compute, new_seed, plan_out, stack_start,
};
use crate::mission::Mission;

/// Flags of `jink plan`.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The mission file (native, interop 2018 or interop 2019 JSON).
    #[arg(long)]
    pub mission: PathBuf,
    /// Moving-obstacle observations (native batch JSON).
    #[arg(long)]
    pub obstacles: Option<PathBuf>,
    /// Seed (default: drawn and printed in the plan).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Index of the mission waypoint the aircraft flies toward (default 1).
    #[arg(long, default_value_t = 1)]
    pub current_index: usize,
    /// `bisection` (default), `insertion` or `none`.
    #[arg(long, default_value = "bisection")]
    pub strategy: String,
    /// Cruise speed, m/s.
    #[arg(long, default_value_t = 20.0)]
    pub speed_mps: f64,
    /// Turn radius, m.
    #[arg(long, default_value_t = 40.0)]
    pub turn_radius_m: f64,
    /// Deadline, ms (default none).
    #[arg(long)]
    pub deadline_ms: Option<u64>,
}

fn fail(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("jink plan: {msg}");
    ExitCode::from(1)
}

/// Runs it.
pub fn run(args: PlanArgs) -> ExitCode {
    let text = match std::fs::read_to_string(&args.mission) {
        Ok(t) => t,
        Err(e) => return fail(format!("{}: {e}", args.mission.display())),
    };
    let m = match wire::domain::read_mission_text(&text, "offline") {
        Ok(m) => Mission {
            created_at: crate::time::format_rfc3339(0.0),
            ..m
        },
        Err(e) => return fail(format!("{}: {e}", args.mission.display())),
    };
    let observations: Vec<ObservationUsed> = match &args.obstacles {
        None => Vec::new(),
        Some(p) => {
            let parsed = std::fs::read_to_string(p)
                .map_err(|e| e.to_string())
                .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
                .and_then(|v| {
                    wire::telemetry::parse_observations(v, None, 0.0).map_err(|e| match e {
                        wire::WireError::Validation(errs) => errs
                            .iter()
                            .map(|e| format!("{}: {}", e.pointer, e.detail))
                            .collect::<Vec<_>>()
                            .join("; "),
                        other => other.to_string(),
                    })
                });
            match parsed {
                Ok(rows) => rows.iter().map(ObservationUsed::from).collect(),
                Err(e) => return fail(format!("{}: {e}", p.display())),
            }
        }
    };
    let strategy = match args.strategy.as_str() {
        "bisection" => StrategyIn::Bisection,
        "insertion" => StrategyIn::Insertion,
        "none" => StrategyIn::None,
        other => {
            return fail(format!(
                "unknown strategy '{other}' (bisection, insertion, none)"
            ));
        }
    };
    let t0 = observations.iter().map(|o| o.t).fold(0.0, f64::max);
    let current_index = args.current_index.min(m.content.waypoints.len());
    let mut observations = observations;
    observations.sort_by(|a, b| {
        a.t.total_cmp(&b.t)
            .then_with(|| a.obstacle_id.cmp(&b.obstacle_id))
    });
    let inputs = PlanInputs {
        seed: args.seed.unwrap_or_else(new_seed),
        strategy,
        deadline_ms: args.deadline_ms,
        horizon_s: 60.0,
        speed_mps: args.speed_mps,
        turn_radius_m: args.turn_radius_m,
        current_index,
        stack: Vec::new(),
        start: stack_start(&m, &[], current_index, t0),
        observations,
        observation_window: None,
        observation_seq: None,
    };
    let snap = crate::api::plans::snapshot_from_observations(&m, &inputs.observations);
    let computed = match compute(&m, &inputs, &snap) {
        Ok(c) => c,
        Err(e) => return fail(e),
    };
    let out = plan_out(&m.id, "offline".into(), 1, 0, &inputs, &computed, t0);
    match serde_json::to_string_pretty(&out) {
        Ok(s) => {
            println!("{s}");
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}
