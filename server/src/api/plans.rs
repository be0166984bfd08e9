//! Plans: `POST /api/v1/missions/{id}/plan` computes a revised waypoint stack with
//! `planner::plan` (static pre-pass of seed 004 + Monte Carlo bisection of seed 002) and
//! stores it as the mission's next revision; `POST .../plans/{plan_id}/replay` recomputes a
//! stored plan. Its wire types are in [`super::plan_types`], its downloads in
//! [`super::plan_files`].
//!
//! The start is the latest aircraft telemetry (else the stack item before the current
//! index, at the current time). Dynamic risk comes from the mission's live snapshot
//! ([`crate::live`]): the predictor fed with every stored batch and its risk map (10 m
//! cells, 1 s slices over the horizon); the plan never re-reads observations from the
//! store. Which obstacles it considers, which it leaves out and why, and clock warnings
//! follow the time rule of [`crate::live::plan_view`]. The least predictable considered
//! stage sets the search's sample budget (NoFly 1.0, Random 0.8, Advanced 0.5, Memory 0.3
//! as the variability hint). Every plan is stored with its inputs (start, base stack,
//! parameters, the observation batch number its snapshot was cut at) and seed, so replay
//! rebuilds the same snapshot from the store and [`compute`] gives the same plan (bit for
//! bit unless the deadline cut the search short).

use std::time::Instant;

use axum::extract::{Path, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;
use utoipa_axum::{router::OpenApiRouter, routes};

use planner::{ItemKind, StackItem, Strategy};
use predictor::Predictor;

use super::plan_record::{PlanRecord, stored_plan_out};
use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::ApiJson;
use crate::live::Snapshot;
use crate::live::plan_view::{PlanObstacle, PlanWarning, plan_view};
use crate::mission::Mission;
use crate::store::plans::{InsertPlanError, PlanRow};
use crate::time::{format_rfc3339, now_s};
use wire::ids::{MissionId, PlanId};

pub use super::plan_types::*;

/// Longest accepted `deadline_ms`.
const MAX_DEADLINE_MS: u64 = 60_000;

/// Planner to run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum StrategyIn {
    /// Static pre-pass (seed 004) then Monte Carlo bisection on the risk map (seed 002).
    #[default]
    Bisection,
    /// Static pre-pass only: waypoint insertion around cylinders.
    Insertion,
    /// Keep the stack; only evaluate its risk.
    None,
}

/// Aircraft performance.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AircraftIn {
    /// Cruise speed, m/s (default 20; telemetry speed wins when reported).
    #[schema(exclusive_minimum = 0)]
    pub speed_mps: Option<f64>,
    /// Minimum turn radius, metres (default 40).
    #[schema(minimum = 0)]
    pub turn_radius_m: Option<f64>,
}

/// `POST /api/v1/missions/{id}/plan` body (every field optional; `{}` is fine).
#[derive(Debug, Clone, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(example = json!({"seed": 42, "deadline_ms": 200, "base_revision": 0, "current_index": 1}))]
pub struct PlanBody {
    /// Seed of the plan's random choices (default: drawn and returned). Same inputs and
    /// seed, same plan.
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    pub seed: Option<u64>,
    /// Compute budget, milliseconds (anytime: the best plan found by then). Default none.
    #[schema(minimum = 1, maximum = 60000)]
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    pub deadline_ms: Option<u64>,
    /// Planner, default `bisection`.
    pub strategy: Option<StrategyIn>,
    /// The revision the aircraft flies (0 or absent = the mission's own waypoints). Older
    /// than the latest revision: 409.
    #[schema(minimum = 0)]
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    pub base_revision: Option<i64>,
    /// Index in the base stack the aircraft flies toward (MAVLink current sequence).
    /// Default: the base plan's, or 0.
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    pub current_index: Option<usize>,
    /// Aircraft performance.
    pub aircraft: Option<AircraftIn>,
    /// Prediction horizon, seconds, default 60.
    #[schema(exclusive_minimum = 0, maximum = 600)]
    pub horizon_s: Option<f64>,
}

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
/// runtime).
pub fn compute(
    mission: &Mission,
    inputs: &PlanInputs,
    snap: &Snapshot,
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
    let plan = planner::replan(&r, dynamic, &cfg, &planner::Termination::deadline(deadline))
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

/// Builds the response document.
pub fn plan_out(
    mission_id: &str,
    plan_id: String,
    revision: i64,
    base_revision: i64,
    inputs: &PlanInputs,
    c: &Computed,
    now: f64,
) -> PlanOut {
    PlanOut {
        plan_id,
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

/// Plan a revised waypoint stack.
///
/// Starts from the latest aircraft telemetry, revises the base stack (`base_revision`,
/// default the mission's waypoints) from `current_index` on, and stores the result as the
/// mission's next revision. The answer's `diff` says which tail of the base stack to
/// rewrite. A stale `base_revision` (older than the latest) is refused with 409: replan
/// from the latest.
#[utoipa::path(post, path = "/api/v1/missions/{id}/plan", tag = "plans",
    params(("id" = String, Path, description = "Mission id")),
    request_body(content = PlanBody, description = "Planning options (all optional)", content_type = "application/json"),
    responses(
        (status = 201, description = "Planned and stored; `Location` names the plan", body = PlanOut,
            headers(("Location" = String, description = "URL of the stored plan"))),
        (status = 400, description = "Malformed JSON or a field of the wrong type", body = Problem, content_type = "application/problem+json"),
        (status = 404, description = "No such mission", body = Problem, content_type = "application/problem+json"),
        (status = 409, description = "`base_revision` is older than the latest revision", body = Problem, content_type = "application/problem+json"),
        (status = 415, description = "Not a JSON body", body = Problem, content_type = "application/problem+json"),
        (status = 422, description = "Invalid field, named by a JSON pointer", body = Problem, content_type = "application/problem+json"),
    ))]
async fn create_plan(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiJson(body): ApiJson<PlanBody>,
) -> Result<Response, ApiError> {
    let mission = super::missions::load(&state, &id).await?;
    let latest = state.store.latest_plan_revision(&id).await?;
    let base_revision = body.base_revision.unwrap_or(0);
    if base_revision < 0 || base_revision > latest {
        return Err(ApiError::field(
            "/base_revision",
            format!("revision {base_revision} does not exist (latest is {latest})"),
        ));
    }
    if body.base_revision.is_some() && base_revision < latest {
        return Err(ApiError::Conflict(format!(
            "base_revision {base_revision} is older than the latest revision {latest}: plan from revision {latest}"
        )));
    }
    let (stack, base_current) = if base_revision == 0 {
        (Vec::new(), 0)
    } else {
        let row = state
            .store
            .get_plan_by_revision(&id, base_revision)
            .await?
            .ok_or_else(|| ApiError::field("/base_revision", "no such revision"))?;
        let out = stored_plan_out(&row)?;
        (out.waypoints, out.current_index)
    };
    let stack_len = if stack.is_empty() {
        mission.content.waypoints.len()
    } else {
        stack.len()
    };
    let current_index = body.current_index.unwrap_or(base_current);
    if current_index > stack_len {
        return Err(ApiError::field(
            "/current_index",
            format!("must be at most {stack_len} (the stack's length)"),
        ));
    }
    let a = body.aircraft.unwrap_or_default();
    let speed_mps = a.speed_mps.unwrap_or(20.0);
    let turn_radius_m = a.turn_radius_m.unwrap_or(40.0);
    if !(speed_mps.is_finite() && speed_mps > 0.0) {
        return Err(ApiError::field("/aircraft/speed_mps", "must be positive"));
    }
    if !(turn_radius_m.is_finite() && turn_radius_m >= 0.0) {
        return Err(ApiError::field("/aircraft/turn_radius_m", "must be >= 0"));
    }
    let horizon_s = body.horizon_s.unwrap_or(60.0);
    if !(horizon_s.is_finite() && horizon_s > 0.0 && horizon_s <= 600.0) {
        return Err(ApiError::field("/horizon_s", "must be in (0, 600]"));
    }
    if body
        .deadline_ms
        .is_some_and(|d| d == 0 || d > MAX_DEADLINE_MS)
    {
        return Err(ApiError::field(
            "/deadline_ms",
            format!("must be in [1, {MAX_DEADLINE_MS}]"),
        ));
    }
    let now = now_s();
    let telemetry = state.store.list_telemetry(&id, Some(1)).await?;
    let start = match telemetry.last() {
        Some(t) => StartOut {
            source: StartSource::Telemetry,
            t: t.t_s,
            lat: t.lat_deg,
            lon: t.lon_deg,
            alt_msl_m: t.alt_msl_m,
            heading_deg: t.heading_deg,
            speed_mps: t.speed_mps.unwrap_or(0.0),
        },
        None => stack_start(&mission, &stack, current_index, now),
    };
    let snap = state.live.snapshot(&state, &mission).await?;
    let inputs = PlanInputs {
        seed: body.seed.unwrap_or_else(new_seed),
        strategy: body.strategy.unwrap_or_default(),
        deadline_ms: body.deadline_ms,
        horizon_s,
        speed_mps,
        turn_radius_m,
        current_index,
        stack,
        start,
        observations: Vec::new(),
        observation_window: None,
        observation_seq: Some(snap.seq),
    };
    let (m2, in2) = (mission.clone(), inputs.clone());
    let computed = state.run_cpu(move || compute(&m2, &in2, &snap)).await??;
    let plan_id = format!("{:016x}", rand::random::<u64>());
    let revision = latest + 1;
    let out = plan_out(
        &id,
        plan_id.clone(),
        revision,
        base_revision,
        &inputs,
        &computed,
        now,
    );
    let row = PlanRow {
        id: PlanId(plan_id.clone()),
        mission_id: id.clone(),
        revision,
        created_at_s: now,
        seed: inputs.seed,
        // `observation_seq` names the observations (every batch up to it).
        inputs: serde_json::to_string(&inputs).map_err(|e| ApiError::Internal(e.to_string()))?,
        body: PlanRecord::from_out(&out).to_json()?,
    };
    match state.store.insert_plan(&row).await {
        Ok(()) => {}
        Err(InsertPlanError::RevisionTaken(r)) => {
            return Err(ApiError::Conflict(format!(
                "revision {r} was created concurrently: plan again from it"
            )));
        }
        Err(InsertPlanError::NoMission) => return Err(ApiError::not_found("mission", id)),
        Err(InsertPlanError::Db(e)) => return Err(e.into()),
    }
    tracing::info!(mission = %id, revision, outcome = %out.outcome, added = out.added, ms = out.compute_ms, "plan stored");
    let mut resp = (StatusCode::CREATED, axum::Json(out)).into_response();
    resp.headers_mut().insert(
        header::LOCATION,
        HeaderValue::from_str(&format!("/api/v1/missions/{id}/plans/{plan_id}"))
            .map_err(|e| ApiError::Internal(e.to_string()))?,
    );
    Ok(resp)
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

/// The result of replaying a stored plan.
#[derive(Debug, Serialize, ToSchema)]
pub struct ReplayOut {
    /// The plan replayed.
    pub plan_id: String,
    /// True when the replay reproduced the stored plan exactly (everything but
    /// `compute_ms` and `created_at`).
    pub identical: bool,
    /// Why a replay may differ: `deadline` (the plan was cut short by `deadline_ms`, so it
    /// is anytime), `stored_before_live_state` (its observations are replayed through
    /// today's live-state pipeline), or null.
    pub caveat: Option<String>,
    /// The replayed plan.
    pub replayed: PlanOut,
}

/// Replay a stored plan from its stored inputs and seed.
///
/// Recomputes the plan from exactly what it was computed from (the mission, the start, the
/// base stack, the observations it used, the parameters and the seed) and says whether the
/// result is identical. A plan with `deadline_ms` is anytime and may differ.
#[utoipa::path(post, path = "/api/v1/missions/{id}/plans/{plan_id}/replay", tag = "plans",
    params(("id" = String, Path, description = "Mission id"), ("plan_id" = String, Path, description = "Plan id")),
    responses(
        (status = 200, description = "The replayed plan and whether it matches the stored one", body = ReplayOut),
        (status = 404, description = "No such mission or plan", body = crate::error::Problem, content_type = "application/problem+json"),
    ))]
async fn replay_plan(
    State(state): State<AppState>,
    Path((id, plan_id)): Path<(MissionId, PlanId)>,
) -> Result<axum::Json<ReplayOut>, ApiError> {
    let mission = super::missions::load(&state, &id).await?;
    let row = state
        .store
        .get_plan(&id, &plan_id)
        .await?
        .ok_or_else(|| ApiError::not_found("plan", plan_id.clone()))?;
    let inputs: PlanInputs =
        serde_json::from_str(&row.inputs).map_err(|e| ApiError::Internal(e.to_string()))?;
    let stored = stored_plan_out(&row)?;
    let snap = stored_snapshot(&state, &mission, &inputs).await?;
    let in2 = inputs.clone();
    let computed = state
        .run_cpu(move || compute(&mission, &in2, &snap))
        .await??;
    let replayed = plan_out(
        &id,
        row.id.to_string(),
        row.revision,
        stored.base_revision,
        &inputs,
        &computed,
        row.created_at_s,
    );
    let strip = |p: &PlanOut| {
        let mut v = serde_json::to_value(p).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.remove("compute_ms");
            o.remove("created_at");
        }
        v
    };
    Ok(axum::Json(ReplayOut {
        plan_id: row.id.0,
        identical: strip(&stored) == strip(&replayed),
        caveat: if inputs.deadline_ms.is_some() {
            Some("deadline".to_string())
        } else if inputs.observation_seq.is_none() {
            Some("stored_before_live_state".to_string())
        } else {
            None
        },
        replayed,
    }))
}

/// Plan routes.
pub fn router() -> OpenApiRouter<AppState> {
    OpenApiRouter::new()
        .routes(routes!(create_plan))
        .routes(routes!(replay_plan))
}
