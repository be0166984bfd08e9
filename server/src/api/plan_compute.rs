//! The planning pipeline behind `POST .../plan`, its replay and `jink plan`: the start, the
//! snapshot a plan reads, one call of the library's replanning seam ([`planner::replan`]),
//! and the wire stack and answer built from its result. No HTTP here beyond the error type.
//!
//! The start is the latest aircraft telemetry (else the stack item before the current
//! index, at the current time, [`stack_start`]). Dynamic risk comes from the mission's live
//! snapshot ([`crate::live`]): the predictor fed with every stored batch and its risk map
//! (10 m cells, 1 s slices over the horizon); the plan never re-reads observations from the
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

use super::plan_types::*;
use super::plans::StrategyIn;
use crate::app::AppState;
use crate::error::ApiError;
use crate::live::Snapshot;
use crate::live::plan_view::{PlanObstacle, PlanWarning, plan_view};
use crate::mission::Mission;
use crate::time::format_rfc3339;
use wire::ids::{MissionId, PlanId};

/// The mission's own waypoints as a wire stack.
pub fn mission_stack_out(m: &Mission) -> Vec<PlanWaypoint> {
    m.content
        .waypoints
        .iter()
        .enumerate()
        .map(|(i, w)| PlanWaypoint {
            lat: w.lat,
            lon: w.lon,
            alt_msl_m: w.alt_msl_m,
            kind: KindOut::Mission,
            mission_index: Some(i),
        })
        .collect()
}

/// The result of [`compute`].
#[derive(Debug, Clone)]
pub struct Computed {
    /// The whole stack.
    pub waypoints: Vec<PlanWaypoint>,
    /// The diff.
    pub diff: DiffOut,
    /// The library's plan (ENU).
    pub plan: planner::Plan,
    /// Dynamic risk used.
    pub dynamic_risk: DynamicRisk,
    /// Obstacles considered and left out.
    pub obstacles: Vec<PlanObstacle>,
    /// Warnings about the inputs.
    pub warnings: Vec<PlanWarning>,
    /// The snapshot's batch number.
    pub observation_seq: i64,
    /// Time taken, ms.
    pub compute_ms: f64,
}

/// A snapshot built from explicit observations (offline plans, plans stored before live
/// state), fed in time then obstacle order.
pub fn snapshot_from_observations(mission: &Mission, observations: &[ObservationUsed]) -> Snapshot {
    let mut rows: Vec<crate::store::ObservationRow> = observations.iter().map(Into::into).collect();
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
    if let Some(seq) = inputs.observation_seq {
        let rows: Vec<crate::store::ObservationRow> = state
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
    let obs = match inputs.observation_window {
        Some(w) => w.fetch(&state.store, &mission.id).await?,
        None => inputs.observations.clone(),
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
    // Stack in ENU: mission items take the mission's own coordinates (no round trip).
    let stack: Vec<StackItem> = inputs
        .stack
        .iter()
        .map(|w| match (w.kind, w.mission_index) {
            (KindOut::Mission, Some(i)) if i < pm.waypoints.len() => {
                StackItem::mission(i, pm.waypoints[i].p_m, pm.waypoints[i].alt_m)
            }
            (KindOut::Search, _) => StackItem::search(frame.to_enu(w.lat, w.lon), w.alt_msl_m),
            _ => StackItem::avoid(frame.to_enu(w.lat, w.lon), w.alt_msl_m),
        })
        .collect();
    let base: Vec<StackItem> = if stack.is_empty() {
        planner::stack::mission_stack(&pm)
    } else {
        stack
    };
    let s = &inputs.start;
    let state = planner::AircraftState {
        p_m: frame.to_enu(s.lat, s.lon),
        alt_m: s.alt_msl_m,
        heading_rad: s.heading_deg.to_radians(),
        speed_mps: s.speed_mps,
        t_s: s.t,
    };

    // Dynamic risk from the live snapshot.
    let view = plan_view(
        mission,
        snap,
        s.t,
        s.source == StartSource::Telemetry,
        inputs.horizon_s,
        inputs.strategy != StrategyIn::Insertion,
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
    let cfg = crate::live::snapshot::service_config(inputs.horizon_s);
    let r = planner::Replan {
        mission: &pm,
        aircraft: planner::Aircraft {
            speed_mps: inputs.speed_mps,
            turn_radius_m: inputs.turn_radius_m,
        },
        state,
        stack: &base,
        current_index: inputs.current_index,
        strategy: match inputs.strategy {
            StrategyIn::Bisection => Strategy::Bisection,
            StrategyIn::Insertion => Strategy::Insertion,
            StrategyIn::None => Strategy::None,
        },
        seed: inputs.seed,
    };
    let mut until = planner::Termination::deadline(deadline);
    if let Some(flag) = cancel {
        until = until.with_cancel(flag);
    }
    let plan = planner::replan(&r, dynamic, &cfg, &until)
        .map_err(|e| ApiError::field("", e.to_string()))?
        .plan;
    let geo = |it: &StackItem| {
        let (lat, lon) = match (it.kind, it.mission_index) {
            (ItemKind::Mission, Some(i)) if i < mission.content.waypoints.len() => (
                mission.content.waypoints[i].lat,
                mission.content.waypoints[i].lon,
            ),
            _ => frame.to_geodetic(it.p_m),
        };
        PlanWaypoint {
            lat,
            lon,
            alt_msl_m: it.alt_m,
            kind: kind_out(it.kind),
            mission_index: it.mission_index,
        }
    };
    // Items taken over from the base stack keep their wire coordinates exactly.
    let base_out: Vec<PlanWaypoint> = if inputs.stack.is_empty() {
        mission_stack_out(mission)
    } else {
        inputs.stack.clone()
    };
    let first = plan.diff.first_changed.unwrap_or(plan.items.len());
    let waypoints: Vec<PlanWaypoint> = plan
        .items
        .iter()
        .enumerate()
        .map(|(i, it)| {
            if i < first && i < base_out.len() {
                base_out[i]
            } else {
                geo(it)
            }
        })
        .collect();
    let diff = DiffOut {
        first_changed: plan.diff.first_changed,
        remove: plan.diff.remove,
        insert: waypoints[first.min(waypoints.len())..].to_vec(),
    };
    Ok(Computed {
        waypoints,
        diff,
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

/// Builds the response document.
pub fn plan_out(
    mission_id: &MissionId,
    plan_id: &PlanId,
    revision: i64,
    base_revision: i64,
    inputs: &PlanInputs,
    c: &Computed,
    now: f64,
) -> PlanOut {
    PlanOut {
        plan_id: plan_id.to_string(),
        mission_id: mission_id.to_string(),
        revision,
        base_revision,
        outcome: outcome_name(c.plan.outcome).to_string(),
        seed: inputs.seed,
        current_index: c.plan.current_index,
        waypoints: c.waypoints.clone(),
        diff: c.diff.clone(),
        risk: c.plan.risk,
        base_risk: c.plan.base_risk,
        exposure_m: c.plan.exposure_m,
        length_m: c.plan.length_m,
        added: c.plan.added,
        turn_violations: c.plan.turn_violations.clone(),
        compute_ms: c.compute_ms,
        dynamic_risk: c.dynamic_risk,
        obstacles: c.obstacles.clone(),
        warnings: c.warnings.clone(),
        observation_seq: c.observation_seq,
        start: inputs.start,
        created_at: format_rfc3339(now),
    }
}

/// A new seed that survives JSON numbers in every client (< 2^53).
pub fn new_seed() -> u64 {
    rand::random::<u64>() >> 11
}

/// No telemetry: start at the stack item before the current index (or the first), heading
/// toward the current one, now.
pub fn stack_start(
    mission: &Mission,
    stack: &[PlanWaypoint],
    current_index: usize,
    now: f64,
) -> StartOut {
    let own;
    let st: &[PlanWaypoint] = if stack.is_empty() {
        own = mission_stack_out(mission);
        &own
    } else {
        stack
    };
    let from = st.get(current_index.saturating_sub(1)).or(st.first());
    let to = st.get(current_index);
    let (lat, lon, alt) = from.map_or(
        (
            mission.home.lat,
            mission.home.lon,
            mission.home.alt_msl_m.unwrap_or(0.0),
        ),
        |w| (w.lat, w.lon, w.alt_msl_m),
    );
    let heading_deg = match to {
        Some(t) => {
            let f = mission.frame();
            let (a, b) = (f.to_enu(lat, lon), f.to_enu(t.lat, t.lon));
            (b[0] - a[0])
                .atan2(b[1] - a[1])
                .to_degrees()
                .rem_euclid(360.0)
        }
        None => 0.0,
    };
    StartOut {
        source: StartSource::Stack,
        t: now,
        lat,
        lon,
        alt_msl_m: alt,
        heading_deg,
        speed_mps: 0.0,
    }
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
