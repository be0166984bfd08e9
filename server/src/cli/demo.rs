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
//!   on the simulated autopilot (`sim::aircraft::Autopilot`, L1 guidance), past the last
//!   item the aircraft reached while the plan was computed when the new stack holds it
//!   ([`resume_index`]; else it would turn back).
//!
//! `--server URL` flies against a service already running (the browser test does, so that
//! it can restart that service under the page) instead of starting one.
//!
//! Each flight is scored the judges' way at its end (`sim::scoring::judge` on the aircraft's
//! true track at 5 Hz: spheres and cylinders hit, waypoints captured, path ratio, time out of
//! the fly zone). `--flights N` flies seeds `--seed` .. `--seed + N - 1` side by side
//! (`--parallel` at a time) against the one service and prints a table; `--compare
//! oracle,mc-auto` flies the simulator's strategies in process on the same scenarios (the
//! scenario of a seed is `jink simulate --mission <the fixture> --family spline`'s), so that
//! the real-time flight over HTTP is set beside perfect knowledge.
//!
//! Everything the flight does is reproducible from `--seed` except timing: the obstacles'
//! tours and the plans' seeds are, the moments at which plans are asked are not.

use std::net::SocketAddr;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;
use serde_json::{Value, json};
use sim::aircraft::{AircraftParams, Autopilot};
use sim::mission::{ItemKind, Stack, StackItem, initial_stack, path_ratio};
use sim::scenario::{Family, Scenario, with_moving_spheres};
use sim::strategy::StrategyKind;

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

    /// Flights to fly, seeds `--seed`, `--seed` + 1, ...: more than one fly side by side
    /// against the one service, and a table of their judged scores is printed.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub flights: u64,

    /// At most this many flights in the air at once.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..=100))]
    pub parallel: u64,

    /// The simulated aircraft's speed, m/s (also sent to the service, unless `--bare`).
    #[arg(long, default_value_t = 20.0)]
    pub aircraft_speed: f64,

    /// The simulated aircraft's largest bank, degrees (its turn radius follows; sent to the
    /// service, unless `--bare`).
    #[arg(long, default_value_t = 35.0)]
    pub max_bank_deg: f64,

    /// Tell the service the least a client can: telemetry without a speed, plan requests
    /// without `aircraft` (as a client speaking only the interop forms).
    #[arg(long)]
    pub bare: bool,

    /// Also fly these `jink simulate` strategies in process on the same scenarios, for
    /// comparison (e.g. `oracle,mc-auto`); they get the flights' obstacle feed (exact
    /// positions at 5 Hz) and fly the simulator's clock (stopped while planning).
    #[arg(long, value_delimiter = ',')]
    pub compare: Vec<String>,

    /// Exit after the flights instead of keeping the service and its page up.
    #[arg(long)]
    pub exit: bool,
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
    super::check_ranges(&[
        super::aircraft_speed_flag(args.aircraft_speed),
        super::max_bank_flag(args.max_bank_deg),
    ])?;
    let mut compare = Vec::new();
    for name in &args.compare {
        match StrategyKind::parse(name) {
            Some(k) if StrategyKind::ALL.contains(&k) => compare.push(k),
            _ => return Err(format!("--compare: unknown in-process strategy {name:?}")),
        }
    }
    let flight = FlightParams {
        seed: args.seed,
        duration_s: args.duration,
        obstacles: usize::from(args.obstacles),
        aircraft: AircraftParams::default()
            .speed_mps(args.aircraft_speed)
            .max_bank_deg(args.max_bank_deg),
        bare: args.bare,
        quiet: args.flights > 1,
    };
    let seeds: Vec<u64> = (args.seed..args.seed.saturating_add(args.flights)).collect();
    let parallel = usize::try_from(args.parallel).unwrap_or(1);
    if let Some(base) = &args.server {
        let base = base.trim_end_matches('/').to_string();
        return fly_all(&base, &flight, &seeds, parallel, &compare)
            .await
            .map(drop);
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
    let flown = fly_all(&base, &flight, &seeds, parallel, &compare).await?;
    if args.exit {
        return Ok(());
    }
    let page = match flown.as_slice() {
        [(_, one)] => format!("{base}/missions/{}", one.mission_id),
        _ => format!("{base}/"),
    };
    println!("jink demo: the page stays up at {page}: press Ctrl-C to stop");
    match server.await {
        Ok(r) => r.map_err(|e| e.to_string()),
        Err(e) => Err(e.to_string()),
    }
}

/// Flies `seeds` (one flight each, at most `parallel` at once) against the service at
/// `base`, prints each flight's judged score, then (several flights, or `compare`) a table
/// with the in-process strategies of `compare` flown on the same scenarios.
async fn fly_all(
    base: &str,
    flight: &FlightParams,
    seeds: &[u64],
    parallel: usize,
    compare: &[StrategyKind],
) -> Result<Vec<(u64, FlightSummary)>, String> {
    let started = Instant::now();
    let gate = std::sync::Arc::new(tokio::sync::Semaphore::new(parallel.max(1)));
    let done = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let mut tasks = tokio::task::JoinSet::new();
    for &seed in seeds {
        let (gate, done, base) = (gate.clone(), done.clone(), base.to_string());
        let p = FlightParams {
            seed,
            ..flight.clone()
        };
        tasks.spawn(async move {
            let _slot = gate.acquire_owned().await;
            let r = fly(&base, &p).await;
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            (seed, r)
        });
    }
    let mut flown: Vec<(u64, FlightSummary)> = Vec::new();
    let mut errors = Vec::new();
    let mut tick = tokio::time::interval(Duration::from_secs(10));
    tick.tick().await;
    loop {
        tokio::select! {
            joined = tasks.join_next() => match joined {
                None => break,
                Some(Ok((seed, Ok(s)))) => {
                    println!("jink demo: seed {seed}, mission {}: {s}", s.mission_id);
                    flown.push((seed, s));
                }
                Some(Ok((seed, Err(e)))) => errors.push(format!("seed {seed}: {e}")),
                Some(Err(e)) => errors.push(e.to_string()),
            },
            _ = tick.tick(), if seeds.len() > 1 => println!(
                "jink demo: [{:>4.0} s] {} of {} flights done",
                started.elapsed().as_secs_f64(),
                done.load(std::sync::atomic::Ordering::Relaxed),
                seeds.len()
            ),
        }
    }
    if !errors.is_empty() {
        return Err(errors.join("; "));
    }
    flown.sort_by_key(|(seed, _)| *seed);
    if seeds.len() == 1 && compare.is_empty() {
        return Ok(flown);
    }
    let client = if flight.bare {
        "jink over HTTP, real time, bare client"
    } else {
        "jink over HTTP, real time"
    };
    let mut rows = vec![(
        client.to_string(),
        flown.iter().map(|(seed, s)| (*seed, s.score)).collect(),
    )];
    for &k in compare {
        let (p, seeds) = (flight.clone(), seeds.to_vec());
        let scores = tokio::task::spawn_blocking(move || {
            let mission = fixture_mission();
            // The flights' own obstacle feed: every sphere's exact position at 5 Hz.
            let cfg = sim::run::RunConfig {
                aircraft: p.aircraft,
                telemetry: judges_feed(),
                record_track: false,
                ..sim::run::RunConfig::default()
            };
            seeds
                .iter()
                .map(|&seed| {
                    let mut sc = scenario(&mission, seed, p.obstacles, p.aircraft.speed_mps);
                    // As long as the flights over HTTP flew.
                    sc.duration_s = p.duration_s.map_or(sc.duration_s, |d| d.min(sc.duration_s));
                    let r = sim::run::run(&sc, k, &cfg);
                    (seed, FlightScore::of_run(&r.metrics))
                })
                .collect::<Vec<_>>()
        })
        .await
        .map_err(|e| e.to_string())?;
        rows.push((
            format!("`{}` (in process, same scenarios)", k.name()),
            scores,
        ));
    }
    println!("{}", score_table(&rows));
    Ok(flown)
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
    /// The simulated aircraft.
    pub aircraft: AircraftParams,
    /// Send no speed and no `aircraft` (the interop forms have neither).
    pub bare: bool,
    /// No progress lines (several flights at once).
    pub quiet: bool,
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
    /// Requests that failed (the service was unreachable or refused): a reason (`plan
    /// 409`, `obstacles: timed out`, ...) and how often, in the reasons' order.
    pub failures: Vec<(String, u64)>,
    /// The flight scored as the judges score it.
    pub score: FlightScore,
    /// Plan requests' round trips, milliseconds: p50 and p95.
    pub plan_ms: (f64, f64),
}

impl std::fmt::Display for FlightSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.0} s flown, waypoint {}/{}, plan revision {}, {} failed requests{}, plan round trip p50 {:.1} ms p95 {:.1} ms; judged: {}",
            self.flown_s,
            self.waypoints.0,
            self.waypoints.1,
            self.revision,
            self.failed_requests(),
            failure_reasons(&self.failures),
            self.plan_ms.0,
            self.plan_ms.1,
            self.score
        )
    }
}

impl FlightSummary {
    /// How many requests failed, whatever the reason.
    pub fn failed_requests(&self) -> u64 {
        self.failures.iter().map(|(_, n)| n).sum()
    }
}

/// A flight scored the judges' way (`sim::scoring::judge` on the true track at 5 Hz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightScore {
    /// Moving spheres entered.
    pub sphere_hits: usize,
    /// Cylinders entered.
    pub cylinder_hits: usize,
    /// Mission waypoints captured (within the judges' 100 ft).
    pub waypoints_captured: usize,
    /// Mission waypoints.
    pub waypoints: usize,
    /// Path flown over the straight route through the waypoints.
    pub path_ratio: f64,
    /// Whether the flight flew its whole stack (not cut by `--duration` or the time
    /// limit): its path ratio is shown only then, a cut flight's says nothing.
    pub finished: bool,
    /// Closest approach to any obstacle's surface, metres (negative: inside).
    pub min_clearance_m: f64,
    /// Seconds outside the fly zone.
    pub out_of_zone_s: f64,
    /// Seconds flown.
    pub time_s: f64,
}

impl FlightScore {
    /// Scores a flight of `scenario`: the aircraft's true positions `track` (time, ENU and
    /// MSL), the length of its path `path_m` and whether it flew its whole stack.
    pub fn judge(
        scenario: &Scenario,
        track: &[(f64, [f64; 3])],
        path_m: f64,
        finished: bool,
    ) -> Self {
        let m = &scenario.mission;
        let jr = sim::scoring::judge(track, scenario, m);
        Self {
            sphere_hits: jr.sphere_hits.iter().filter(|h| **h).count(),
            cylinder_hits: jr.cylinder_hits.iter().filter(|h| **h).count(),
            waypoints_captured: jr.waypoints_captured.iter().filter(|h| **h).count(),
            waypoints: jr.waypoints_captured.len(),
            path_ratio: path_ratio(m, scenario.start_m, path_m),
            finished,
            min_clearance_m: jr.min_clearance_m,
            out_of_zone_s: jr.boundary_violation_s,
            time_s: track.last().map_or(0.0, |p| p.0),
        }
    }

    /// The same figures of an in-process simulator run.
    pub fn of_run(m: &sim::run::RunMetrics) -> Self {
        Self {
            sphere_hits: m.spheres_hit,
            cylinder_hits: m.cylinders_hit,
            waypoints_captured: m.waypoints_captured,
            waypoints: m.waypoints,
            path_ratio: m.path_ratio,
            finished: m.completed,
            min_clearance_m: m.min_clearance_m,
            out_of_zone_s: m.boundary_violation_s,
            time_s: m.mission_time_s,
        }
    }
}

impl std::fmt::Display for FlightScore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} spheres and {} cylinders hit, {}/{} waypoints captured, path ratio {}, {:.1} s out of the fly zone, closest {:.1} m",
            self.sphere_hits,
            self.cylinder_hits,
            self.waypoints_captured,
            self.waypoints,
            if self.finished {
                format!("{:.3}", self.path_ratio)
            } else {
                "- (not finished)".to_string()
            },
            self.out_of_zone_s,
            self.min_clearance_m
        )
    }
}

/// A markdown table of judged flights, one row per client: flights, clean ones, sphere
/// hits (with the seeds that took them), cylinder hits, waypoints, path ratio mean / p50
/// (of the flights that finished; `-` when none did), mean time, time out of the fly zone.
pub fn score_table(rows: &[(String, Vec<(u64, FlightScore)>)]) -> String {
    let mut out = String::from(
        "| client | flights | clean | sphere hits (seeds) | cylinder hits | waypoints | path ratio mean / p50 | mean time (s) | out of the fly zone (s a flight) |\n|---|---:|---:|---|---:|---:|---|---:|---:|\n",
    );
    for (name, flights) in rows {
        let n = flights.len().max(1) as f64;
        let clean = flights
            .iter()
            .filter(|(_, s)| s.sphere_hits + s.cylinder_hits == 0)
            .count();
        let hits: usize = flights.iter().map(|(_, s)| s.sphere_hits).sum();
        let hit_seeds: Vec<String> = flights
            .iter()
            .filter(|(_, s)| s.sphere_hits > 0)
            .map(|(seed, _)| seed.to_string())
            .collect();
        let ratios: Vec<f64> = flights
            .iter()
            .filter(|(_, s)| s.finished)
            .map(|(_, s)| s.path_ratio)
            .collect();
        let ratio = if ratios.is_empty() {
            "-".to_string()
        } else {
            format!(
                "{:.3} / {:.3}",
                ratios.iter().sum::<f64>() / ratios.len() as f64,
                sim::run::percentile(&ratios, 0.5)
            )
        };
        let sum = |f: fn(&FlightScore) -> f64| flights.iter().map(|(_, s)| f(s)).sum::<f64>();
        out.push_str(&format!(
            "| {name} | {} | {clean} | {hits}{} | {} | {} / {} | {ratio} | {:.1} | {:.1} |\n",
            flights.len(),
            if hit_seeds.is_empty() {
                String::new()
            } else {
                format!(" ({})", hit_seeds.join(", "))
            },
            flights.iter().map(|(_, s)| s.cylinder_hits).sum::<usize>(),
            flights
                .iter()
                .map(|(_, s)| s.waypoints_captured)
                .sum::<usize>(),
            flights.iter().map(|(_, s)| s.waypoints).sum::<usize>(),
            sum(|s| s.time_s) / n,
            sum(|s| s.out_of_zone_s) / n,
        ));
    }
    out
}

/// The obstacle telemetry the flights get, as the simulator's parameters: each sphere's
/// exact position (the judges' server computes it from the tour) every `POST_EVERY` steps
/// (5 Hz), none lost (`jink simulate --obstacle-rate-hz 5 --obstacle-noise-m 0
/// --obstacle-dropout 0`).
pub fn judges_feed() -> sim::telemetry::TelemetryParams {
    sim::telemetry::TelemetryParams {
        rate_hz: 1.0 / (STEP_S * POST_EVERY as f64),
        noise_sigma_m: 0.0,
        dropout_prob: 0.0,
        lead_in_s: 0.0,
    }
}

/// The embedded Webster Field mission, read as `jink simulate --mission` reads the fixture.
fn fixture_mission() -> Mission {
    wire::domain::read_mission_text(MISSION_JSON, "demo").expect("the embedded fixture reads")
}

/// The demo's scenario on `mission`: `obstacles` moving spheres on spline tours from the
/// seed, the aircraft starting at home at the first waypoint's altitude: the scenario `jink
/// simulate --mission <the mission> --family spline --spheres <obstacles> --aircraft-speed
/// <speed_mps>` flies for the same seed.
pub fn scenario(mission: &Mission, seed: u64, obstacles: usize, speed_mps: f64) -> Scenario {
    let pm = mission.to_planner();
    let start = mission.home_start().unwrap_or_else(|| {
        pm.waypoints
            .first()
            .map_or([0.0, 0.0, 100.0], |w| [w.p_m[0], w.p_m[1] - 200.0, w.alt_m])
    });
    with_moving_spheres(pm, start, Family::Spline, seed, obstacles, speed_mps)
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
    let scenario = scenario(
        &fixture_mission(),
        p.seed,
        p.obstacles,
        p.aircraft.speed_mps,
    );
    let params = p.aircraft;
    let mut stack = initial_stack(&scenario.mission);
    let toward = stack.target().map_or([0.0, 0.0], |t| t.p_m);
    let mut ap = Autopilot::new(params, scenario.start_m, toward);
    let duration_s = p.duration_s.unwrap_or(scenario.duration_s).max(0.0);
    if !p.quiet {
        println!("jink demo: the live page is {base}/missions/{id}");
        println!(
            "jink demo: flying mission {id} (Webster Field 2021) against {} moving obstacles on spline tours, seed {}, for {}",
            scenario.spheres.len(),
            p.seed,
            p.duration_s
                .map_or("the whole mission".to_string(), |d| format!("{d} s"))
        );
    }
    // The aircraft's true positions at 5 Hz, as the judges' telemetry, and its path.
    let mut judged = vec![(ap.state.t_s, ap.state.p_m)];
    let mut path_m = 0.0;
    let plan_ms = std::sync::Arc::new(std::sync::Mutex::new(Vec::<f64>::new()));

    let t0_s = crate::time::now_s();
    let started = Instant::now();
    let mut progress = Progress {
        started,
        last: None,
    };
    let failed = Failures::default();
    let (plan_tx, mut plan_rx) = tokio::sync::mpsc::channel::<Result<PlanOut, PlanFailure>>(2);
    // The stack item the aircraft flew toward when the plan in flight was asked for.
    let mut plan_in_flight: Option<usize> = None;
    let mut revision = 0_i64;
    // The server refused our base revision (a newer one exists: a plan answered after we
    // gave up on it, another client, or a restart): the next plan is asked from the
    // mission's own waypoints, which needs no revision, and its answer is the new base.
    let mut resync = false;
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
            let before = ap.state.p_m;
            ap.step(&mut stack, STEP_S);
            path_m += (ap.state.p_m[0] - before[0]).hypot(ap.state.p_m[1] - before[1]);
            step += 1;
            let t_s = t0_s + step as f64 * STEP_S;
            if step.is_multiple_of(POST_EVERY) {
                judged.push((ap.state.t_s, ap.state.p_m));
                let mut telemetry = telemetry_json(&ap.state, &frame, t_s);
                if p.bare
                    && let Some(o) = telemetry.as_object_mut()
                {
                    o.remove("speed_mps");
                }
                let snapshot = obstacle_snapshot(&scenario, &frame, ap.state.t_s);
                post_detached(
                    &client,
                    format!("{base}/api/v1/missions/{id}/telemetry"),
                    telemetry,
                    "telemetry",
                    &failed,
                );
                post_detached(
                    &client,
                    format!("{base}/api/v1/missions/{id}/obstacles?time={t_s}"),
                    snapshot,
                    "obstacles",
                    &failed,
                );
            }
            if step.is_multiple_of(PLAN_EVERY) && plan_in_flight.is_none() {
                plan_in_flight = Some(stack.current);
                let mut body = json!({
                    "seed": p.seed.wrapping_mul(1_000_003).wrapping_add(step / PLAN_EVERY),
                    "deadline_ms": PLAN_DEADLINE_MS,
                    "base_revision": revision,
                    "current_index": stack.current,
                    "aircraft": {"speed_mps": params.speed_mps, "turn_radius_m": params.min_turn_radius_m()},
                });
                if p.bare
                    && let Some(o) = body.as_object_mut()
                {
                    o.remove("aircraft");
                }
                if resync && let Some(o) = body.as_object_mut() {
                    // Without a base revision `current_index` is a mission index: the
                    // mission waypoint flown toward.
                    o.remove("base_revision");
                    let next = stack.items[stack.current.min(stack.items.len())..]
                        .iter()
                        .find_map(|i| i.mission_index)
                        .unwrap_or(total_wp);
                    o.insert("current_index".into(), json!(next));
                }
                let (client, url, tx, times) = (
                    client.clone(),
                    format!("{base}/api/v1/missions/{id}/plan"),
                    plan_tx.clone(),
                    plan_ms.clone(),
                );
                tokio::spawn(async move {
                    let asked = Instant::now();
                    let answer = request_plan(&client, &url, &body).await;
                    if let Ok(mut t) = times.lock() {
                        t.push(asked.elapsed().as_secs_f64() * 1e3);
                    }
                    let _ = tx.send(answer).await;
                });
            }
        }
        while let Ok(answer) = plan_rx.try_recv() {
            let asked_at = plan_in_flight.take();
            match answer {
                Ok(plan) if plan.revision > revision => {
                    revision = plan.revision;
                    resync = false;
                    last_plan = format!(
                        "plan revision {} ({}, {:.0} ms, {} avoid waypoints)",
                        plan.revision, plan.outcome, plan.compute_ms, plan.added
                    );
                    let mut next = stack_from_plan(&plan, &frame);
                    // Items the aircraft reached while the plan was computed are behind it.
                    let from = asked_at.unwrap_or(stack.current).min(stack.current);
                    next.current = resume_index(&next, &stack.items[from..stack.current]);
                    ap.replace_stack(&mut stack, next);
                }
                Ok(_) => {}
                Err(e) => {
                    failed.count(format!("plan {}", e.reason));
                    last_plan = format!("plan failed: {}", e.detail);
                    resync |= e.stale_base();
                }
            }
        }
        let passed = stack.items[..stack.current.min(stack.items.len())]
            .iter()
            .filter(|i| i.mission_index.is_some())
            .count();
        if !p.quiet {
            progress.show(|| {
                format!(
                    "waypoint {passed}/{total_wp}, {last_plan}, {} failed requests",
                    failed.total()
                )
            });
        }
        if stack.target().is_none() || elapsed >= duration_s {
            if judged.last().is_some_and(|l| l.0 < ap.state.t_s) {
                judged.push((ap.state.t_s, ap.state.p_m));
            }
            let times = plan_ms.lock().map(|t| t.clone()).unwrap_or_default();
            return Ok(FlightSummary {
                mission_id: id,
                flown_s: elapsed,
                revision,
                waypoints: (passed, total_wp),
                failures: failed.reasons(),
                score: FlightScore::judge(&scenario, &judged, path_m, stack.target().is_none()),
                plan_ms: (
                    sim::run::percentile(&times, 0.5),
                    sim::run::percentile(&times, 0.95),
                ),
            });
        }
    }
}

/// Where to fly a new stack `next` from, when the aircraft reached `reached` (in order)
/// while it was computed: just past the last of them if `next` holds it at or after its
/// own current item (a mission waypoint by its index, another item by its position within
/// 1 m), since everything before it is behind the aircraft; else `next`'s own current
/// item. It skips nothing but what lies behind an item the aircraft reached: counting the
/// items reached and skipping as many (as the demo did before) could skip a detour the plan
/// had just put first, once plans took long enough for the aircraft to reach items
/// meanwhile.
pub fn resume_index(next: &Stack, reached: &[StackItem]) -> usize {
    let Some(last) = reached.last() else {
        return next.current;
    };
    let same = |a: &StackItem| match (a.mission_index, last.mission_index) {
        (Some(i), Some(j)) => i == j,
        (None, None) => a.kind == last.kind && sim::geometry::dist(a.p_m, last.p_m) <= 1.0,
        _ => false,
    };
    next.items
        .iter()
        .enumerate()
        .skip(next.current)
        .find(|(_, a)| same(a))
        .map_or(next.current, |(j, _)| j + 1)
}

/// Posts `body` without waiting for the answer; failures are counted.
fn post_detached(
    client: &reqwest::Client,
    url: String,
    body: Value,
    what: &'static str,
    failed: &Failures,
) {
    let (client, failed) = (client.clone(), failed.clone());
    tokio::spawn(async move {
        match client.post(url).json(&body).send().await {
            Ok(r) if r.status().is_success() => {}
            Ok(r) => failed.count(format!("{what} {}", r.status().as_u16())),
            Err(e) => failed.count(format!("{what}: {}", error_kind(&e))),
        }
    });
}

/// Failed requests of one flight, counted by reason (shared with the detached posts).
#[derive(Debug, Clone, Default)]
struct Failures(std::sync::Arc<std::sync::Mutex<std::collections::BTreeMap<String, u64>>>);

impl Failures {
    fn count(&self, reason: String) {
        if let Ok(mut m) = self.0.lock() {
            *m.entry(reason).or_default() += 1;
        }
    }

    fn total(&self) -> u64 {
        self.0.lock().map_or(0, |m| m.values().sum())
    }

    fn reasons(&self) -> Vec<(String, u64)> {
        self.0
            .lock()
            .map(|m| m.iter().map(|(k, v)| (k.clone(), *v)).collect())
            .unwrap_or_default()
    }
}

/// ` (plan 409 x1, obstacles: timed out x2)`, or nothing without failures.
fn failure_reasons(failures: &[(String, u64)]) -> String {
    if failures.is_empty() {
        return String::new();
    }
    let each: Vec<String> = failures.iter().map(|(r, n)| format!("{r} x{n}")).collect();
    format!(" ({})", each.join(", "))
}

/// A client error in a few words: what went wrong, not the URL.
fn error_kind(e: &reqwest::Error) -> &'static str {
    if e.is_timeout() {
        "timed out"
    } else if e.is_connect() {
        "could not connect"
    } else if e.is_body() || e.is_decode() {
        "bad answer body"
    } else {
        "connection failed"
    }
}

/// Why a plan request failed: a short reason (the HTTP status, or the kind of client
/// error) to count, and the whole message to show.
#[derive(Debug)]
struct PlanFailure {
    reason: String,
    detail: String,
    /// The problem document's `latest_revision`: the server refused the base revision
    /// and named the latest.
    latest_revision: Option<i64>,
}

impl PlanFailure {
    /// The server refused the base revision: a newer one exists (409), or the one named
    /// does not (422); either way the problem document names the latest revision.
    fn stale_base(&self) -> bool {
        self.reason == "409" || self.latest_revision.is_some()
    }

    fn client(e: &reqwest::Error) -> Self {
        Self {
            reason: error_kind(e).to_string(),
            detail: e.to_string(),
            latest_revision: None,
        }
    }
}

async fn request_plan(
    client: &reqwest::Client,
    url: &str,
    body: &Value,
) -> Result<PlanOut, PlanFailure> {
    let r = client
        .post(url)
        .json(body)
        .send()
        .await
        .map_err(|e| PlanFailure::client(&e))?;
    let status = r.status();
    if !status.is_success() {
        let text = r.text().await.unwrap_or_default();
        let latest_revision = serde_json::from_str::<Value>(&text)
            .ok()
            .and_then(|p| p.get("latest_revision").and_then(Value::as_i64));
        return Err(PlanFailure {
            reason: status.as_u16().to_string(),
            detail: format!("{status}: {text}"),
            latest_revision,
        });
    }
    r.json::<PlanOut>()
        .await
        .map_err(|e| PlanFailure::client(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn webster() -> Mission {
        wire::domain::read_mission_text(MISSION_JSON, "demo").expect("the embedded fixture")
    }

    #[test]
    fn a_refused_base_revision_is_read_from_the_problem_document() {
        let failure = |reason: &str, latest_revision| PlanFailure {
            reason: reason.into(),
            detail: String::new(),
            latest_revision,
        };
        assert!(failure("409", Some(4)).stale_base());
        assert!(failure("422", Some(4)).stale_base());
        // Another invalid field, or an overloaded service: the base revision stands.
        assert!(!failure("422", None).stale_base());
        assert!(!failure("503", None).stale_base());
    }

    #[test]
    fn failed_requests_are_counted_by_reason_across_clones() {
        let f = Failures::default();
        assert_eq!(failure_reasons(&f.reasons()), "");
        // A detached post counts through its own clone.
        let post = f.clone();
        post.count("obstacles: timed out".into());
        f.count("plan 409".into());
        f.count("plan 409".into());
        assert_eq!(f.total(), 3);
        assert_eq!(
            failure_reasons(&f.reasons()),
            " (obstacles: timed out x1, plan 409 x2)"
        );
    }

    #[test]
    fn the_obstacle_snapshot_is_the_judges_form_in_feet_at_the_spheres_true_positions() {
        let m = webster();
        let s = scenario(&m, 7, 4, 20.0);
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
        let a = scenario(&m, 3, 6, 20.0);
        let b = scenario(&m, 3, 6, 20.0);
        let c = scenario(&m, 4, 6, 20.0);
        assert_eq!(a.spheres, b.spheres);
        assert_ne!(a.spheres, c.spheres);
    }

    #[test]
    fn a_seed_flies_the_scenario_jink_simulate_flies_for_it() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/fixtures/interop/mission_2021_webster_field.json");
        let (m, start) = crate::cli::simulate::load_mission(&path).unwrap();
        for seed in [0, 146] {
            let ours = scenario(&webster(), seed, 10, 18.0);
            let simulate = with_moving_spheres(m.clone(), start, Family::Spline, seed, 10, 18.0);
            assert_eq!(ours.start_m, simulate.start_m);
            assert_eq!(ours.spheres, simulate.spheres);
            assert_eq!(ours.mission, simulate.mission);
        }
    }

    #[test]
    fn a_flight_is_judged_against_the_spheres_true_positions() {
        let s = scenario(&webster(), 5, 3, 20.0);
        let straight = sim::mission::straight_length_m(&s.mission, s.start_m);
        // Ten seconds sitting in sphere 1's centre as it moves: a hit of that sphere only
        // (the others are elsewhere at those moments, checked below against the truth).
        let inside: Vec<(f64, [f64; 3])> = (0..=50)
            .map(|k| {
                let t = 100.0 + f64::from(k) * 0.2;
                (t, s.spheres[1].track.at(t))
            })
            .collect();
        let others_clear = inside.iter().all(|&(t, p)| {
            [0, 2].iter().all(|&i| {
                let c = s.spheres[i].track.at(t);
                let d =
                    ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
                d > s.spheres[i].radius_m
            })
        });
        let hit = FlightScore::judge(&s, &inside, 2.0 * straight, true);
        assert!(others_clear, "the test's track must meet sphere 1 alone");
        assert_eq!(hit.sphere_hits, 1, "{hit}");
        assert!(hit.min_clearance_m < 0.0, "{hit}");
        assert!((hit.path_ratio - 2.0).abs() < 1e-12, "{hit}");
        assert!((hit.time_s - 110.0).abs() < 1e-9, "{hit}");
        // Every waypoint visited, at each one's own altitude, far from every sphere's truth
        // is checked by the judge itself: all captured.
        let visits: Vec<(f64, [f64; 3])> = s
            .mission
            .waypoints
            .iter()
            .enumerate()
            .map(|(k, w)| (k as f64 * 20.0, [w.p_m[0], w.p_m[1], w.alt_m]))
            .collect();
        let v = FlightScore::judge(&s, &visits, straight, true);
        assert_eq!(
            (v.waypoints_captured, v.waypoints),
            (s.mission.waypoints.len(), s.mission.waypoints.len())
        );
    }

    #[test]
    fn the_table_counts_clean_flights_and_names_the_seeds_that_hit() {
        let score = |spheres, cylinders, ratio| FlightScore {
            sphere_hits: spheres,
            cylinder_hits: cylinders,
            waypoints_captured: 13,
            waypoints: 14,
            path_ratio: ratio,
            finished: true,
            min_clearance_m: 3.0,
            out_of_zone_s: 2.0,
            time_s: 300.0,
        };
        let t = score_table(&[(
            "jink".into(),
            vec![
                (4, score(0, 0, 1.1)),
                (5, score(2, 0, 1.3)),
                (6, score(0, 1, 1.2)),
            ],
        )]);
        let row = t.lines().nth(2).unwrap();
        assert_eq!(
            row,
            "| jink | 3 | 1 | 2 (5) | 1 | 39 / 42 | 1.200 / 1.200 | 300.0 | 2.0 |"
        );
        // A flight cut before its stack's end (`--duration`) has flown part of the route:
        // its path ratio is left out of the column and not shown.
        let cut = FlightScore {
            finished: false,
            ..score(0, 0, 0.4)
        };
        assert!(
            cut.to_string().contains("path ratio - (not finished)"),
            "{cut}"
        );
        let t = score_table(&[
            ("jink".into(), vec![(4, score(0, 0, 1.1)), (5, cut)]),
            ("cut".into(), vec![(5, cut)]),
        ]);
        let rows: Vec<&str> = t.lines().skip(2).collect();
        assert_eq!(
            rows,
            [
                "| jink | 2 | 2 | 0 | 0 | 26 / 28 | 1.100 / 1.100 | 300.0 | 2.0 |",
                "| cut | 1 | 1 | 0 | 0 | 13 / 14 | - | 300.0 | 2.0 |"
            ]
        );
    }

    #[test]
    fn the_comparisons_feed_is_the_flights_exact_positions_at_5_hz() {
        let s = scenario(&webster(), 2, 4, 18.0);
        let streams = sim::telemetry::sample_streams(&s, &judges_feed());
        for (sphere, stream) in s.spheres.iter().zip(&streams) {
            // Every 0.2 s from take-off, none lost, each at the sphere's true position
            // (what `obstacle_snapshot` posts at those moments).
            assert!(
                stream.len() as f64 >= s.duration_s * 5.0 - 1.0,
                "{}",
                stream.len()
            );
            for (k, o) in stream.iter().take(100).enumerate() {
                assert!((o.t_s - k as f64 * 0.2).abs() < 1e-9, "{k}: {}", o.t_s);
                let truth = sphere.track.at(o.t_s);
                assert!((0..3).all(|i| (o.p_m[i] - truth[i]).abs() < 1e-9), "{k}");
            }
        }
    }

    #[test]
    fn a_new_stack_is_flown_past_the_last_item_reached_meanwhile_and_never_past_a_new_detour() {
        let m = |i: usize, x: f64| StackItem::mission(i, [x, 0.0], 60.0);
        let avoid = |x: f64, y: f64| StackItem {
            p_m: [x, y],
            alt_m: 60.0,
            kind: ItemKind::Avoid,
            mission_index: None,
        };
        let stack = |items: Vec<StackItem>, current| Stack { items, current };
        // Mission waypoint 3 reached while the plan (a detour first, then 3 and 4) was
        // computed: fly on to 4.
        let next = stack(vec![avoid(50.0, 80.0), m(3, 100.0), m(4, 200.0)], 0);
        assert_eq!(resume_index(&next, &[m(3, 100.0)]), 2);
        // The plan put a detour before waypoint 4 and the aircraft reached an old avoid
        // item meanwhile: nothing skipped (counting would have skipped the detour).
        let next = stack(vec![avoid(150.0, -60.0), m(4, 200.0)], 0);
        assert_eq!(resume_index(&next, &[avoid(80.0, 40.0)]), 0);
        // An avoid item reached is found by its position, and nothing reached changes
        // nothing.
        let next = stack(vec![m(2, 0.0), avoid(80.0, 40.0), m(3, 100.0)], 1);
        assert_eq!(resume_index(&next, &[avoid(80.3, 40.2)]), 2);
        assert_eq!(resume_index(&next, &[]), 1);
        // Items before the new stack's own current one are not looked at.
        assert_eq!(resume_index(&next, &[m(2, 0.0)]), 1);
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
