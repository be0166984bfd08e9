//! What the operator's page draws, as the JSON its server-sent events carry: the mission's
//! fixed geometry once per connection ([`mission_json`]), then the live state
//! ([`Feed::state`]) whenever it changes: the moving obstacles from the mission's live
//! snapshot (the same predictor the plans use) with their recent tracks, the aircraft's
//! telemetry track, the current plan with its last diff, the plan history and warnings.
//!
//! Positions are ENU metres in the mission's frame (east, north), rounded to 0.1 m, so
//! the page needs no geodesy.
//!
//! # Units
//! Metres, seconds (Unix seconds for times), degrees for headings (compass).

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::Arc;

use predictor::ObstacleSummary;
use serde_json::{Value, json};

use crate::api::obstacles::StageOut;
use crate::api::plan_record::stored_plan_out;
use crate::api::plans::PlanOut;
use crate::app::AppState;
use crate::error::ApiError;
use crate::live::Snapshot;
use crate::live::plan_view::CLOCK_TOLERANCE_S;
use crate::mission::Mission;

/// Seconds of obstacle track drawn behind each obstacle.
pub const OBSTACLE_TRACK_S: f64 = 30.0;
/// Aircraft telemetry points drawn (the newest).
pub const AIRCRAFT_TRACK_POINTS: u32 = 600;
/// Plans in the history panel.
pub const HISTORY_PLANS: i64 = 20;
/// Telemetry or obstacle data older than this by the server's clock is stale, seconds.
pub const STALE_S: f64 = 3.0;

pub(crate) fn r1(x: f64) -> f64 {
    (x * 10.0).round() / 10.0
}

pub(crate) fn pt(p: [f64; 2]) -> [f64; 2] {
    [r1(p[0]), r1(p[1])]
}

/// A name for people: the mission's own, else its interop id, else the place of its first
/// waypoint (else of its home).
pub fn display_name(m: &Mission) -> String {
    if let Some(n) = m.content.name.as_deref().filter(|n| !n.trim().is_empty()) {
        return n.to_string();
    }
    if let Some(i) = m.content.interop_id {
        return format!("Interop mission {i}");
    }
    let (lat, lon) = m
        .content
        .waypoints
        .first()
        .map_or((m.home.lat, m.home.lon), |w| (w.lat, w.lon));
    format!(
        "Mission at {:.4}° {}, {:.4}° {}",
        lat.abs(),
        if lat >= 0.0 { 'N' } else { 'S' },
        lon.abs(),
        if lon >= 0.0 { 'E' } else { 'W' }
    )
}

/// The mission's fixed geometry in its ENU frame.
pub fn mission_json(m: &Mission) -> Value {
    let f = m.frame();
    let c = &m.content;
    json!({
        "id": m.id.to_string(),
        "name": display_name(m),
        "fly_zones": c.fly_zones.iter().map(|z| json!({
            "boundary": z.boundary.iter().map(|p| pt(f.to_enu(p.lat, p.lon))).collect::<Vec<_>>(),
            "alt_min_msl_m": z.alt_min_msl_m,
            "alt_max_msl_m": z.alt_max_msl_m,
        })).collect::<Vec<_>>(),
        "waypoints": c.waypoints.iter().map(|w| json!({
            "p": pt(f.to_enu(w.lat, w.lon)), "alt_msl_m": r1(w.alt_msl_m),
        })).collect::<Vec<_>>(),
        "search_grid": c.search_grid.iter().map(|p| pt(f.to_enu(p.lat, p.lon))).collect::<Vec<_>>(),
        "cylinders": c.stationary_obstacles.iter().map(|o| json!({
            "id": o.id.to_string(), "p": pt(f.to_enu(o.lat, o.lon)),
            "radius_m": r1(o.radius_m), "top_msl_m": r1(o.top_msl_m),
        })).collect::<Vec<_>>(),
    })
}

/// A plan as the page draws it: its stack in ENU metres, each item flagged when the plan's
/// diff wrote it (`changed`), and the diff's size.
pub fn plan_json(p: &PlanOut, frame: &crate::geodesy::LocalFrame) -> Value {
    let first = p.diff.first_changed;
    json!({
        "revision": p.revision,
        "plan_id": p.plan_id,
        "outcome": p.outcome,
        "current_index": p.current_index,
        "risk": p.risk,
        "compute_ms": p.compute_ms,
        "seed": p.seed.to_string(),
        "created_at": p.created_at,
        "start_t": p.start.t,
        "waypoints": p.waypoints.iter().enumerate().map(|(i, w)| json!({
            "p": pt(frame.to_enu(w.lat, w.lon)),
            "alt_msl_m": r1(w.alt_msl_m),
            "kind": w.kind,
            "mission_index": w.mission_index,
            "changed": first.is_some_and(|f| i >= f && i < f + p.diff.insert.len()),
        })).collect::<Vec<_>>(),
        "diff": {"first_changed": first, "remove": p.diff.remove, "insert": p.diff.insert.len()},
    })
}

/// One row of the plan history.
#[derive(Debug, Clone)]
struct HistoryRow {
    revision: i64,
    outcome: String,
    compute_ms: f64,
    risk: f64,
    added: usize,
    created_at: String,
}

/// One page connection's view of a mission: remembers the obstacle tracks and plan
/// history it has read, so that each update reads only what is new.
#[derive(Debug)]
pub struct Feed {
    mission: Arc<Mission>,
    tracks: HashMap<String, VecDeque<(f64, [f64; 2])>>,
    tracks_until_s: Option<f64>,
    history: BTreeMap<i64, HistoryRow>,
    plan: Option<PlanOut>,
    last_key: Option<String>,
}

impl Feed {
    /// A feed of `mission` that has read nothing yet.
    pub fn new(mission: Mission) -> Self {
        Self {
            mission: Arc::new(mission),
            tracks: HashMap::new(),
            tracks_until_s: None,
            history: BTreeMap::new(),
            plan: None,
            last_key: None,
        }
    }

    /// The mission.
    pub fn mission(&self) -> &Mission {
        &self.mission
    }

    /// The live state when it changed since the last call (None: nothing new).
    ///
    /// # Errors
    /// Database failures; 404 when the mission was deleted.
    pub async fn state_if_changed(&mut self, state: &AppState) -> Result<Option<Value>, ApiError> {
        let id = self.mission.id.clone();
        // The snapshot last published (each accepted batch publishes a new one in the
        // background): the page never waits for a map build. Only an unloaded state (first
        // use, or the mission deleted and forgotten) is loaded, which answers 404 for a
        // deleted mission.
        let live = state.live.entry(&self.mission);
        let published = live.published();
        let snap = if published.seq >= 0 {
            published
        } else {
            live.snapshot(state).await?
        };
        let telemetry = state
            .store
            .list_telemetry(&id, Some(AIRCRAFT_TRACK_POINTS))
            .await?;
        let revision = state.store.latest_plan_revision(&id).await?;
        let now_s = crate::time::now_s();
        // One summary per obstacle, shared by the warnings and the state.
        let obstacles: Vec<ObstacleSummary> = snap.predictor.obstacles().collect();
        let warnings = self.warnings(&snap, &obstacles, telemetry.last().map(|t| t.t_s), now_s);
        let key = format!(
            "{}/{:?}/{revision}/{}",
            snap.seq,
            telemetry.last().map(|t| t.t_s),
            warnings
                .iter()
                .map(|w| w["code"].as_str().unwrap_or(""))
                .collect::<Vec<_>>()
                .join(",")
        );
        if self.last_key.as_deref() == Some(key.as_str()) {
            return Ok(None);
        }
        self.last_key = Some(key);
        self.read_tracks(state, &snap).await?;
        self.read_plans(state, revision).await?;
        Ok(Some(
            self.state(&snap, &obstacles, &telemetry, warnings, now_s),
        ))
    }

    /// Appends the observations newer than those already read to the tracks and drops the
    /// points older than [`OBSTACLE_TRACK_S`] before the newest.
    async fn read_tracks(&mut self, state: &AppState, snap: &Snapshot) -> Result<(), ApiError> {
        let Some(anchor) = snap.anchor_t_s else {
            return Ok(());
        };
        if self.tracks_until_s.is_some_and(|t| t >= anchor) {
            return Ok(());
        }
        let after = self
            .tracks_until_s
            .unwrap_or(anchor - OBSTACLE_TRACK_S)
            .max(anchor - OBSTACLE_TRACK_S);
        let rows = state
            .store
            .list_observations(&self.mission.id, None, Some(after))
            .await?;
        let frame = snap.frame;
        for r in &rows {
            self.tracks
                .entry(r.obstacle_id.clone())
                .or_default()
                .push_back((r.t_s, pt(frame.to_enu(r.lat_deg, r.lon_deg))));
        }
        let newest = rows.iter().map(|r| r.t_s).fold(anchor, f64::max);
        for t in self.tracks.values_mut() {
            while t
                .front()
                .is_some_and(|(t0, _)| *t0 < newest - OBSTACLE_TRACK_S)
            {
                t.pop_front();
            }
        }
        self.tracks_until_s = Some(newest);
        Ok(())
    }

    /// Reads the plans of the history not read yet, and the current plan.
    async fn read_plans(&mut self, state: &AppState, latest: i64) -> Result<(), ApiError> {
        if latest == 0 || self.plan.as_ref().is_some_and(|p| p.revision == latest) {
            return Ok(());
        }
        let id = &self.mission.id;
        for rev in (latest - HISTORY_PLANS + 1).max(1)..=latest {
            if self.history.contains_key(&rev) {
                continue;
            }
            let Some(row) = state.store.get_plan_by_revision(id, rev).await? else {
                continue;
            };
            let out = stored_plan_out(&row)?;
            self.history.insert(
                rev,
                HistoryRow {
                    revision: rev,
                    outcome: out.outcome.clone(),
                    compute_ms: out.compute_ms,
                    risk: out.risk,
                    added: out.added,
                    created_at: out.created_at.clone(),
                },
            );
            if rev == latest {
                self.plan = Some(out);
            }
        }
        while self.history.len() > HISTORY_PLANS as usize {
            self.history.pop_first();
        }
        Ok(())
    }

    fn warnings(
        &self,
        snap: &Snapshot,
        obstacles: &[ObstacleSummary],
        telemetry_t: Option<f64>,
        now_s: f64,
    ) -> Vec<Value> {
        let mut w = Vec::new();
        match telemetry_t {
            None => w.push(json!({"code": "no_telemetry",
                "message": "no aircraft telemetry yet: the aircraft is not drawn"})),
            Some(t) if now_s - t > STALE_S => w.push(json!({"code": "stale_telemetry",
                "message": format!("stale telemetry: the newest aircraft position is {:.0} s old (server clock)", now_s - t)})),
            Some(_) => {}
        }
        if let Some(a) = snap.anchor_t_s {
            if now_s - a > STALE_S {
                w.push(json!({"code": "stale_obstacles",
                    "message": format!("stale obstacle data: the newest observation is {:.0} s old (server clock)", now_s - a)}));
            }
            if let Some(t) = telemetry_t
                && (t < a - CLOCK_TOLERANCE_S || t > a + crate::live::snapshot::LIVE_HORIZON_S)
            {
                w.push(json!({"code": "clock_mismatch",
                    "message": format!("clock mismatch: aircraft telemetry (t={t:.1}) and obstacle data (t={a:.1}) are {:.1} s apart; stamp both with the same clock", (t - a).abs())}));
            }
        }
        if let Some(a) = snap.anchor_t_s {
            // The obstacles a plan anchored now would consider (README "Time rule").
            let young = crate::live::plan_view::not_learned(obstacles.iter().filter(|o| {
                crate::live::plan_view::considered(
                    o.last_observation.t_s,
                    a,
                    crate::live::snapshot::LIVE_HORIZON_S,
                )
            }));
            if let Some(m) = crate::live::plan_view::not_learned_message(&young) {
                w.push(json!({"code": "tours_not_learned", "message": m}));
            }
        }
        if let Some(p) = &self.plan {
            // The page shows its own, live `tours_not_learned` (above).
            for pw in p.warnings.iter().filter(|w| w.code != "tours_not_learned") {
                w.push(json!({"code": format!("plan_{}", pw.code), "message": format!("plan {}: {}", p.revision, pw.message)}));
            }
        }
        w
    }

    fn state(
        &self,
        snap: &Snapshot,
        obstacles: &[ObstacleSummary],
        telemetry: &[crate::store::TelemetryRow],
        warnings: Vec<Value>,
        now_s: f64,
    ) -> Value {
        let frame = snap.frame;
        let obstacles: Vec<Value> = obstacles
            .iter()
            .map(|o| {
                let e = &o.estimates;
                let track: Vec<[f64; 2]> = self
                    .tracks
                    .get(&o.id)
                    .map(|t| t.iter().map(|(_, p)| *p).collect())
                    .unwrap_or_default();
                json!({
                    "id": o.id,
                    "stage": StageOut::from(o.stage),
                    "p": pt(e.position_m),
                    "v": [r1(e.velocity_mps[0]), r1(e.velocity_mps[1])],
                    "speed_mps": r1(e.speed_mps),
                    "heading_deg": e.heading_deg.map(r1),
                    "radius_m": r1(o.last_observation.radius_m),
                    "alt_msl_m": r1(o.last_observation.alt_m),
                    "last_t": o.last_observation.t_s,
                    "in_map": snap.map_ids.contains(&o.id),
                    "observations": o.observations,
                    "track": track,
                })
            })
            .collect();
        let aircraft = telemetry.last().map(|t| {
            json!({
                "t": t.t_s,
                "p": pt(frame.to_enu(t.lat_deg, t.lon_deg)),
                "alt_msl_m": r1(t.alt_msl_m),
                "heading_deg": t.heading_deg,
                "speed_mps": t.speed_mps,
                "track": telemetry.iter().map(|r| pt(frame.to_enu(r.lat_deg, r.lon_deg))).collect::<Vec<_>>(),
            })
        });
        let plan = self.plan.as_ref().map(|p| plan_json(p, &frame));
        let history: Vec<Value> = self
            .history
            .values()
            .rev()
            .map(|h| {
                json!({"revision": h.revision, "outcome": h.outcome, "compute_ms": (h.compute_ms * 10.0).round() / 10.0,
                    "risk": h.risk, "added": h.added, "created_at": h.created_at})
            })
            .collect();
        json!({
            "seq": snap.seq,
            "server_t": now_s,
            "anchor_t": snap.anchor_t_s,
            "obstacles": obstacles,
            "aircraft": aircraft,
            "plan": plan,
            "history": history,
            "warnings": warnings,
        })
    }
}
