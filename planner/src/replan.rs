//! The replanning seam: the one pipeline from (mission, stack, aircraft, dynamic
//! information, seed) to a plan, used by the server's `POST .../plan` and by the
//! simulator's closed-loop bisection strategy, so both plan the same way.
//!
//! Contract:
//! - Dynamic risk comes from one of [`Dynamic`]: a `&mut Predictor` whose cached risk map
//!   is built or updated here (threat-filtered against the remaining route, anchored at
//!   `t0_s`; what the simulator does), an already built `&RiskMap` with the summaries of
//!   the obstacles it covers (an immutable live snapshot; what the server does), or none.
//! - The risk-map grid of a mission is [`ReplanConfig::map_config`]: the bounding box of
//!   the fly zones and home (the ENU origin) plus `margin_m`, so a live map cached
//!   elsewhere uses the same cells as a map built here.
//! - The least predictable stage among the obstacles in the map sets the sample budget
//!   ([`predictor::Stage::variability`]).
//! - [`Replanned::dynamic`] says what dynamic risk the plan saw: each obstacle with its
//!   stage, whether it is in the map and whether it passed the threat filter.
//! - Deterministic: same inputs, configuration and seed give the same plan bit for bit,
//!   unless `term` stopped the search.
//!
//! # Units
//! ENU metres, seconds on the risk field's clock.

use predictor::{NoRisk, ObstacleSummary, Predictor, RiskField, RiskMap, RiskMapConfig, Stage};

use crate::mission::{Aircraft, Mission};
use crate::plan::{AircraftState, Plan, PlanError, PlanParams, PlanRequest, Strategy, plan_until};
use crate::stack::{StackItem, mission_stack};
use crate::termination::Termination;

/// Risk-map slice interval, seconds.
pub const SLICE_DT_S: f64 = 1.0;

/// The one set of replanning parameters (server and simulator share [`Default`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ReplanConfig {
    /// Margin around the fly zones' (and home's) bounding box, metres. Default 300.
    pub margin_m: f64,
    /// Risk-map template: cell size (default 10 m), resolution schedule, particles, buffer,
    /// seed. Bounds and time axis are set by [`ReplanConfig::map_config`].
    pub map: RiskMapConfig,
    /// Planner parameters (horizon 60 s, samples, buffer fraction...).
    pub plan: PlanParams,
}

impl Default for ReplanConfig {
    fn default() -> Self {
        Self {
            margin_m: 300.0,
            map: RiskMapConfig::default().cell_m(10.0),
            plan: PlanParams::default(),
        }
    }
}

impl ReplanConfig {
    /// Sets the horizon of both the map and the search, seconds.
    pub fn horizon_s(mut self, h: f64) -> Self {
        self.plan.horizon_s = h;
        self
    }

    /// The risk-map configuration of `mission`: bounding box of the fly zones and home
    /// plus `margin_m`, the template's cells, [`SLICE_DT_S`] slices over the horizon.
    pub fn map_config(&self, mission: &Mission) -> RiskMapConfig {
        let (mut lo, mut hi) = ([0.0f64; 2], [0.0f64; 2]);
        for q in mission.fly_zones.iter().flat_map(|z| z.boundary_m.iter()) {
            lo = [lo[0].min(q[0]), lo[1].min(q[1])];
            hi = [hi[0].max(q[0]), hi[1].max(q[1])];
        }
        let m = self.margin_m;
        self.map
            .clone()
            .bounds([lo[0] - m, lo[1] - m], [hi[0] + m, hi[1] + m])
            .time(SLICE_DT_S, self.plan.horizon_s.max(SLICE_DT_S))
    }
}

/// Where dynamic risk comes from.
#[derive(Debug)]
pub enum Dynamic<'a> {
    /// No moving obstacle: static planning only.
    None,
    /// Build or update `predictor`'s cached map anchored at `t0_s`.
    Predictor {
        /// The predictor.
        predictor: &'a mut Predictor,
        /// Slice-0 time, seconds.
        t0_s: f64,
    },
    /// An already built map and the obstacles it was built from (or more).
    Map {
        /// The map.
        map: &'a RiskMap,
        /// Summaries of the observed obstacles.
        obstacles: &'a [ObstacleSummary],
    },
}

/// One obstacle as the plan saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct SeenObstacle {
    /// Obstacle id.
    pub id: String,
    /// Stage used.
    pub stage: Stage,
    /// Whether it is in the risk map.
    pub in_map: bool,
    /// Whether it passed the map's threat filter (contributes risk).
    pub threat: bool,
}

/// What dynamic risk a plan saw.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DynamicSeen {
    /// Whether a risk map was used (false: no dynamic risk).
    pub map_used: bool,
    /// Every obstacle given, by id.
    pub obstacles: Vec<SeenObstacle>,
    /// Sample-budget hint used (least predictable stage in the map).
    pub variability: Option<f64>,
}

/// The static inputs of one replanning call.
#[derive(Debug, Clone, Copy)]
pub struct Replan<'a> {
    /// The mission.
    pub mission: &'a Mission,
    /// Aircraft performance.
    pub aircraft: Aircraft,
    /// Aircraft state (latest telemetry).
    pub state: AircraftState,
    /// The stack flown; empty = the mission's waypoints.
    pub stack: &'a [StackItem],
    /// Index flown toward.
    pub current_index: usize,
    /// Strategy.
    pub strategy: Strategy,
    /// Plan seed.
    pub seed: u64,
}

/// A plan and the dynamic risk it saw.
#[derive(Debug, Clone, PartialEq)]
pub struct Replanned {
    /// The plan.
    pub plan: Plan,
    /// What dynamic risk it saw.
    pub dynamic: DynamicSeen,
}

/// The remaining route from the aircraft: its position then the stack from
/// `current_index` (the threat filter's intended path).
pub fn remaining_route(
    state: &AircraftState,
    stack: &[StackItem],
    current_index: usize,
) -> Vec<[f64; 2]> {
    std::iter::once(state.p_m)
        .chain(stack.iter().skip(current_index).map(|i| i.p_m))
        .collect()
}

fn seen(map: &RiskMap, obstacles: &[ObstacleSummary]) -> DynamicSeen {
    let in_map: Vec<(&str, bool)> = map.obstacles().collect();
    let mut var: Option<f64> = None;
    let obstacles = obstacles
        .iter()
        .map(|o| {
            let hit = in_map.iter().find(|(id, _)| *id == o.id);
            if hit.is_some() {
                let v = o.stage.variability();
                var = Some(var.map_or(v, |a: f64| a.max(v)));
            }
            SeenObstacle {
                id: o.id.clone(),
                stage: o.stage,
                in_map: hit.is_some(),
                threat: hit.is_some_and(|(_, t)| *t),
            }
        })
        .collect();
    DynamicSeen {
        map_used: true,
        obstacles,
        variability: var,
    }
}

/// Replans (see the module docs).
///
/// # Errors
/// [`PlanError`] for bad input only.
pub fn replan(
    r: &Replan<'_>,
    dynamic: Dynamic<'_>,
    cfg: &ReplanConfig,
    term: &Termination,
) -> Result<Replanned, PlanError> {
    let owned;
    let stack = if r.stack.is_empty() {
        owned = mission_stack(r.mission);
        &owned[..]
    } else {
        r.stack
    };
    let (risk, dynamic): (&dyn RiskField, DynamicSeen) = match dynamic {
        Dynamic::None => (&NoRisk, DynamicSeen::default()),
        Dynamic::Predictor { predictor, t0_s } => {
            let summaries: Vec<ObstacleSummary> = predictor.obstacles().collect();
            if summaries.is_empty() {
                (&NoRisk, DynamicSeen::default())
            } else {
                let route = remaining_route(&r.state, stack, r.current_index);
                let map = predictor.risk_map(&cfg.map_config(r.mission), &route, t0_s);
                let s = seen(map, &summaries);
                (map, s)
            }
        }
        Dynamic::Map { map, obstacles } => (map, seen(map, obstacles)),
    };
    let mut params = cfg.plan;
    params.strategy = r.strategy;
    params.variability = dynamic.variability;
    let req = PlanRequest {
        mission: r.mission,
        aircraft: r.aircraft,
        stack,
        current_index: r.current_index,
        state: r.state,
        params,
        seed: r.seed,
    };
    let plan = plan_until(&req, risk, term)?;
    Ok(Replanned { plan, dynamic })
}
