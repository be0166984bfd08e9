//! The simulator's `server` strategy: each closed-loop run flies against the real service
//! over HTTP, as a team's ground station would, so that `jink simulate` measures exactly
//! the pipeline `jink serve` runs (ingest, live state, plan request, answer) beside
//! `mc-auto` (the same planner called in-process) and `oracle`.
//!
//! [`start`] serves an in-process `jink serve` on a temporary SQLite database at a free
//! loopback port (write-rate limits off: the simulator posts as fast as it flies) and
//! registers the strategy with [`sim::strategy::register_server`]. Per run, the strategy
//! ([`HttpPlanner`]):
//! - at its first call uploads the run's mission in native form (ENU metres turned into
//!   latitude and longitude with a frame whose origin is the mission's home, so that the
//!   service's ENU frame is the simulator's);
//! - at every call posts the obstacle telemetry received since the last call as one native
//!   batch (ids "0", "1", ...; times on the mission clock [`T0_S`] + simulated seconds) and
//!   the aircraft's own state as native telemetry, then asks for a plan with `base_revision`
//!   (the revision it flies), `current_index`, the aircraft's speed and turn radius,
//!   `max_map_age_ms: 0` (the map of every batch posted, so that a run never depends on
//!   how fast a map was built) and a seed derived from the run seed and the call count, and
//!   flies the answer.
//! - `server-bare` tells the service the least a client can: its telemetry carries no speed
//!   (the interop telemetry forms have none) and its plan requests no `aircraft`.
//! - `server-mission` keeps no revision, as a client that reads DESIGN.md's default would:
//!   each plan request goes without `base_revision` (the mission's own waypoints) and with
//!   `current_index` the mission index of the next mission waypoint of the stack it flies
//!   (the waypoint count once none is left), and the answer is flown from its own
//!   `current_index`.
//!
//! The simulated clock stops while a request is answered, as it does for `mc-auto`, so the
//! plan the aircraft flies is the one computed for the moment it was asked.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use sim::mission::{Mission, Stack};
use sim::strategy::{Command, Strategy, View};

use crate::api::plans::PlanOut;
use crate::app::{AppState, Settings};
use crate::geodesy::LocalFrame;
use crate::store::Store;

/// The mission clock's zero as Unix seconds (2027-01-15), so that the service sees
/// ordinary absolute times.
pub const T0_S: f64 = 1_800_000_000.0;

/// Where the simulated missions are put on the earth (any place would do; this is Webster
/// Field, where the judges flew).
const ORIGIN_DEG: (f64, f64) = (38.1446, -76.4280);

/// The running service and what the runs report back.
pub struct Service {
    _rt: tokio::runtime::Runtime,
    base: String,
    failures: Arc<AtomicU64>,
    _dir: tempfile::TempDir,
}

impl Service {
    /// The service's base URL (`http://127.0.0.1:PORT`).
    pub fn base(&self) -> &str {
        &self.base
    }

    /// Requests that failed so far (each made its run keep the stack it flew).
    pub fn failures(&self) -> u64 {
        self.failures.load(Ordering::Relaxed)
    }
}

/// Starts the service and registers the `server` strategy.
///
/// # Errors
/// When the database, the listener or the runtime cannot be made, or a `server` strategy
/// is registered already.
pub fn start() -> Result<Service, String> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .thread_name("jink-sim-service")
        .build()
        .map_err(|e| format!("cannot start a runtime: {e}"))?;
    let dir = tempfile::Builder::new()
        .prefix("jink-simulate-")
        .tempdir()
        .map_err(|e| format!("cannot create a temporary directory: {e}"))?;
    let url = format!("sqlite://{}", dir.path().join("simulate.sqlite").display());
    let base = rt.block_on(async {
        let store = Store::open(&url).await.map_err(|e| e.to_string())?;
        let mut settings = Settings::default();
        // The simulator posts as fast as it flies, far above a ground station's rate.
        settings.access.rates = crate::auth::RateSettings {
            ingest_per_s: 0.0,
            ingest_burst: 0.0,
            other_per_s: 0.0,
            other_burst: 0.0,
        };
        let state = AppState::new(store, settings);
        let listener = tokio::net::TcpListener::bind(("127.0.0.1", 0))
            .await
            .map_err(|e| format!("cannot listen on 127.0.0.1: {e}"))?;
        let local = listener.local_addr().map_err(|e| e.to_string())?;
        tokio::spawn(crate::app::serve_on(listener, state));
        Ok::<_, String>(format!("http://{local}"))
    })?;
    let client = reqwest::Client::builder()
        .timeout(Duration::from_secs(120))
        .build()
        .map_err(|e| e.to_string())?;
    let failures = Arc::new(AtomicU64::new(0));
    let (handle, b, f) = (rt.handle().clone(), base.clone(), failures.clone());
    sim::strategy::register_server(Box::new(move |kind, seed| {
        Box::new(HttpPlanner {
            bare: kind == sim::strategy::StrategyKind::ServerBare,
            mission_only: kind == sim::strategy::StrategyKind::ServerMission,
            handle: handle.clone(),
            client: client.clone(),
            base: b.clone(),
            failures: f.clone(),
            seed,
            frame: LocalFrame::new(ORIGIN_DEG.0, ORIGIN_DEG.1),
            mission_id: None,
            revision: 0,
            fed: Vec::new(),
            calls: 0,
            live_ms: None,
        })
    }))
    .map_err(|_| "the `server` strategy is registered already".to_string())?;
    Ok(Service {
        _rt: rt,
        base,
        failures,
        _dir: dir,
    })
}

/// One run's client of the service.
struct HttpPlanner {
    handle: tokio::runtime::Handle,
    client: reqwest::Client,
    base: String,
    failures: Arc<AtomicU64>,
    seed: u64,
    /// Telemetry without a speed, plan requests without `aircraft` (`server-bare`).
    bare: bool,
    /// Plan requests without `base_revision`, `current_index` in the mission's waypoints
    /// (`server-mission`).
    mission_only: bool,
    frame: LocalFrame,
    mission_id: Option<String>,
    revision: i64,
    /// Observations of each obstacle posted so far.
    fed: Vec<usize>,
    calls: u64,
    live_ms: Option<f64>,
}

/// The native upload of a simulator mission, placed with `frame` (its origin is home).
pub fn mission_json(m: &Mission, frame: &LocalFrame) -> Value {
    let ll = |p: [f64; 2]| {
        let (lat, lon) = frame.to_geodetic(p);
        json!({"lat": lat, "lon": lon})
    };
    let (lat0, lon0) = frame.origin_deg();
    json!({
        "name": "jink simulate",
        "home": {"lat": lat0, "lon": lon0},
        "fly_zones": m.fly_zones.iter().map(|z| json!({
            "boundary": z.boundary_m.iter().map(|p| ll(*p)).collect::<Vec<_>>(),
            "alt_min_msl_m": z.alt_min_m,
            "alt_max_msl_m": z.alt_max_m,
        })).collect::<Vec<_>>(),
        "waypoints": m.waypoints.iter().map(|w| {
            let (lat, lon) = frame.to_geodetic(w.p_m);
            json!({"lat": lat, "lon": lon, "alt_msl_m": w.alt_m})
        }).collect::<Vec<_>>(),
        "stationary_obstacles": m.cylinders.iter().enumerate().map(|(i, c)| {
            let (lat, lon) = frame.to_geodetic(c.center_m);
            json!({"id": i.to_string(), "lat": lat, "lon": lon, "radius_m": c.radius_m, "top_msl_m": c.top_m})
        }).collect::<Vec<_>>(),
    })
}

impl HttpPlanner {
    async fn post(&self, path: &str, body: &Value) -> Result<Value, String> {
        let r = self
            .client
            .post(format!("{}{path}", self.base))
            .json(body)
            .send()
            .await
            .map_err(|e| format!("POST {path}: {e}"))?;
        let status = r.status();
        let text = r.text().await.map_err(|e| format!("POST {path}: {e}"))?;
        if !status.is_success() {
            return Err(format!("POST {path}: {status}: {text}"));
        }
        serde_json::from_str(&text).map_err(|e| format!("POST {path}: {e}: {text}"))
    }

    /// The mission's id, uploading it at the first call.
    async fn mission(&mut self, m: &Mission) -> Result<String, String> {
        if let Some(id) = &self.mission_id {
            return Ok(id.clone());
        }
        let stored = self
            .post("/api/v1/missions", &mission_json(m, &self.frame))
            .await?;
        let id = stored["id"]
            .as_str()
            .ok_or("the mission upload answered no id")?
            .to_string();
        self.mission_id = Some(id.clone());
        Ok(id)
    }

    /// Posts what the aircraft learnt since the last call: new obstacle observations, its
    /// own state.
    async fn ingest(&mut self, id: &str, view: &View<'_>) -> Result<(), String> {
        self.fed.resize(view.tracks.len(), 0);
        let mut batch = Vec::new();
        for (i, track) in view.tracks.iter().enumerate() {
            for o in &track[self.fed[i]..] {
                let (lat, lon) = self.frame.to_geodetic([o.p_m[0], o.p_m[1]]);
                batch.push(json!({"obstacle_id": i.to_string(), "t": T0_S + o.t_s,
                    "lat": lat, "lon": lon, "alt_msl_m": o.p_m[2], "radius_m": o.radius_m}));
            }
            self.fed[i] = track.len();
        }
        // A lead-in (telemetry from before take-off) arrives all at once at the first call:
        // posted in batches a client would send.
        for chunk in batch.chunks(1000) {
            self.post(
                &format!("/api/v1/missions/{id}/obstacles"),
                &json!({ "observations": chunk }),
            )
            .await?;
        }
        let mut tel = super::demo::telemetry_json(&view.own, &self.frame, T0_S + view.t_s);
        if self.bare
            && let Some(o) = tel.as_object_mut()
        {
            o.remove("speed_mps");
        }
        self.post(&format!("/api/v1/missions/{id}/telemetry"), &tel)
            .await?;
        Ok(())
    }

    async fn plan(&mut self, id: &str, view: &View<'_>) -> Result<Stack, String> {
        let a = view.aircraft.planner_aircraft();
        let mut body = json!({
            "seed": planner::plan::leg_seed(self.seed, self.calls as usize, 0),
            "base_revision": self.revision,
            "current_index": view.stack.current,
            // Every batch posted before it (read your writes): a run must not depend on
            // how fast the map of the last batch was built.
            "max_map_age_ms": 0,
            "aircraft": {"speed_mps": a.speed_mps, "turn_radius_m": a.turn_radius_m,
                         "acceptance_radius_m": view.aircraft.acceptance_radius_m,
                         "l1_period_s": view.aircraft.l1_period_s},
        });
        if self.bare
            && let Some(o) = body.as_object_mut()
        {
            o.remove("aircraft");
        }
        if self.mission_only
            && let Some(o) = body.as_object_mut()
        {
            o.remove("base_revision");
            let next = view
                .stack
                .next_mission_index()
                .unwrap_or(view.mission.waypoints.len());
            o.insert("current_index".into(), json!(next));
        }
        let answer = self
            .post(&format!("/api/v1/missions/{id}/plan"), &body)
            .await?;
        let plan: PlanOut = serde_json::from_value(answer).map_err(|e| e.to_string())?;
        if sim::strategy::trace_plans() {
            trace_answer(view, &plan);
        }
        self.revision = plan.revision;
        Ok(super::demo::stack_from_plan(&plan, &self.frame))
    }

    async fn decide_async(&mut self, view: &View<'_>) -> Result<Stack, String> {
        let started = Instant::now();
        let id = self.mission(view.mission).await?;
        self.ingest(&id, view).await?;
        self.live_ms = Some(started.elapsed().as_secs_f64() * 1e3);
        self.plan(&id, view).await
    }
}

/// One line of `JINK_SIM_TRACE` for a plan the service answered: the simulated time and
/// position, then what the answer says (outcome, risks, length, the start it planned from,
/// warnings and the obstacles it left out).
fn trace_answer(view: &View<'_>, plan: &PlanOut) {
    let left_out: Vec<&str> = plan
        .obstacles
        .iter()
        .filter(|o| !o.considered)
        .map(|o| o.id.as_str())
        .collect();
    eprintln!(
        "plan t={:.1} s pos=({:.0}, {:.0}) current_index={} pending_s={:?} outcome={} \
         risk={:.2} base_risk={:.2} exposure_m={:.0} length_m={:.0} added={} \
         start_speed={:.1} start_heading={:.0} map_lag={} warnings={:?} left_out={:?} \
         compute_ms={:.1}",
        view.t_s,
        view.own.p_m[0],
        view.own.p_m[1],
        plan.current_index,
        plan.target_pending_s,
        plan.outcome,
        plan.risk,
        plan.base_risk,
        plan.exposure_m,
        plan.length_m,
        plan.added,
        plan.start.speed_mps,
        plan.start.heading_deg,
        plan.map_lag_batches,
        plan.warnings
            .iter()
            .map(|w| if w.code == "turn_radius_assumed" {
                w.message.split(';').next().unwrap_or_default()
            } else {
                w.code.as_str()
            })
            .collect::<Vec<_>>(),
        left_out,
        plan.compute_ms,
    );
}

impl Strategy for HttpPlanner {
    fn period_s(&self) -> f64 {
        // `mc-auto`'s period (sim::strategy::bisection::Bisection).
        1.0
    }

    fn take_live_ms(&mut self) -> Option<f64> {
        self.live_ms.take()
    }

    fn decide(&mut self, view: &View<'_>) -> Command {
        self.calls += 1;
        let handle = self.handle.clone();
        match handle.block_on(self.decide_async(view)) {
            Ok(stack) => Command::Replace(stack),
            Err(e) => {
                if self.failures.fetch_add(1, Ordering::Relaxed) < 5 {
                    eprintln!("jink simulate: the `server` strategy kept its stack: {e}");
                }
                Command::Keep
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_simulator_mission_uploaded_in_native_form_comes_back_in_the_same_enu_frame() {
        let s = sim::scenario::generate(
            sim::scenario::Family::Mixed,
            3,
            &sim::scenario::ScenarioParams::default(),
        );
        let m = &s.mission;
        assert!(!m.cylinders.is_empty() && m.waypoints.len() >= 5);
        let frame = LocalFrame::new(ORIGIN_DEG.0, ORIGIN_DEG.1);
        let text = mission_json(m, &frame).to_string();
        let stored = wire::domain::read_mission_text(&text, "t").expect("a valid mission");
        // The service's frame is the one the upload was placed with...
        assert_eq!(stored.frame().origin_deg(), frame.origin_deg());
        // ... so its ENU geometry is the simulator's, to well under a millimetre.
        let back = stored.to_planner();
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6;
        assert_eq!(back.waypoints.len(), m.waypoints.len());
        for (a, b) in back.waypoints.iter().zip(&m.waypoints) {
            assert!(close(a.p_m, b.p_m), "{:?} {:?}", a.p_m, b.p_m);
            assert_eq!(a.alt_m, b.alt_m);
        }
        for (a, b) in back.cylinders.iter().zip(&m.cylinders) {
            assert!(close(a.center_m, b.center_m));
            assert_eq!((a.radius_m, a.top_m), (b.radius_m, b.top_m));
        }
        let (za, zb) = (&back.fly_zones[0], &m.fly_zones[0]);
        assert_eq!((za.alt_min_m, za.alt_max_m), (zb.alt_min_m, zb.alt_max_m));
        assert!(
            za.boundary_m
                .iter()
                .zip(&zb.boundary_m)
                .all(|(a, b)| close(*a, *b))
        );
    }
}
