//! The replanning seam: the one pipeline from (mission, stack, aircraft, dynamic
//! information, seed) to a plan, used by the server's `POST .../plan` and by the
//! simulator's closed-loop bisection strategy, so both plan the same way.
//!
//! Contract:
//! - Dynamic risk comes from one of [`Dynamic`]: a `&Predictor` whose live map
//!   ([`live_map`]) is built here (what the simulator does), an already built `&RiskMap`
//!   with the summaries of the obstacles it covers (the server's live snapshot, built by the
//!   same [`live_map`]), or none.
//! - The live map ([`live_map`]) is anchored at the newest observation, covers every
//!   obstacle observed within the horizon before it (older ones are stale), and is not
//!   threat-filtered: a detour meets every obstacle the predictor knows, never only those
//!   near the route it replaces.
//! - The risk-map grid of a mission is [`ReplanConfig::map_config`]: the bounding box of
//!   the fly zones and home (the ENU origin) plus `margin_m`, so a live map cached
//!   elsewhere uses the same cells as a map built here.
//! - 3-D (DESIGN.md "Frames, units, time": a sphere matters if the leg's altitude is within
//!   its radius of its centre): an obstacle whose observed altitude band, grown by its
//!   radius, the map's buffer and [`VERTICAL_MARGIN_M`], does not reach the altitudes of
//!   the route still to fly (the aircraft's and the remaining items') is left out of
//!   every read of the map this plan makes (removed from a map built here, read around in
//!   a shared one); the aircraft passes over or under it. Within the route, each leg
//!   reads the map for its own altitudes ([`predictor::AltitudeView`]: the altitudes
//!   the aircraft may be at along it, [`crate::cost::leg_bands`]), so a sphere that only
//!   another leg's altitudes reach does not stand in this leg's way.
//! - The least predictable stage among the obstacles in the map sets the sample budget
//!   ([`predictor::Stage::variability`]).
//! - [`Replanned::dynamic`] says what dynamic risk the plan saw: each obstacle with its
//!   stage, whether it is in the map and whether it passed the threat filter.
//! - A waypoint the aircraft has pursued longer than [`PlanParams::defer_after_s`]
//!   ([`Replan::target_pending_s`]) is put off to the end of the stack when another
//!   mission waypoint follows it ([`crate::defer`], [`Replanned::deferred`]); not in a
//!   plan that flies a missed waypoint again or skips a captured one.
//! - Deterministic: same inputs, configuration and seed give the same plan bit for bit,
//!   unless `term` stopped the search.
//!
//! # Units
//! ENU metres, seconds on the risk field's clock.

use predictor::{NoRisk, ObstacleSummary, Predictor, RiskField, RiskMap, RiskMapConfig, Stage};

use crate::defer::{Deferred, with_deferred};
use crate::geometry::dist;
use crate::lane::{Lane, LaneField};
use crate::mission::{Aircraft, Mission};
use crate::plan::{AircraftState, Plan, PlanError, PlanParams, PlanRequest, Strategy, plan_until};
use crate::revisit::{with_captured_skipped, with_revisit};
use crate::stack::{StackItem, diff, mission_stack, next_fixed};
use crate::termination::Termination;

/// Risk-map slice interval, seconds. A read takes the worse of the two slices round its
/// time, so a sphere is read up to one interval longer than it is there on each side of a
/// gap; half a second (one second until 2026-11-30) keeps a 7 s window at a swept waypoint
/// a 6-7 s window. (Within the first 15 s, the sparse fine slices, each obstacle is read
/// where its cloud is between the two slices instead, since 2026-12-03:
/// [`predictor::RiskMapConfig::sparse_fine`].) The live map's build grows with the slice
/// count (61 over 30 s).
pub const SLICE_DT_S: f64 = 0.5;

/// An obstacle may leave its observed altitude band by this much within the horizon,
/// metres (the judges' tours change altitude slowly between their waypoints).
pub const VERTICAL_MARGIN_M: f64 = 10.0;

/// The one set of replanning parameters (server and simulator share [`Default`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ReplanConfig {
    /// Margin around the fly zones' (and home's) bounding box, metres. Default 300.
    pub margin_m: f64,
    /// Risk-map template: cell size, resolution schedule, particles, buffer, seed. Bounds
    /// and time axis are set by [`ReplanConfig::map_config`]. Default: 5 m cells up to 15 s
    /// after the map's anchor, kept out of the shared grid and read from the obstacles' own
    /// runs ([`RiskMapConfig::sparse_fine`]), 20 m cells beyond (10 m everywhere up to 15 s
    /// until 2026-12-03: the cell rounding cost the perfect-knowledge planner 11.5 s a
    /// Webster Field flight; README, "Fine slices read from the obstacles' runs").
    pub map: RiskMapConfig,
    /// Planner parameters (horizon [`crate::DEFAULT_HORIZON_S`], samples, buffer fraction...).
    pub plan: PlanParams,
}

impl Default for ReplanConfig {
    fn default() -> Self {
        Self {
            margin_m: 300.0,
            map: RiskMapConfig::default()
                .cell_m(5.0)
                .resolution(15.0, 15.0, 2)
                .sparse_fine(true),
            plan: PlanParams::default(),
        }
    }
}

impl ReplanConfig {
    /// An obstacle whose newest observation is older than the newest observation of all by
    /// more than this is stale: left out of the live map (its prediction has expired).
    /// The horizon, seconds.
    pub fn stale_after_s(&self) -> f64 {
        self.plan.horizon_s
    }

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
pub enum Dynamic<'a> {
    /// No moving obstacle: static planning only.
    None,
    /// Build `predictor`'s live map ([`live_map`]).
    Predictor(&'a Predictor),
    /// A given risk field, e.g. the simulator's ground truth for its oracle (no stage: the
    /// largest sample budget).
    Field(&'a dyn RiskField),
    /// An already built map and the obstacles it was built from (or more).
    Map {
        /// The map.
        map: &'a RiskMap,
        /// Summaries of the observed obstacles.
        obstacles: &'a [ObstacleSummary],
    },
}

impl std::fmt::Debug for Dynamic<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::None => f.write_str("None"),
            Self::Predictor(_) => f.write_str("Predictor(..)"),
            Self::Field(_) => f.write_str("Field(..)"),
            Self::Map { obstacles, .. } => f
                .debug_struct("Map")
                .field("obstacles", &obstacles.len())
                .finish_non_exhaustive(),
        }
    }
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
    /// Whether it was taken out because its altitudes cannot reach the route's.
    pub altitude_clear: bool,
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
    /// How long the next fixed item of the stack (from `current_index` on) has already
    /// been the target, seconds of mission time: the caller keeps it (the server from the
    /// base revision's record, the simulator per run). It lowers the delay credit of the
    /// verification ([`crate::verify::VerifyParams::delay_credit_s`]), so a waypoint is put
    /// off for at most that long in all. `None`: unknown, taken as 0.
    pub target_pending_s: Option<f64>,
    /// Fly the item just passed (`stack[current_index - 1]`) again before the rest: the
    /// caller found it missed ([`crate::revisit::missed_waypoint`]). The plan's stack then
    /// holds a copy of it at `current_index`, and its diff is against `stack` as given.
    pub revisit: bool,
    /// Skip the next fixed item of the stack and the avoid items before it: the caller
    /// found the aircraft captured it on the way ([`crate::revisit::captured_on_the_way`]).
    /// The plan's stack goes on from the item after it, and its diff is against `stack` as
    /// given. Ignored with `revisit` (a copy of the item just passed is then the next fixed
    /// item).
    pub captured: bool,
}

/// A plan and the dynamic risk it saw.
#[derive(Debug, Clone, PartialEq)]
pub struct Replanned {
    /// The plan.
    pub plan: Plan,
    /// What dynamic risk it saw.
    pub dynamic: DynamicSeen,
    /// The waypoint this plan put off to the end of the stack, waited for longer than
    /// [`crate::PlanParams::defer_after_s`] ([`crate::defer`]); the plan's stack and diff
    /// show the move.
    pub deferred: Option<Deferred>,
    /// The near window the plan was verified with, seconds: [`crate::VerifyParams::near_s`],
    /// or [`crate::PlanParams::calm_near_s`] while no obstacle about as fast as the
    /// aircraft is near.
    pub near_s: f64,
}

/// A mission's live risk map and the obstacles in it.
#[derive(Debug, Clone)]
pub struct LiveMap {
    /// Slice-0 time: the newest observation, seconds.
    pub t0_s: f64,
    /// Obstacles in the map (observed at or after `t0_s - stale_after_s`), ascending.
    pub ids: Vec<String>,
    /// The map.
    pub map: RiskMap,
}

/// The obstacles of `predictor` observed at or after `since_t_s`, ascending by id.
pub fn fresh_ids(predictor: &Predictor, since_t_s: f64) -> Vec<String> {
    predictor
        .obstacles()
        .filter(|o| o.last_observation.t_s >= since_t_s)
        .map(|o| o.id)
        .collect()
}

/// Builds the map from obstacles `ids` (ascending) of `predictor` anchored at `t0_s`, one
/// obstacle at a time: the same cells, bit for bit, whoever builds it (a full rebuild).
///
/// # Errors
/// An invalid configuration (a mission whose bounds are degenerate).
pub fn build_map(
    predictor: &Predictor,
    cfg: &RiskMapConfig,
    ids: &[String],
    t0_s: f64,
) -> Result<RiskMap, predictor::RiskMapError> {
    let mut map = RiskMap::new(cfg.clone(), &[], t0_s)?;
    for id in ids {
        predictor.update_map_obstacle(&mut map, id);
    }
    Ok(map)
}

/// The live map of `mission` (see the module docs): anchored at `predictor`'s newest
/// observation, every obstacle observed within the horizon before it, on
/// [`ReplanConfig::map_config`]'s grid. `None` without observations.
///
/// # Errors
/// An invalid configuration (a mission whose bounds are degenerate).
pub fn live_map(
    predictor: &Predictor,
    mission: &Mission,
    cfg: &ReplanConfig,
) -> Result<Option<LiveMap>, predictor::RiskMapError> {
    let Some(t0_s) = predictor.latest_t_s() else {
        return Ok(None);
    };
    let ids = fresh_ids(predictor, t0_s - cfg.stale_after_s());
    let map = build_map(predictor, &cfg.map_config(mission), &ids, t0_s)?;
    Ok(Some(LiveMap { t0_s, ids, map }))
}

/// Whether obstacle `o` is faster than `speed_mps` (its estimated speed) and can reach
/// altitudes `alt_m` ([`reaches_altitudes`]).
fn faster_within(o: &ObstacleSummary, speed_mps: f64, alt_m: [f64; 2], buffer_m: f64) -> bool {
    o.estimates.speed_mps > speed_mps && reaches_altitudes(o, alt_m[0], alt_m[1], buffer_m)
}

/// The distance from `p` to the edge of the nearest obstacle faster than `speed_mps` (its
/// estimated speed) that can reach altitudes `alt_m` ([`reaches_altitudes`]), metres
/// (negative inside it); `None` when there is none ([`PlanParams::fast_obstacle_m`]).
pub fn nearest_fast_obstacle_m(
    obstacles: &[ObstacleSummary],
    speed_mps: f64,
    p: crate::geometry::Point,
    alt_m: [f64; 2],
    buffer_m: f64,
) -> Option<f64> {
    nearest_edge_m(obstacles, p, |o| {
        faster_within(o, speed_mps, alt_m, buffer_m)
    })
}

/// The distance from `p` to the edge of the nearest of `obstacles` that `keep` keeps,
/// metres (negative inside it); `None` when it keeps none.
fn nearest_edge_m(
    obstacles: &[ObstacleSummary],
    p: crate::geometry::Point,
    keep: impl Fn(&ObstacleSummary) -> bool,
) -> Option<f64> {
    obstacles
        .iter()
        .filter(|o| keep(o))
        .map(|o| dist(o.estimates.position_m, p) - o.last_observation.radius_m)
        .reduce(f64::min)
}

/// The near window of a plan for an aircraft at `at` cruising at `speed_mps`
/// ([`PlanParams::calm_near_s`]): `p.calm_near_s` when it is on and shorter than
/// `p.verify.near_s` and no obstacle of `obstacles` that has flown at least
/// `p.calm_speed_factor` times `speed_mps` lately
/// ([`ObstacleSummary::recent_max_speed_mps`]), reaching altitudes `alt_m`, has its edge
/// within `p.calm_m` of `at`; `p.verify.near_s` otherwise.
pub fn calm_near_s(
    p: &PlanParams,
    obstacles: &[ObstacleSummary],
    speed_mps: f64,
    at: crate::geometry::Point,
    alt_m: [f64; 2],
    buffer_m: f64,
) -> f64 {
    let near_s = p.verify.near_s;
    if !(p.calm_near_s > 0.0 && p.calm_near_s < near_s) {
        return near_s;
    }
    let fast_mps = speed_mps * p.calm_speed_factor;
    let near = nearest_edge_m(obstacles, at, |o| {
        o.recent_max_speed_mps > fast_mps && reaches_altitudes(o, alt_m[0], alt_m[1], buffer_m)
    });
    match near {
        Some(d) if d <= p.calm_m => near_s,
        _ => p.calm_near_s,
    }
}

/// The lanes ([`crate::lane`]) of the obstacles faster than the aircraft (`speed_mps`)
/// that reach altitudes `alt_m` and could meet it within `lane_s` seconds of `t_s` (the
/// aircraft at `p`): each disc of radius plus `buffer_m`, carried on at its estimated
/// velocity from `t_s` to `t_s + lane_s`, read at `risk`. The caller passes the obstacles
/// its map holds ([`replan`]: not the stale ones, whose extrapolation means nothing).
#[allow(clippy::too_many_arguments)]
pub fn fast_lanes<'o>(
    obstacles: impl IntoIterator<Item = &'o ObstacleSummary>,
    speed_mps: f64,
    p: crate::geometry::Point,
    t_s: f64,
    alt_m: [f64; 2],
    buffer_m: f64,
    lane_s: f64,
    risk: f64,
) -> Vec<Lane> {
    obstacles
        .into_iter()
        .filter(|o| faster_within(o, speed_mps, alt_m, buffer_m))
        .filter_map(|o| {
            let e = &o.estimates;
            let radius_m = o.last_observation.radius_m + buffer_m;
            let at = [
                e.position_m[0] + e.velocity_mps[0] * (t_s - e.t_s),
                e.position_m[1] + e.velocity_mps[1] * (t_s - e.t_s),
            ];
            let reach = (e.speed_mps + speed_mps) * lane_s + radius_m;
            (dist(at, p) <= reach).then(|| Lane {
                p_m: e.position_m,
                at_s: e.t_s,
                v_mps: e.velocity_mps,
                radius_m,
                window_s: [t_s, t_s + lane_s],
                reach_m: altitude_reach(o, buffer_m),
                risk,
            })
        })
        .collect()
}

/// Whether obstacle `o` can come within its radius plus `buffer_m` of altitudes
/// `[lo_m, hi_m]` (see the module docs).
pub fn reaches_altitudes(o: &ObstacleSummary, lo_m: f64, hi_m: f64, buffer_m: f64) -> bool {
    let [a, b] = altitude_reach(o, buffer_m);
    a <= hi_m && b >= lo_m
}

/// The lowest and highest altitude obstacle `o` can touch with its radius plus `buffer_m`
/// within the horizon: its observed centre altitudes grown by both and
/// [`VERTICAL_MARGIN_M`].
pub fn altitude_reach(o: &ObstacleSummary, buffer_m: f64) -> [f64; 2] {
    let reach = o.last_observation.radius_m + buffer_m + VERTICAL_MARGIN_M;
    let [a, b] = o.alt_range_m;
    [a - reach, b + reach]
}

fn seen(map: &RiskMap, obstacles: &[ObstacleSummary], dropped: &[String]) -> DynamicSeen {
    let in_map: Vec<(&str, bool)> = map.obstacles().collect();
    let mut var: Option<f64> = None;
    let obstacles = obstacles
        .iter()
        .map(|o| {
            let hit = in_map
                .iter()
                .find(|(id, _)| *id == o.id)
                .filter(|_| !dropped.contains(&o.id));
            if hit.is_some() {
                let v = o.stage.variability();
                var = Some(var.map_or(v, |a: f64| a.max(v)));
            }
            SeenObstacle {
                id: o.id.clone(),
                stage: o.stage,
                in_map: hit.is_some(),
                threat: hit.is_some_and(|(_, t)| *t),
                altitude_clear: dropped.contains(&o.id),
            }
        })
        .collect();
    DynamicSeen {
        map_used: true,
        obstacles,
        variability: var,
    }
}

/// A shared map and the obstacles whose altitudes a plan reads it for.
type Banded<'a> = (&'a RiskMap, &'a [ObstacleSummary]);

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
    let given = if r.stack.is_empty() {
        owned = mission_stack(r.mission);
        &owned[..]
    } else {
        r.stack
    };
    let mut deferred = None;
    let rewritten = if r.revisit {
        with_revisit(given, r.current_index)
    } else if r.captured {
        next_fixed(given, r.current_index)
            .and_then(|j| with_captured_skipped(given, r.current_index, j))
    } else {
        // A waypoint waited for too long is put off to the end (PlanParams::defer_after_s).
        let pending = r.target_pending_s.unwrap_or(0.0);
        with_deferred(given, r.current_index, pending, cfg.plan.defer_after_s).map(|(s, d)| {
            deferred = Some(d);
            s
        })
    };
    let stack = rewritten.as_deref().unwrap_or(given);
    // The altitudes still to fly.
    let (mut lo, mut hi) = (r.state.alt_m, r.state.alt_m);
    for it in stack.iter().skip(r.current_index) {
        lo = lo.min(it.alt_m);
        hi = hi.max(it.alt_m);
    }
    let buffer = cfg.map.buffer_m;
    let out_of_reach = |obstacles: &[ObstacleSummary]| -> Vec<String> {
        obstacles
            .iter()
            .filter(|o| !reaches_altitudes(o, lo, hi, buffer))
            .map(|o| o.id.clone())
            .collect()
    };
    let built: RiskMap;
    let summaries: Vec<ObstacleSummary>;
    // The map the plan reads, with the obstacles whose altitudes it reads it for.
    let (risk, dynamic, banded): (&dyn RiskField, DynamicSeen, Option<Banded<'_>>) = match dynamic {
        Dynamic::None => (&NoRisk, DynamicSeen::default(), None),
        Dynamic::Predictor(predictor) => {
            summaries = predictor.obstacles().collect();
            let dropped = out_of_reach(&summaries);
            match live_map(predictor, r.mission, cfg) {
                Ok(Some(mut live)) => {
                    for id in &dropped {
                        live.map.remove_obstacle(id);
                    }
                    built = live.map;
                    let seen = seen(&built, &summaries, &dropped);
                    (&built, seen, Some((&built, &summaries[..])))
                }
                Ok(None) => (&NoRisk, DynamicSeen::default(), None),
                Err(e) => return Err(PlanError::RiskMap(e.to_string())),
            }
        }
        Dynamic::Field(field) => (
            field,
            DynamicSeen {
                map_used: true,
                obstacles: Vec::new(),
                variability: Some(1.0),
            },
            None,
        ),
        Dynamic::Map { map, obstacles } => {
            // The shared map is read without the obstacles out of the route's reach
            // (the view below), not copied to remove them.
            let dropped: Vec<String> = out_of_reach(obstacles)
                .into_iter()
                .filter(|id| map.obstacles().any(|(m, _)| m == id))
                .collect();
            (map, seen(map, obstacles, &dropped), Some((map, obstacles)))
        }
    };
    // Each leg reads the map for its own altitudes: a sphere out of their reach is passed
    // over or under there, though other legs of the route meet it (crate::cost::leg_bands).
    let mut view;
    let risk: &dyn RiskField = match banded {
        Some((map, obstacles)) => {
            // Only obstacles that miss some of the route's altitudes can be left out of
            // a leg (the others cost a query nothing).
            view = map
                .altitude_view(
                    obstacles
                        .iter()
                        .map(|o| {
                            let r = altitude_reach(o, buffer);
                            (o.id.as_str(), r, r[0] <= hi && r[1] >= lo)
                        })
                        .filter(|&(_, r, reaches)| !reaches || r[0] > lo || r[1] < hi)
                        .map(|(id, r, reaches)| (id, reaches.then_some(r))),
                )
                // Obstacles faster than the aircraft, within the near window
                // (VerifyParams::fast_weight; 1, the default, reads every one as it is).
                .fast_weight(
                    r.aircraft.speed_mps,
                    cfg.plan.verify.fast_weight,
                    cfg.plan.verify.near_s,
                );
            // A near window of their own for obstacles faster than the aircraft
            // (VerifyParams::fast_near_s; off by default): read at the ratio of the
            // graded limit to the one graded from their window, they meet the latter.
            let v = &cfg.plan.verify;
            if v.fast_weight <= 1 && v.fast_near_s > v.near_s && cfg.plan.safe_risk > 0.0 {
                let (safe, far, h) = (cfg.plan.safe_risk, v.far_risk, cfg.plan.horizon_s);
                let limit = |near: f64, t: f64| crate::verify::graded_limit(safe, far, near, h, t);
                let (near, fast_near) = (v.near_s, v.fast_near_s);
                view = view.fast_weights(r.aircraft.speed_mps, |t| {
                    limit(near, t) / limit(fast_near, t)
                });
            }
            &view
        }
        None => risk,
    };
    // The lanes of obstacles faster than the aircraft (PlanParams::chase_lane_s), of those
    // the map holds.
    let laned;
    let risk: &dyn RiskField = match banded {
        Some((map, obstacles)) if cfg.plan.chase_lane_s > 0.0 => {
            let lanes = fast_lanes(
                obstacles
                    .iter()
                    .filter(|o| map.obstacles().any(|(id, _)| id == o.id)),
                r.aircraft.speed_mps,
                r.state.p_m,
                r.state.t_s,
                [lo, hi],
                buffer,
                cfg.plan.chase_lane_s,
                cfg.plan.chase_lane_risk,
            );
            if lanes.is_empty() {
                risk
            } else {
                laned = LaneField::new(risk, lanes);
                &laned
            }
        }
        _ => risk,
    };
    let mut params = cfg.plan;
    params.strategy = r.strategy;
    // PlanParams::chase_escape_m reads it.
    params.fast_obstacle_m = banded.and_then(|(_, obstacles)| {
        nearest_fast_obstacle_m(
            obstacles,
            r.aircraft.speed_mps,
            r.state.p_m,
            [lo, hi],
            buffer,
        )
    });
    // A shorter near window while no obstacle about as fast as the aircraft is near
    // (PlanParams::calm_near_s).
    if let Some((_, obstacles)) = banded {
        params.verify.near_s = calm_near_s(
            &params,
            obstacles,
            r.aircraft.speed_mps,
            r.state.p_m,
            [lo, hi],
            buffer,
        );
    }
    // A waypoint captured on the way is skipped (or one waited for too long put off): the
    // next one has only now become the target.
    let skipped = !r.revisit && rewritten.is_some();
    let pending = r
        .target_pending_s
        .filter(|p| p.is_finite() && !skipped)
        .unwrap_or(0.0)
        .max(0.0);
    let overdue_s = (pending - params.verify.delay_credit_s).max(0.0);
    params.verify.delay_credit_s = (params.verify.delay_credit_s - pending).max(0.0);
    if overdue_s > 0.0 {
        // Waited for on a verified circle rather than looped round, for a while
        // (PlanParams::hold_overdue, hold_overdue_max_s).
        params.hold |= params.hold_overdue && overdue_s <= params.hold_overdue_max_s;
        let v = &mut params.verify;
        v.far_risk = (v.far_risk + v.overdue_far_risk_per_s.max(0.0) * overdue_s)
            .min(v.overdue_far_risk_max.max(v.far_risk));
    }
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
    let mut plan = plan_until(&req, risk, term)?;
    if rewritten.is_some() {
        plan.diff = diff(given, &plan.items);
    }
    Ok(Replanned {
        plan,
        dynamic,
        deferred,
        near_s: params.verify.near_s,
    })
}
