//! `jink plan --mission M.json --obstacles O.json [--seed N] [--position LAT,LON[,ALT]]
//! [--heading DEG] [--acceptance-radius-m M] [--l1-period-s S] [--format json|wpl|qgc-plan]
//! [--out FILE]`: plan offline and print (or write) the plan as JSON (the same document
//! `POST /api/v1/missions/{id}/plan` answers), a QGC WPL 110 file or a QGroundControl
//! `.plan` (cylinders as exclusion circles).
//!
//! The mission file may be in any format the server accepts (native, interop 2017/2018,
//! interop 2019+; detected). The optional obstacles file is the native observation batch
//! `{"observations": [{"obstacle_id", "t", "lat", "lon", "alt_msl_m", "radius_m"}]}` with `t`
//! in Unix seconds. Without telemetry the start is the first waypoint (or the item before
//! `--current-index`) at the time of the newest observation.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use crate::api::plan_compute::{
    Observations, PlanInputs, Start, bearing_deg, compute, new_seed, plan_out,
    snapshot_from_observations, stack_start,
};
use crate::api::plan_files::plan_file_text;
use crate::api::plans::{PlanFormat, StrategyIn};
use crate::mission::Mission;
use crate::store::{ObservationRow, TelemetryRow};

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
    /// Minimum turn radius, m (default: a coordinated turn at 30 degrees of bank at the
    /// cruise speed, as the service assumes).
    #[arg(long)]
    pub turn_radius_m: Option<f64>,
    /// The autopilot's waypoint acceptance radius, m (ArduPlane `WP_RADIUS`), 0 to 500
    /// (default 10, as the service assumes): the plan's check flies its routes so.
    #[arg(long)]
    pub acceptance_radius_m: Option<f64>,
    /// The autopilot's L1 period, s (ArduPlane `NAVL1_PERIOD`), 5 to 60 (default 17, as
    /// the service assumes): the plan's check flies its routes with this L1 distance.
    #[arg(long)]
    pub l1_period_s: Option<f64>,
    /// Deadline, ms (default none).
    #[arg(long)]
    pub deadline_ms: Option<u64>,
    /// The aircraft's position `LAT,LON[,ALT_MSL_M]` (degrees, metres), at the newest
    /// observation's time (default: the waypoint before --current-index).
    #[arg(long, value_parser = parse_position)]
    pub position: Option<(f64, f64, Option<f64>)>,
    /// The aircraft's heading, degrees true in [0, 360] (with --position; default toward
    /// the current waypoint).
    #[arg(long)]
    pub heading: Option<f64>,
    /// Output: `json` (the plan), `wpl` (QGC WPL 110) or `qgc-plan` (QGroundControl `.plan`).
    #[arg(long, default_value = "json")]
    pub format: String,
    /// Write the output to this file instead of standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `LAT,LON[,ALT]` in range.
fn parse_position(s: &str) -> Result<(f64, f64, Option<f64>), String> {
    let parts: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>().map_err(|e| format!("{p:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let (lat, lon, alt) = match parts[..] {
        [lat, lon] => (lat, lon, None),
        [lat, lon, alt] if alt.is_finite() => (lat, lon, Some(alt)),
        _ => return Err("expected LAT,LON or LAT,LON,ALT_MSL_M".into()),
    };
    let mut errs = Vec::new();
    if !wire::coords::check_lat_lon(&mut errs, "latitude", "longitude", lat, lon) {
        return Err(errs
            .iter()
            .map(|e| e.detail.clone())
            .collect::<Vec<_>>()
            .join("; "));
    }
    Ok((lat, lon, alt))
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
    let observations: Vec<ObservationRow> = match &args.obstacles {
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
                Ok(rows) => rows,
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
    let format = match args.format.as_str() {
        "json" => PlanFormat::Json,
        "wpl" | "qgc-wpl" => PlanFormat::QgcWpl,
        "qgc-plan" => PlanFormat::QgcPlan,
        other => return fail(format!("unknown format '{other}' (json, wpl, qgc-plan)")),
    };
    if let Some(h) = args.heading
        && !(h.is_finite() && (0.0..=360.0).contains(&h))
    {
        return fail(format!("--heading {h} is not in [0, 360]"));
    }
    let max_acceptance = crate::api::plans::MAX_ACCEPTANCE_RADIUS_M;
    if let Some(r) = args.acceptance_radius_m
        && !crate::api::plans::valid_acceptance_radius_m(r)
    {
        return fail(format!(
            "--acceptance-radius-m {r} is not in [0, {max_acceptance}]"
        ));
    }
    let l1_range = crate::api::plans::L1_PERIOD_RANGE_S;
    if let Some(p) = args.l1_period_s
        && !crate::api::plans::valid_l1_period_s(p)
    {
        return fail(format!(
            "--l1-period-s {p} is not in [{}, {}]",
            l1_range.start(),
            l1_range.end()
        ));
    }
    let t0 = observations.iter().map(|o| o.t_s).fold(0.0, f64::max);
    let current_index = args.current_index.min(m.content.waypoints.len());
    let mut observations = observations;
    observations.sort_by(|a, b| {
        a.t_s
            .total_cmp(&b.t_s)
            .then_with(|| a.obstacle_id.cmp(&b.obstacle_id))
    });
    let snap = snapshot_from_observations(&m, &observations);
    let from_stack = stack_start(&m, &[], current_index, t0);
    let start = match args.position {
        None => Start {
            at: TelemetryRow {
                heading_deg: args.heading.unwrap_or(from_stack.at.heading_deg),
                ..from_stack.at
            },
            ..from_stack
        },
        Some((lat, lon, alt)) => {
            let heading_deg = args.heading.unwrap_or_else(|| {
                let to = m.content.waypoints.get(current_index);
                to.map_or(from_stack.at.heading_deg, |to| {
                    bearing_deg(&m, (lat, lon), (to.lat, to.lon))
                })
            });
            Start {
                from_telemetry: true,
                at: TelemetryRow {
                    lat_deg: lat,
                    lon_deg: lon,
                    alt_msl_m: alt.unwrap_or(from_stack.at.alt_msl_m),
                    heading_deg,
                    speed_mps: Some(args.speed_mps),
                    ..from_stack.at
                },
            }
        }
    };
    let inputs = PlanInputs {
        seed: args.seed.unwrap_or_else(new_seed),
        strategy: strategy.into(),
        deadline_ms: args.deadline_ms,
        horizon_s: planner::DEFAULT_HORIZON_S,
        aircraft: planner::Aircraft {
            speed_mps: args.speed_mps,
            turn_radius_m: args
                .turn_radius_m
                .unwrap_or_else(|| crate::api::plans::default_turn_radius_m(args.speed_mps)),
        },
        turn_radius_assumed: args.turn_radius_m.is_none(),
        shown_bank_deg: None,
        acceptance_radius_m: args.acceptance_radius_m,
        l1_period_s: args.l1_period_s,
        current_index,
        stack: Vec::new(),
        start,
        observations: Observations::Given(observations),
        target_since_s: None,
        revisit: None,
        captured: None,
        watch: None,
        // No clock offline (target_since_s is None): nothing is put off.
        defer_after_s: planner::PlanParams::default().defer_after_s,
    };
    let computed = match compute(&m, &inputs, &snap, None) {
        Ok(c) => c,
        Err(e) => return fail(e),
    };
    let out = plan_out(
        &m.id,
        &"offline".to_string().into(),
        1,
        0,
        &inputs,
        &computed,
        t0,
    );
    let (text, _, _) = plan_file_text(&m, &out, format);
    match &args.out {
        None => {
            print!("{text}");
            ExitCode::SUCCESS
        }
        Some(path) => match std::fs::write(path, text) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => fail(format!("{}: {e}", path.display())),
        },
    }
}
