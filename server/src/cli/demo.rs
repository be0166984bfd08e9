//! `jink demo`: starts the service on an embedded SQLite database (a temporary file) and
//! flies a simulated aircraft against simulated judge-style moving obstacles through the
//! real HTTP API, so that a newcomer can watch jink work in a browser.
//!
//! The flight ([`fly`]) is a client of the API like a team's ground station: it uploads the
//! Webster Field 2021 interop mission (the fixture in `tests/fixtures/interop/`, embedded in
//! the binary), generates moving spheres on the judges' periodic spline tours around it
//! (`sim::scenario::with_moving_spheres`, family `spline`), and then, in real time:
//! - posts aircraft telemetry (native JSON) and obstacle snapshots (the judges' interop 2018
//!   `/api/obstacles` form, feet) at 5 Hz each, the interop rates;
//! - asks for a plan at 1 Hz (`base_revision` = the revision it flies, `current_index` =
//!   the item it flies toward, seed derived from `--seed`) and installs each new revision
//!   on the simulated autopilot (`sim::aircraft::Autopilot`, L1 guidance), skipping as many
//!   items as the aircraft reached while the plan was computed (else it would turn back).
//!
//! `--server URL` flies against a service already running (the browser test does, so that
//! it can restart that service under the page) instead of starting one.
//!
//! Everything the flight does is reproducible from `--seed` except timing: the obstacles'
//! tours and the plans' seeds are, the moments at which plans are asked are not.

use std::net::SocketAddr;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;
use serde_json::{Value, json};
use sim::aircraft::{AircraftParams, Autopilot};
use sim::mission::{ItemKind, Stack, StackItem, initial_stack};
use sim::scenario::{Family, Scenario, with_moving_spheres};

use crate::api::plans::{KindOut, PlanOut};
use crate::app::{AppState, Settings};
use crate::geodesy::LocalFrame;
use crate::mission::Mission;
use crate::store::Store;

/// The mission the demo flies: the judges' Webster Field 2021 mission, as served.
const MISSION_JSON: &str =
    include_str!("../../../tests/fixtures/interop/mission_2021_webster_field.json");
/// Feet per metre (the interop snapshot is in feet).
const FT_PER_M: f64 = 1.0 / 0.3048;
/// Simulation step, seconds.
const STEP_S: f64 = 0.1;
/// Telemetry and obstacle snapshots go out every this many steps (5 Hz).
const POST_EVERY: u64 = 2;
/// A plan is asked every this many steps (1 Hz).
const PLAN_EVERY: u64 = 10;
/// Compute budget of each plan, milliseconds.
const PLAN_DEADLINE_MS: u64 = 500;

/// Flags of `jink demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Seed of the moving obstacles' tours and of the plans (printed; the same seed flies
    /// the same obstacles).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// Port on 127.0.0.1 to serve on (0: any free port; the page's URL is printed).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,

    /// Seconds to fly (default: until the mission's last waypoint). The service keeps
    /// running after the flight until Ctrl-C.
    #[arg(long)]
    pub duration: Option<f64>,

    /// Moving obstacles to fly against (1 to 10, the rules' maximum).
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u8).range(1..=10))]
    pub obstacles: u8,

    /// Fly against a service already running at this base URL (e.g.
    /// `http://127.0.0.1:8080`) instead of starting one; exits after the flight.
    #[arg(long)]
    pub server: Option<String>,
}

/// Runs the demo.
pub fn run(args: DemoArgs) -> ExitCode {
    // Warnings only: the terminal shows the demo's own progress lines.
    super::serve::init_logging_with(super::serve::LogFormat::Text, "warn");
    let Some(rt) = super::runtime(tokio::runtime::Builder::new_multi_thread()) else {
        return ExitCode::FAILURE;
    };
    rt.block_on(async move {
        match demo(args).await {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("jink demo: {e}");
                ExitCode::FAILURE
            }
        }
    })
}

async fn demo(args: DemoArgs) -> Result<(), String> {
    let flight = FlightParams {
        seed: args.seed,
        duration_s: args.duration,
        obstacles: usize::from(args.obstacles),
    };
    if let Some(base) = &args.server {
        let base = base.trim_end_matches('/').to_string();
        return fly(&base, &flight).await.map(|_| ());
    }
    // The database lives in a temporary directory removed at exit.
    let dir = tempfile::Builder::new()
        .prefix("jink-demo-")
        .tempdir()
        .map_err(|e| format!("cannot create a temporary directory: {e}"))?;
    let url = format!("sqlite://{}", dir.path().join("demo.sqlite").display());
    let store = Store::open(&url).await.map_err(|e| e.to_string())?;
    let state = AppState::new(store, Settings::default());
    let addr = SocketAddr::from(([127, 0, 0, 1], args.port));
    let listener = tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|e| format!("cannot listen on {addr}: {e} (choose another with --port)"))?;
    let local = listener.local_addr().map_err(|e| e.to_string())?;
    let server = tokio::spawn(crate::app::serve_on(listener, state));
    let base = format!("http://{local}");
    let summary = fly(&base, &flight).await?;
    println!(
        "jink demo: flight finished ({summary}); the page stays up at {base}/missions/{}: press Ctrl-C to stop",
        summary.mission_id
    );
    match server.await {
        Ok(r) => r.map_err(|e| e.to_string()),
        Err(e) => Err(e.to_string()),
    }
}

/// What to fly.
#[derive(Debug, Clone)]
pub struct FlightParams {
    /// Seed of the obstacles and plans.
    pub seed: u64,
    /// Seconds to fly (None: until the last waypoint, at most the scenario's time limit).
    pub duration_s: Option<f64>,
    /// Moving obstacles.
    pub obstacles: usize,
}

/// How a flight went.
#[derive(Debug, Clone)]
pub struct FlightSummary {
    /// The mission flown.
    pub mission_id: String,
    /// Seconds flown.
    pub flown_s: f64,
    /// Newest plan revision installed.
    pub revision: i64,
    /// Mission waypoints passed / total.
    pub waypoints: (usize, usize),
    /// Requests that failed (the service was unreachable or refused).
    pub failed_requests: u64,
}

impl std::fmt::Display for FlightSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.0} s flown, waypoint {}/{}, plan revision {}, {} failed requests",
            self.flown_s, self.waypoints.0, self.waypoints.1, self.revision, self.failed_requests
        )
    }
}

/// The demo's scenario on `mission` (as stored): moving spheres on spline tours from the
/// seed, the aircraft starting 200 m south of the first waypoint at its altitude.
pub fn scenario(mission: &Mission, seed: u64, obstacles: usize) -> Scenario {
    let pm = mission.to_planner();
    let first = pm
        .waypoints
        .first()
        .map_or([0.0, 0.0, 100.0], |w| [w.p_m[0], w.p_m[1] - 200.0, w.alt_m]);
    with_moving_spheres(pm, first, Family::Spline, seed, obstacles, 20.0)
}

/// The interop 2018 `/api/obstacles` snapshot of the scenario's spheres at mission time
/// `t_s` (feet, as the judges' server sent it).
pub fn obstacle_snapshot(scenario: &Scenario, frame: &LocalFrame, t_s: f64) -> Value {
    let moving: Vec<Value> = scenario
        .spheres
        .iter()
        .map(|s| {
            let p = s.track.at(t_s);
            let (lat, lon) = frame.to_geodetic([p[0], p[1]]);
            json!({
                "latitude": lat,
                "longitude": lon,
                "altitude_msl": p[2] * FT_PER_M,
                "sphere_radius": s.radius_m * FT_PER_M,
            })
        })
        .collect();
    json!({"moving_obstacles": moving, "stationary_obstacles": []})
}

/// Native aircraft telemetry of the simulated aircraft's `state` at Unix time `t_s`
/// (the simulator's heading, counter-clockwise from east, as a compass heading).
pub fn telemetry_json(state: &sim::aircraft::AircraftState, frame: &LocalFrame, t_s: f64) -> Value {
    let (lat, lon) = frame.to_geodetic([state.p_m[0], state.p_m[1]]);
    let heading = (90.0 - state.heading_rad.to_degrees()).rem_euclid(360.0);
    json!({"t": t_s, "lat": lat, "lon": lon, "alt_msl_m": state.p_m[2],
        "heading_deg": heading, "speed_mps": state.speed_mps})
}

/// The autopilot's stack for a plan's answer (ENU metres in the mission's frame).
pub fn stack_from_plan(plan: &PlanOut, frame: &LocalFrame) -> Stack {
    Stack {
        items: plan
            .waypoints
            .iter()
            .map(|w| StackItem {
                p_m: frame.to_enu(w.lat, w.lon),
                alt_m: w.alt_msl_m,
                kind: match w.kind {
                    KindOut::Mission => ItemKind::Mission,
                    KindOut::Avoid => ItemKind::Avoid,
                    KindOut::Search => ItemKind::Search,
                },
                mission_index: w.mission_index,
            })
            .collect(),
        current: plan.current_index.min(plan.waypoints.len()),
    }
}

/// Progress shown while flying: a line every few seconds.
struct Progress {
    started: Instant,
    last: Option<Instant>,
}

impl Progress {
    fn show(&mut self, line: impl FnOnce() -> String) {
        let now = Instant::now();
        if self
            .last
            .is_none_or(|l| now.duration_since(l) >= Duration::from_secs(5))
        {
            self.last = Some(now);
            println!(
                "jink demo: [{:>4.0} s] {}",
                now.duration_since(self.started).as_secs_f64(),
                line()
            );
        }
    }
}

/// Flies the demo against the service at `base` (e.g. `http://127.0.0.1:8080`) in real
/// time and prints the page's URL and progress.
///
/// # Errors
/// When the mission cannot be uploaded (the service is not there).
pub async fn fly(base: &str, p: &FlightParams) -> Result<FlightSummary, String> {
    let client = reqwest::Client::builder()
        .timeout(Duration::from_secs(10))
        .build()
        .map_err(|e| e.to_string())?;
    let resp = client
        .post(format!("{base}/api/v1/missions"))
        .header("content-type", "application/json")
        .body(MISSION_JSON)
        .send()
        .await
        .map_err(|e| format!("cannot upload the mission to {base}: {e}"))?;
    if !resp.status().is_success() {
        return Err(format!(
            "the mission upload answered {}: {}",
            resp.status(),
            resp.text().await.unwrap_or_default()
        ));
    }
    let mission: Mission = resp.json().await.map_err(|e| e.to_string())?;
    let id = mission.id.to_string();
    let frame = mission.frame();
    let scenario = scenario(&mission, p.seed, p.obstacles);
    let params = AircraftParams::default();
    let mut stack = initial_stack(&scenario.mission);
    let toward = stack.target().map_or([0.0, 0.0], |t| t.p_m);
    let mut ap = Autopilot::new(params, scenario.start_m, toward);
    let duration_s = p.duration_s.unwrap_or(scenario.duration_s).max(0.0);
    println!("jink demo: the live page is {base}/missions/{id}");
    println!(
        "jink demo: flying mission {id} (Webster Field 2021) against {} moving obstacles on spline tours, seed {}, for {}",
        scenario.spheres.len(),
        p.seed,
        p.duration_s
            .map_or("the whole mission".to_string(), |d| format!("{d} s"))
    );

    let t0_s = crate::time::now_s();
    let started = Instant::now();
    let mut progress = Progress {
        started,
        last: None,
    };
    let failed = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let (plan_tx, mut plan_rx) = tokio::sync::mpsc::channel::<Result<PlanOut, String>>(2);
    // The stack item the aircraft flew toward when the plan in flight was asked for.
    let mut plan_in_flight: Option<usize> = None;
    let mut revision = 0_i64;
    let mut last_plan = String::from("no plan yet");
    let mut step = 0_u64;
    let mut tick = tokio::time::interval(Duration::from_secs_f64(STEP_S));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let total_wp = scenario.mission.waypoints.len();
    loop {
        tick.tick().await;
        // Catch up with the wall clock: the simulation runs in real time.
        let elapsed = started.elapsed().as_secs_f64();
        while (step as f64) * STEP_S < elapsed && stack.target().is_some() {
            ap.step(&mut stack, STEP_S);
            step += 1;
            let t_s = t0_s + step as f64 * STEP_S;
            if step.is_multiple_of(POST_EVERY) {
                let telemetry = telemetry_json(&ap.state, &frame, t_s);
                let snapshot = obstacle_snapshot(&scenario, &frame, ap.state.t_s);
                post_detached(
                    &client,
                    format!("{base}/api/v1/missions/{id}/telemetry"),
                    telemetry,
                    &failed,
                );
                post_detached(
                    &client,
                    format!("{base}/api/v1/missions/{id}/obstacles?time={t_s}"),
                    snapshot,
                    &failed,
                );
            }
            if step.is_multiple_of(PLAN_EVERY) && plan_in_flight.is_none() {
                plan_in_flight = Some(stack.current);
                let body = json!({
                    "seed": p.seed.wrapping_mul(1_000_003).wrapping_add(step / PLAN_EVERY),
                    "deadline_ms": PLAN_DEADLINE_MS,
                    "base_revision": revision,
                    "current_index": stack.current,
                    "aircraft": {"speed_mps": params.speed_mps, "turn_radius_m": params.min_turn_radius_m()},
                });
                let (client, url, tx) = (
                    client.clone(),
                    format!("{base}/api/v1/missions/{id}/plan"),
                    plan_tx.clone(),
                );
                tokio::spawn(async move {
                    let _ = tx.send(request_plan(&client, &url, &body).await).await;
                });
            }
        }
        while let Ok(answer) = plan_rx.try_recv() {
            let asked_at = plan_in_flight.take();
            match answer {
                Ok(plan) if plan.revision > revision => {
                    revision = plan.revision;
                    last_plan = format!(
                        "plan revision {} ({}, {:.0} ms, {} avoid waypoints)",
                        plan.revision, plan.outcome, plan.compute_ms, plan.added
                    );
                    let mut next = stack_from_plan(&plan, &frame);
                    // Items the aircraft reached while the plan was computed are behind it:
                    // skip as many in the new stack rather than turn back for them.
                    let reached = stack
                        .current
                        .saturating_sub(asked_at.unwrap_or(stack.current));
                    next.current = (next.current + reached).min(next.items.len());
                    ap.replace_stack(&mut stack, next);
                }
                Ok(_) => {}
                Err(e) => {
                    failed.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    last_plan = format!("plan failed: {e}");
                }
            }
        }
        let passed = stack.items[..stack.current.min(stack.items.len())]
            .iter()
            .filter(|i| i.mission_index.is_some())
            .count();
        progress.show(|| {
            format!(
                "waypoint {passed}/{total_wp}, {last_plan}, {} failed requests",
                failed.load(std::sync::atomic::Ordering::Relaxed)
            )
        });
        if stack.target().is_none() || elapsed >= duration_s {
            return Ok(FlightSummary {
                mission_id: id,
                flown_s: elapsed,
                revision,
                waypoints: (passed, total_wp),
                failed_requests: failed.load(std::sync::atomic::Ordering::Relaxed),
            });
        }
    }
}

/// Posts `body` without waiting for the answer; failures are counted.
fn post_detached(
    client: &reqwest::Client,
    url: String,
    body: Value,
    failed: &std::sync::Arc<std::sync::atomic::AtomicU64>,
) {
    let (client, failed) = (client.clone(), failed.clone());
    tokio::spawn(async move {
        let ok = client
            .post(url)
            .json(&body)
            .send()
            .await
            .is_ok_and(|r| r.status().is_success());
        if !ok {
            failed.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    });
}

async fn request_plan(
    client: &reqwest::Client,
    url: &str,
    body: &Value,
) -> Result<PlanOut, String> {
    let r = client
        .post(url)
        .json(body)
        .send()
        .await
        .map_err(|e| e.to_string())?;
    let status = r.status();
    if !status.is_success() {
        return Err(format!("{status}: {}", r.text().await.unwrap_or_default()));
    }
    r.json::<PlanOut>().await.map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn webster() -> Mission {
        wire::domain::read_mission_text(MISSION_JSON, "demo").expect("the embedded fixture")
    }

    #[test]
    fn the_obstacle_snapshot_is_the_judges_form_in_feet_at_the_spheres_true_positions() {
        let m = webster();
        let s = scenario(&m, 7, 4);
        assert_eq!(s.spheres.len(), 4);
        let frame = m.frame();
        let snap = obstacle_snapshot(&s, &frame, 12.5);
        let moving = snap["moving_obstacles"].as_array().unwrap();
        assert_eq!(moving.len(), 4);
        let truth = s.spheres[2].track.at(12.5);
        let got = frame.to_enu(
            moving[2]["latitude"].as_f64().unwrap(),
            moving[2]["longitude"].as_f64().unwrap(),
        );
        assert!((got[0] - truth[0]).abs() < 0.01 && (got[1] - truth[1]).abs() < 0.01);
        let alt_ft = moving[2]["altitude_msl"].as_f64().unwrap();
        assert!((alt_ft * 0.3048 - truth[2]).abs() < 1e-9);
        let r_ft = moving[2]["sphere_radius"].as_f64().unwrap();
        assert!((r_ft * 0.3048 - s.spheres[2].radius_m).abs() < 1e-9);
    }

    #[test]
    fn the_same_seed_flies_the_same_obstacles_and_another_seed_others() {
        let m = webster();
        let a = scenario(&m, 3, 6);
        let b = scenario(&m, 3, 6);
        let c = scenario(&m, 4, 6);
        assert_eq!(a.spheres, b.spheres);
        assert_ne!(a.spheres, c.spheres);
    }

    #[test]
    fn a_plans_stack_keeps_its_kinds_indices_and_current_item() {
        let m = webster();
        let frame = m.frame();
        let w = &m.content.waypoints;
        let plan: PlanOut = serde_json::from_value(json!({
            "plan_id": "p", "mission_id": "demo", "revision": 3, "base_revision": 2,
            "outcome": "exact", "seed": 1, "current_index": 1,
            "waypoints": [
                {"lat": w[0].lat, "lon": w[0].lon, "alt_msl_m": 50.0, "kind": "mission", "mission_index": 0},
                {"lat": w[0].lat + 0.001, "lon": w[0].lon, "alt_msl_m": 55.0, "kind": "avoid"},
                {"lat": w[1].lat, "lon": w[1].lon, "alt_msl_m": 60.0, "kind": "mission", "mission_index": 1}],
            "diff": {"first_changed": 1, "remove": 0, "insert": []},
            "risk": 0.0, "base_risk": 0.0, "exposure_m": 0.0, "length_m": 1.0, "added": 1,
            "turn_violations": [], "compute_ms": 1.0,
            "dynamic_risk": {"source": "none", "obstacles": 0},
            "start": {"source": "stack", "t": 0.0, "lat": 0.0, "lon": 0.0, "alt_msl_m": 0.0, "heading_deg": 0.0, "speed_mps": 0.0},
            "created_at": "2026-01-01T00:00:00Z"
        }))
        .unwrap();
        let s = stack_from_plan(&plan, &frame);
        assert_eq!(s.current, 1);
        assert_eq!(s.items.len(), 3);
        assert_eq!(s.items[1].kind, ItemKind::Avoid);
        assert_eq!(s.items[2].mission_index, Some(1));
        assert!((s.items[1].p_m[1] - s.items[0].p_m[1] - 111.0).abs() < 1.0);
        assert_eq!(s.items[1].alt_m, 55.0);
    }
}
