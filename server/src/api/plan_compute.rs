//! The planning pipeline behind `POST .../plan`, its replay and `jink plan`: the start, the
//! snapshot a plan reads, one call of the library's replanning seam ([`planner::replan`]),
//! and the stack and answer built from its result. No HTTP here beyond the error type, and
//! no wire or storage shapes: [`PlanInputs`] is the domain form of what a plan depends on,
//! parsed at the edge (the handler, `jink plan`) and stored in its own record
//! ([`super::plan_inputs`]).
//!
//! The start is the latest aircraft telemetry (else the stack item before the current
//! index, at the current time, [`stack_start`]). Dynamic risk comes from the mission's live
//! snapshot ([`crate::live`]): the predictor fed with every stored batch and its risk map
//! (10 m cells, half-second slices over the horizon); the plan never re-reads observations from the
//! store. Which obstacles it considers, which it leaves out and why, and clock warnings
//! follow the time rule of [`crate::live::plan_view`]. The least predictable considered
//! stage sets the search's sample budget ([`predictor::Stage::variability`]). Every plan is
//! stored with its inputs (start, base stack, parameters, the observation batch number its
//! snapshot was cut at) and seed, so replay rebuilds the same snapshot from the store
//! ([`stored_snapshot`]) and [`compute`] gives the same plan (bit for bit unless the
//! deadline cut the search short).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use planner::{ItemKind, StackItem, Strategy};
use predictor::Predictor;

use super::plan_inputs::ObservationWindow;
use super::plan_types::*;
use crate::app::AppState;
use crate::error::ApiError;
use crate::live::Snapshot;
use crate::live::plan_view::{PlanObstacle, PlanWarning, plan_view};
use crate::mission::{Mission, Waypoint};
use crate::store::{ObservationRow, TelemetryRow};
use crate::time::format_rfc3339;
use wire::ids::{MissionId, PlanId};

/// One item of a waypoint stack, in geodetic coordinates (a plan's base stack and the
/// stack it answers).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeoItem {
    /// Where it is (degrees, metres MSL).
    pub at: Waypoint,
    /// What it is for.
    pub kind: ItemKind,
    /// Index into the mission's waypoints, for mission items.
    pub mission_index: Option<usize>,
}

/// Where a plan starts: a telemetry sample, or one made up from the stack
/// ([`stack_start`]; its speed unknown).
#[derive(Debug, Clone, PartialEq)]
pub struct Start {
    /// Whether `at` is the aircraft's own telemetry.
    pub from_telemetry: bool,
    /// Time, position, heading and (when known) speed.
    pub at: TelemetryRow,
}

/// The observations a plan's snapshot is built from.
#[derive(Debug, Clone, PartialEq)]
pub enum Observations {
    /// Every stored batch up to this sequence number (the live snapshot's cut-off).
    Through(i64),
    /// Plans stored before live state: the stored observations of a time window.
    Window(ObservationWindow),
    /// Given explicitly (offline `jink plan`; the first stored plans held them inline).
    Given(Vec<ObservationRow>),
}

/// Everything a plan depends on besides the mission (stored with it for replay).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanInputs {
    /// Seed of the plan's random choices.
    pub seed: u64,
    /// Planner to run.
    pub strategy: Strategy,
    /// Compute budget, milliseconds (none: search to the end).
    pub deadline_ms: Option<u64>,
    /// Prediction horizon, seconds.
    pub horizon_s: f64,
    /// Cruise speed and turn radius.
    pub aircraft: planner::Aircraft,
    /// True when the request gave no turn radius and `aircraft.turn_radius_m` is the
    /// default derived from the speed (the plan then warns `turn_radius_assumed`).
    pub turn_radius_assumed: bool,
    /// The largest bank the aircraft had shown in its telemetry by this plan, degrees
    /// (carried from the base revision; `None`: no turn seen). Without a turn radius in
    /// the request, the radius assumed is a turn at this bank (less a margin), never wider
    /// than the default ([`super::plans::assumed_turn_radius_m`]).
    pub shown_bank_deg: Option<f64>,
    /// The autopilot's waypoint acceptance radius, metres (`None`: the verification's
    /// default, 10).
    pub acceptance_radius_m: Option<f64>,
    /// The autopilot's L1 period, seconds (`None`: the verification's default, ArduPlane's
    /// 17 s).
    pub l1_period_s: Option<f64>,
    /// Index in `stack` the aircraft flies toward.
    pub current_index: usize,
    /// The base stack (empty = the mission's waypoints).
    pub stack: Vec<GeoItem>,
    /// The start.
    pub start: Start,
    /// The observations.
    pub observations: Observations,
    /// Since when (mission seconds, the start's clock) the next fixed item of the stack
    /// from `current_index` on has been the target: carried from the base revision while
    /// the target stays the same ([`planner::Replan::target_pending_s`]). `None`: unknown.
    pub target_since_s: Option<f64>,
    /// The mission waypoint just passed too wide, flown again by this plan
    /// ([`planner::Replan::revisit`]; found from the track when the plan was asked).
    pub revisit: Option<planner::Missed>,
    /// The mission waypoint ahead captured on the way, skipped by this plan with the avoid
    /// items before it ([`planner::Replan::captured`]; found from the track when the plan was asked).
    pub captured: Option<planner::Captured>,
    /// The mission waypoint just passed that only the flight ahead would still capture
    /// ([`planner::Watch`]): not flown again by this plan, judged again at the next one with
    /// the newer telemetry.
    pub watch: Option<planner::Watch>,
    /// Put off the next mission waypoint to the end of the stack once it has been the
    /// target longer than this, seconds ([`planner::PlanParams::defer_after_s`]; 0:
    /// never).
    pub defer_after_s: f64,
}

/// The mission's own waypoints as a stack.
pub fn mission_stack(m: &Mission) -> Vec<GeoItem> {
    m.content
        .waypoints
        .iter()
        .enumerate()
        .map(|(i, w)| GeoItem {
            at: *w,
            kind: ItemKind::Mission,
            mission_index: Some(i),
        })
        .collect()
}

/// The result of [`compute`].
#[derive(Debug, Clone)]
pub struct Computed {
    /// The whole stack (items taken over from the base stack keep its coordinates exactly;
    /// `plan.diff` says which tail changed).
    pub stack: Vec<GeoItem>,
    /// The library's plan (ENU).
    pub plan: planner::Plan,
    /// Dynamic risk used.
    pub dynamic_risk: DynamicRisk,
    /// Obstacles considered and left out.
    pub obstacles: Vec<PlanObstacle>,
    /// Warnings about the inputs.
    pub warnings: Vec<PlanWarning>,
    /// The mission waypoint this plan put off to the end of the stack
    /// ([`planner::Replanned::deferred`]).
    pub deferred: Option<planner::Deferred>,
    /// The snapshot's batch number.
    pub observation_seq: i64,
    /// Time taken, ms.
    pub compute_ms: f64,
}

/// A snapshot built from explicit observations (offline plans, plans stored before live
/// state), fed in time then obstacle order.
pub fn snapshot_from_observations(mission: &Mission, observations: &[ObservationRow]) -> Snapshot {
    let mut rows = observations.to_vec();
    crate::store::observations::sort_feeding_order(&mut rows);
    let mut p = Predictor::new(crate::live::snapshot::predictor_config());
    crate::live::snapshot::feed(&mut p, &mission.frame(), &rows);
    Snapshot::build(mission, 0, std::sync::Arc::new(p))
}

/// Rebuilds the snapshot a stored plan used: batches through `observation_seq`, or (plans
/// stored before live state) the observation window it named.
///
/// # Errors
/// Database failures.
pub async fn stored_snapshot(
    state: &AppState,
    mission: &Mission,
    inputs: &PlanInputs,
) -> Result<Snapshot, ApiError> {
    let obs = match &inputs.observations {
        &Observations::Through(seq) => {
            let rows: Vec<ObservationRow> = state
                .store
                .list_observations_through(&mission.id, -1, seq)
                .await?
                .into_iter()
                .map(|(_, r)| r)
                .collect();
            let m = mission.clone();
            return state
                .run_cpu(move || {
                    let mut p = Predictor::new(crate::live::snapshot::predictor_config());
                    crate::live::snapshot::feed(&mut p, &m.frame(), &rows);
                    Snapshot::build(&m, seq, std::sync::Arc::new(p))
                })
                .await;
        }
        Observations::Window(w) => w.fetch(&state.store, &mission.id).await?,
        Observations::Given(obs) => obs.clone(),
    };
    let m = mission.clone();
    state
        .run_cpu(move || snapshot_from_observations(&m, &obs))
        .await
}

/// Plans `mission` from `inputs` and the live `snap` (CPU work: call it off the async
/// runtime). The search stops early at `inputs.deadline_ms` or when `cancel` is raised
/// (the plan is then anytime: its outcome says `timeout`).
pub fn compute(
    mission: &Mission,
    inputs: &PlanInputs,
    snap: &Snapshot,
    cancel: Option<Arc<AtomicBool>>,
) -> Result<Computed, ApiError> {
    let started = Instant::now();
    let deadline = inputs
        .deadline_ms
        .map(|ms| started + std::time::Duration::from_millis(ms));
    let frame = mission.frame();
    let pm = mission.to_planner();
    let base = enu_stack(&pm, &frame, &inputs.stack);
    let s = &inputs.start.at;
    let state = planner::AircraftState {
        p_m: frame.to_enu(s.lat_deg, s.lon_deg),
        alt_m: s.alt_msl_m,
        heading_rad: s.heading_deg.to_radians(),
        speed_mps: s.speed_mps.unwrap_or(0.0),
        t_s: s.t_s,
    };

    // Dynamic risk from the live snapshot.
    let view = plan_view(
        mission,
        snap,
        s.t_s,
        inputs.start.from_telemetry,
        inputs.horizon_s,
        inputs.strategy != Strategy::Insertion,
    )
    .map_err(|e| ApiError::Internal(format!("risk map: {e}")))?;
    let map = view.map.clone();
    let summaries: Vec<predictor::ObstacleSummary> = match &map {
        Some(_) => snap.predictor.obstacles().collect(),
        None => Vec::new(),
    };
    let dynamic = match &map {
        Some(m) => planner::Dynamic::Map {
            map: m.as_ref(),
            obstacles: &summaries,
        },
        None => planner::Dynamic::None,
    };
    // One pipeline with the simulator: the seam sets the sample budget from the least
    // predictable stage in the map (seed 002).
    let mut cfg = crate::live::snapshot::service_config(inputs.horizon_s);
    if let Some(a) = inputs.acceptance_radius_m {
        cfg.plan.verify.acceptance_m = a;
    }
    if let Some(p) = inputs.l1_period_s {
        cfg.plan.verify.l1_s = planner::verify::l1_seconds(p);
    }
    cfg.plan.defer_after_s = inputs.defer_after_s;
    let r = planner::Replan {
        mission: &pm,
        aircraft: inputs.aircraft,
        state,
        stack: &base,
        current_index: inputs.current_index,
        strategy: inputs.strategy,
        seed: inputs.seed,
        target_pending_s: inputs.target_since_s.map(|since| (s.t_s - since).max(0.0)),
        revisit: inputs.revisit.is_some(),
        captured: inputs.captured.is_some(),
    };
    let mut until = planner::Termination::deadline(deadline);
    if let Some(flag) = cancel {
        until = until.with_cancel(flag);
    }
    let replanned = planner::replan(&r, dynamic, &cfg, &until)
        .map_err(|e| ApiError::field("", e.to_string()))?;
    let (plan, deferred) = (replanned.plan, replanned.deferred);
    let geo = |it: &StackItem| {
        let (lat, lon) = match (it.kind, it.mission_index) {
            (ItemKind::Mission, Some(i)) if i < mission.content.waypoints.len() => (
                mission.content.waypoints[i].lat,
                mission.content.waypoints[i].lon,
            ),
            _ => frame.to_geodetic(it.p_m),
        };
        GeoItem {
            at: Waypoint {
                lat,
                lon,
                alt_msl_m: it.alt_m,
            },
            kind: it.kind,
            mission_index: it.mission_index,
        }
    };
    // Items taken over from the base stack keep their coordinates exactly.
    let base_geo: Vec<GeoItem> = if inputs.stack.is_empty() {
        mission_stack(mission)
    } else {
        inputs.stack.clone()
    };
    let first = plan.diff.first_changed.unwrap_or(plan.items.len());
    let stack: Vec<GeoItem> = plan
        .items
        .iter()
        .enumerate()
        .map(|(i, it)| {
            if i < first && i < base_geo.len() {
                base_geo[i]
            } else {
                geo(it)
            }
        })
        .collect();
    Ok(Computed {
        stack,
        dynamic_risk: DynamicRisk {
            source: if map.is_some() {
                DynamicSource::RiskMap
            } else {
                DynamicSource::None
            },
            obstacles: view.obstacles.iter().filter(|o| o.considered).count(),
        },
        obstacles: view.obstacles,
        warnings: view.warnings,
        deferred,
        observation_seq: snap.seq,
        plan,
        compute_ms: started.elapsed().as_secs_f64() * 1e3,
    })
}

/// Raises its flag when dropped. A request's plan is searched with this flag as its cancel
/// flag, so when the request's future is dropped (the client went away) the search stops
/// instead of running to completion on the CPU pool for nobody.
#[derive(Debug, Default)]
pub struct CancelOnDrop(Arc<AtomicBool>);

impl CancelOnDrop {
    /// The flag to hand to [`compute`].
    pub fn flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.0)
    }
}

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// Builds the response document: the map taken as current (the caller sets the lag of a
/// live plan) and written by the current request's writer ([`crate::auth::writer`]).
pub fn plan_out(
    mission_id: &MissionId,
    plan_id: &PlanId,
    revision: i64,
    base_revision: i64,
    inputs: &PlanInputs,
    c: &Computed,
    now: f64,
) -> PlanOut {
    let waypoints: Vec<PlanWaypoint> = c.stack.iter().map(PlanWaypoint::from).collect();
    PlanOut {
        plan_id: plan_id.to_string(),
        mission_id: mission_id.to_string(),
        revision,
        base_revision,
        outcome: outcome_name(c.plan.outcome).to_string(),
        seed: inputs.seed,
        current_index: c.plan.current_index,
        diff: DiffOut::of(c.plan.diff.first_changed, c.plan.diff.remove, &waypoints),
        waypoints,
        risk: c.plan.risk,
        base_risk: c.plan.base_risk,
        exposure_m: c.plan.exposure_m,
        length_m: c.plan.length_m,
        added: c.plan.added,
        turn_violations: c.plan.turn_violations.clone(),
        compute_ms: c.compute_ms,
        dynamic_risk: c.dynamic_risk,
        obstacles: c.obstacles.clone(),
        warnings: warnings_of(inputs, c),
        observation_seq: c.observation_seq,
        map_lag_batches: 0,
        map_age_ms: 0.0,
        target_pending_s: inputs
            .target_since_s
            .map(|since| (inputs.start.at.t_s - since).max(0.0)),
        written_by: crate::auth::writer(),
        start: StartOut::from(&inputs.start),
        created_at: format_rfc3339(now),
    }
}

/// The plan's warnings: its view's, and `turn_radius_assumed` when the request gave no
/// turn radius.
fn warnings_of(inputs: &PlanInputs, c: &Computed) -> Vec<PlanWarning> {
    let mut w = c.warnings.clone();
    if inputs.turn_radius_assumed {
        let speed_mps = planned_speed_mps(&inputs.start, inputs.aircraft.speed_mps);
        w.push(PlanWarning {
            code: "turn_radius_assumed".into(),
            message: format!(
                "no aircraft.turn_radius_m in the request: turns assumed at {:.1} m ({:.1} degrees of bank at {:.1} m/s; {}). Send the aircraft's own minimum turn radius: a radius smaller than the aircraft's lets a plan hold turns the aircraft flies wide of.",
                inputs.aircraft.turn_radius_m,
                planner::shown_turn::bank_for_radius_rad(speed_mps, inputs.aircraft.turn_radius_m)
                    .to_degrees(),
                speed_mps,
                match inputs.shown_bank_deg {
                    Some(b) if b > super::plans::DEFAULT_BANK_DEG => format!(
                        "the telemetry has shown turns at {b:.1} degrees of bank, planned 3 degrees below, at most 45"
                    ),
                    _ => format!(
                        "the default, {} degrees, until the telemetry shows harder turns",
                        super::plans::DEFAULT_BANK_DEG
                    ),
                },
            ),
        });
    }
    if let Some(m) = inputs.revisit {
        w.push(PlanWarning {
            code: "waypoint_revisited".into(),
            message: format!(
                "mission waypoint {} (stack item {}) was passed {:.1} m away, wider than the judges' 100 ft (30.48 m): the plan flies it again before the rest (a waypoint is passed three times at most; \"revisit_missed\": false turns this off)",
                m.mission_index, m.stack_index, m.closest_m
            ),
        });
    }
    if let Some(c) = inputs.captured {
        w.push(PlanWarning {
            code: "waypoint_captured_on_the_way".into(),
            message: format!(
                "mission waypoint {} (stack item {}) was passed {:.1} m away on the way, within the judges' 100 ft (30.48 m) less a margin, before the autopilot switched past it: the judges count it, so the plan skips it and any avoid items before it (\"skip_captured\": false turns this off)",
                c.mission_index, c.stack_index, c.closest_m
            ),
        });
    }
    if let Some(d) = c.deferred {
        w.push(PlanWarning {
            code: "waypoint_deferred".into(),
            message: format!(
                "mission waypoint {} (stack item {}) has been the target for {:.0} s, longer than {:.0} s: the plan puts it off to the end of the stack, flies the waypoints after it first and tries it again last (\"defer_after_s\": 0 turns this off)",
                d.mission_index, d.stack_index, d.pending_s, inputs.defer_after_s
            ),
        });
    }
    w
}

/// The speed the planner times the route with ([`planner::Aircraft::route_speed_mps`]):
/// the start's when known, else the request's cruise speed.
pub fn planned_speed_mps(start: &Start, cruise_mps: f64) -> f64 {
    planner::Aircraft {
        speed_mps: cruise_mps,
        ..planner::Aircraft::default()
    }
    .route_speed_mps(start.at.speed_mps.unwrap_or(0.0))
}

/// `stack` in ENU (empty: the mission's waypoints); mission items take the mission's own
/// coordinates (no round trip through degrees).
fn enu_stack(
    pm: &planner::Mission,
    frame: &wire::geodesy::LocalFrame,
    stack: &[GeoItem],
) -> Vec<StackItem> {
    if stack.is_empty() {
        return planner::stack::mission_stack(pm);
    }
    stack
        .iter()
        .map(|w| match (w.kind, w.mission_index) {
            (ItemKind::Mission, Some(i)) if i < pm.waypoints.len() => {
                StackItem::mission(i, pm.waypoints[i].p_m, pm.waypoints[i].alt_m)
            }
            (ItemKind::Search, _) => {
                StackItem::search(frame.to_enu(w.at.lat, w.at.lon), w.at.alt_msl_m)
            }
            _ => StackItem::avoid(frame.to_enu(w.at.lat, w.at.lon), w.at.alt_msl_m),
        })
        .collect()
}

/// `stack` (empty: the mission's) and `telemetry` (oldest first) in the planner's ENU terms,
/// for [`planner::judge_pass`] and [`planner::captured_on_the_way`].
pub fn enu_track(
    mission: &Mission,
    stack: &[GeoItem],
    telemetry: &[TelemetryRow],
) -> (Vec<StackItem>, Vec<planner::TrackPoint>) {
    let frame = mission.frame();
    let track = telemetry
        .iter()
        .map(|r| planner::TrackPoint {
            t_s: r.t_s,
            p_m: frame.to_enu(r.lat_deg, r.lon_deg),
            alt_m: r.alt_msl_m,
        })
        .collect();
    (enu_stack(&mission.to_planner(), &frame, stack), track)
}

/// A new seed that survives JSON numbers in every client (< 2^53).
pub fn new_seed() -> u64 {
    rand::random::<u64>() >> 11
}

/// No telemetry: start at the stack item before the current index (or the first), heading
/// toward the current one, now, speed unknown.
pub fn stack_start(mission: &Mission, stack: &[GeoItem], current_index: usize, now: f64) -> Start {
    let own;
    let st: &[GeoItem] = if stack.is_empty() {
        own = mission_stack(mission);
        &own
    } else {
        stack
    };
    let from = st.get(current_index.saturating_sub(1)).or(st.first());
    let at = from.map_or(
        Waypoint {
            lat: mission.home.lat,
            lon: mission.home.lon,
            alt_msl_m: mission.home.alt_msl_m.unwrap_or(0.0),
        },
        |w| w.at,
    );
    let heading_deg = st.get(current_index).map_or(0.0, |to| {
        bearing_deg(mission, (at.lat, at.lon), (to.at.lat, to.at.lon))
    });
    Start {
        from_telemetry: false,
        at: TelemetryRow {
            t_s: now,
            lat_deg: at.lat,
            lon_deg: at.lon,
            alt_msl_m: at.alt_msl_m,
            heading_deg,
            speed_mps: None,
        },
    }
}

/// The heading from `from` toward `to` (both `(lat, lon)`, degrees) in the mission's frame,
/// degrees true in [0, 360).
pub fn bearing_deg(mission: &Mission, from: (f64, f64), to: (f64, f64)) -> f64 {
    let f = mission.frame();
    let (a, b) = (f.to_enu(from.0, from.1), f.to_enu(to.0, to.1));
    (b[0] - a[0])
        .atan2(b[1] - a[1])
        .to_degrees()
        .rem_euclid(360.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dropping_the_guard_raises_the_flag_it_handed_out() {
        let guard = CancelOnDrop::default();
        let flag = guard.flag();
        assert!(!flag.load(Ordering::Relaxed));
        drop(guard);
        assert!(flag.load(Ordering::Relaxed));
        assert!(planner::Termination::none().with_cancel(flag).should_stop());
    }
}
