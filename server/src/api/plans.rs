//! Plans: `POST /api/v1/missions/{id}/plan` computes a revised waypoint stack with
//! `planner::plan` (static pre-pass of seed 004 + Monte Carlo bisection of seed 002) and
//! stores it as the mission's next revision; `POST .../plans/{plan_id}/replay` recomputes a
//! stored plan. Its wire types are in [`super::plan_types`], its downloads in
//! [`super::plan_files`].
//!
//! The pipeline itself (start, snapshot, the library's replanning seam, the answer) is in
//! [`super::plan_compute`], shared with `jink plan`.

use axum::extract::{Path, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;
use utoipa_axum::{router::OpenApiRouter, routes};

use super::plan_compute::{
    CancelOnDrop, GeoItem, Observations, PlanInputs, Start, compute, enu_track, new_seed, plan_out,
    planned_speed_mps, stack_start, stored_snapshot,
};
use super::plan_inputs::{InputsRecord, stored_inputs};
use super::plan_record::{PlanRecord, stored_plan_out};
use crate::app::AppState;
use crate::error::{ApiError, Problem};
use crate::extract::ApiJson;
use crate::store::plans::{InsertPlanError, PlanRow};
use crate::time::now_s;
use crate::timing::ServerTiming;
use wire::ids::{MissionId, PlanId};

pub use super::plan_types::*;

/// Longest accepted `deadline_ms`.
const MAX_DEADLINE_MS: u64 = 60_000;
/// The longest wait `defer_after_s` accepts, seconds (a day).
const MAX_DEFER_AFTER_S: f64 = 86_400.0;

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

impl From<StrategyIn> for planner::Strategy {
    fn from(s: StrategyIn) -> Self {
        match s {
            StrategyIn::Bisection => Self::Bisection,
            StrategyIn::Insertion => Self::Insertion,
            StrategyIn::None => Self::None,
        }
    }
}

/// Aircraft performance.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AircraftIn {
    /// Cruise speed, m/s (default 20; the telemetry's ground speed wins when reported or
    /// when it can be estimated from the last 2 s of telemetry), at most 200.
    #[schema(exclusive_minimum = 0, maximum = 200)]
    pub speed_mps: Option<f64>,
    /// Minimum turn radius, metres, at most 10 000. Default: the radius of a coordinated
    /// turn at the speed flown (the telemetry's, reported or estimated, else `speed_mps`)
    /// at 30 degrees of bank, v^2 / (g tan 30 deg) (71 m at 20 m/s, 45 m at 16 m/s), or,
    /// once the telemetry has shown the aircraft turning harder (carried from the base
    /// revision), at the bank shown less 3 degrees, at most 45. Send your aircraft's own:
    /// a radius below the aircraft's is not safe (the plan's turns are flown wider than it
    /// verified).
    #[schema(minimum = 0, maximum = 10000)]
    pub turn_radius_m: Option<f64>,
    /// The autopilot's waypoint acceptance radius, metres (ArduPlane `WP_RADIUS`, PX4
    /// `NAV_ACC_RAD`): it goes on to the next item within this distance of the current one
    /// (or on passing it). The plan's check of its routes flies them so. Default 10, at
    /// most 500. The judges count a waypoint within 100 ft: above about 25 m the autopilot
    /// turns away before it captures them.
    #[schema(minimum = 0, maximum = 500)]
    pub acceptance_radius_m: Option<f64>,
    /// The autopilot's L1 period, seconds (ArduPlane `NAVL1_PERIOD`, damping
    /// `NAVL1_DAMPING` taken at its default 0.75): the plan's check of its routes flies
    /// them with this L1 distance, `0.75 * period * speed / pi`, which a slow aircraft
    /// that banks hard turns wider under than its turn radius allows. Default 17 (the
    /// ArduPlane default), from 5 to 60.
    #[schema(minimum = 5, maximum = 60)]
    pub l1_period_s: Option<f64>,
}

/// The largest acceptance radius a plan accepts, metres.
pub(crate) const MAX_ACCEPTANCE_RADIUS_M: f64 = 500.0;

/// The L1 periods a plan accepts, seconds.
pub(crate) const L1_PERIOD_RANGE_S: std::ops::RangeInclusive<f64> = 5.0..=60.0;

/// Whether `r` is an acceptance radius a plan accepts (finite, 0 to
/// [`MAX_ACCEPTANCE_RADIUS_M`]): the API's rule and `jink plan`'s.
pub(crate) fn valid_acceptance_radius_m(r: f64) -> bool {
    r.is_finite() && (0.0..=MAX_ACCEPTANCE_RADIUS_M).contains(&r)
}

/// Whether `p` is an L1 period a plan accepts (finite, within [`L1_PERIOD_RANGE_S`]): the
/// API's rule and `jink plan`'s.
pub(crate) fn valid_l1_period_s(p: f64) -> bool {
    p.is_finite() && L1_PERIOD_RANGE_S.contains(&p)
}

/// Bank angle of the default turn radius ([`default_turn_radius_m`]), degrees.
pub const DEFAULT_BANK_DEG: f64 = 30.0;

/// The turn radius assumed when a plan request gives none: a coordinated turn at
/// [`DEFAULT_BANK_DEG`] of bank at `speed_mps`, v^2 / (g tan bank). Fixed-wing UAVs at the
/// competition fly 25-45 degrees of bank; a radius below the aircraft's own lets a plan hold
/// turns the aircraft flies wide (stop 30 measured a 40 m default on a 58 m aircraft: 6
/// cylinder hits in 40 runs), so the default takes the cautious end.
pub fn default_turn_radius_m(speed_mps: f64) -> f64 {
    const G_MPS2: f64 = 9.806_65;
    speed_mps * speed_mps / (G_MPS2 * DEFAULT_BANK_DEG.to_radians().tan())
}

/// The turn radius assumed when a plan request gives none, at `speed_mps`: a turn at the
/// bank the aircraft has shown in its telemetry (`shown_bank_deg`, see
/// [`planner::shown_turn`]; 3 degrees less, at most 45), and never below
/// [`DEFAULT_BANK_DEG`], so the default radius ([`default_turn_radius_m`]) until the
/// aircraft has turned harder.
pub fn assumed_turn_radius_m(speed_mps: f64, shown_bank_deg: Option<f64>) -> f64 {
    let params = planner::shown_turn::ShownTurnParams::default();
    let bank = planner::shown_turn::planned_bank_rad(
        shown_bank_deg.map(f64::to_radians),
        DEFAULT_BANK_DEG.to_radians(),
        &params,
    );
    planner::shown_turn::radius_for_bank_m(speed_mps, bank)
}

/// The bank (degrees) the `track`'s samples (in time order) show the aircraft sustaining
/// in a turn ([`planner::shown_turn::shown_bank_rad`]); `None` when they show no turn.
pub(crate) fn shown_bank_deg(
    track: &[crate::store::TelemetryRow],
    frame: &wire::geodesy::LocalFrame,
) -> Option<f64> {
    let samples: Vec<planner::shown_turn::HeadingSample> = track
        .iter()
        .map(|r| {
            let p = frame.to_enu(r.lat_deg, r.lon_deg);
            planner::shown_turn::HeadingSample {
                t_s: r.t_s,
                p_m: [p[0], p[1]],
                heading_rad: r.heading_deg.to_radians(),
                speed_mps: r.speed_mps,
            }
        })
        .collect();
    planner::shown_turn::shown_bank_rad(&samples, &Default::default()).map(f64::to_degrees)
}

/// Newest telemetry samples a plan reads: the newest is its start, the others give its
/// ground speed when the newest does not report one ([`with_track_speed`]) and the bank
/// it turns at ([`shown_bank_deg`]).
const TRACK_SAMPLES: u32 = 32;

/// At most this many telemetry samples show whether a waypoint was missed
/// ([`planner::revisit`]): 20 minutes at 5 Hz of pursuing one waypoint.
const REVISIT_SAMPLES: u32 = 6000;

/// A ground speed is estimated from pairs of samples at least this far apart, seconds...
const TRACK_MIN_S: f64 = 0.5;
/// ... and at most this far apart...
const TRACK_MAX_S: f64 = 2.0;
/// ... among the samples of the newest this-many seconds.
const TRACK_SPAN_S: f64 = 5.0;

/// `newest` with a ground speed: its own when reported, else the median, over every pair
/// of samples of `track` (the newest samples, in time order) within [`TRACK_SPAN_S`] of
/// it and [`TRACK_MIN_S`] to [`TRACK_MAX_S`] apart, of the distance between the two over
/// the time between. The interop telemetry forms carry no speed; without this a plan would
/// time the route at the request's cruise speed (20 m/s by default) whatever the aircraft
/// flies. In a turn the chord is shorter than the arc flown (2 % at 20 degrees a second
/// over 2 s), so each chord is lengthened to the arc of a steady turn through the heading
/// change between its two samples ([`arc_over_chord`]). One pair carries its two
/// positions' noise: 1 m of GPS noise on a 1 s pair at 20 m/s read 17-23 m/s in the
/// simulator, and a speed read low makes the assumed turn radius (v^2 / g tan bank) tighter
/// than the aircraft's; the median of the pairs reads through it.
/// No estimate when no pair is in range: the request's cruise speed is used.
pub(crate) fn with_track_speed(
    newest: &crate::store::TelemetryRow,
    track: &[crate::store::TelemetryRow],
    frame: &wire::geodesy::LocalFrame,
) -> crate::store::TelemetryRow {
    let mut at = newest.clone();
    if at.speed_mps.is_some() {
        return at;
    }
    let recent: Vec<(f64, [f64; 2], f64)> = track
        .iter()
        .filter(|r| (0.0..=TRACK_SPAN_S).contains(&(newest.t_s - r.t_s)))
        .map(|r| (r.t_s, frame.to_enu(r.lat_deg, r.lon_deg), r.heading_deg))
        .collect();
    let mut speeds = Vec::new();
    for (i, a) in recent.iter().enumerate() {
        for b in &recent[i + 1..] {
            let dt = b.0 - a.0;
            if dt < TRACK_MIN_S {
                continue;
            }
            if dt > TRACK_MAX_S {
                break;
            }
            let turn = (b.2 - a.2).to_radians();
            let v = (b.1[0] - a.1[0]).hypot(b.1[1] - a.1[1]) * arc_over_chord(turn) / dt;
            if v.is_finite() && v > 0.0 && v <= wire::telemetry::MAX_SPEED_MPS {
                speeds.push(v);
            }
        }
    }
    if !speeds.is_empty() {
        let mid = speeds.len() / 2;
        at.speed_mps = Some(*speeds.select_nth_unstable_by(mid, f64::total_cmp).1);
    }
    at
}

/// How much longer the arc of a steady turn through `turn_rad` (any angle; wrapped to
/// [-pi, pi]) is than its chord: (x/2) / sin(x/2). A heading change above 150 degrees
/// between two samples at most 2 s apart is no steady turn of a fixed-wing aircraft (a
/// heading that wraps or jumps): the chord is then taken as it is.
fn arc_over_chord(turn_rad: f64) -> f64 {
    let x =
        (turn_rad + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if x.abs() / 2.0 > 75f64.to_radians() {
        1.0
    } else {
        geom::arc_over_chord(x)
    }
}

/// The largest turn radius a plan accepts, metres.
const MAX_TURN_RADIUS_M: f64 = 10_000.0;

/// `POST /api/v1/missions/{id}/plan` body (every field optional; `{}` is fine).
#[derive(Debug, Clone, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(example = json!({"seed": 42, "deadline_ms": 200, "base_revision": 0, "current_index": 1}))]
pub struct PlanBody {
    /// Seed of the plan's random choices (default: drawn and returned). Same inputs and
    /// seed, same plan. Any unsigned 64-bit integer (`uint64`: the simulator's client
    /// and `jink demo` send seeds above 2^63).
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    #[schema(format = "uint64")]
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
    /// Prediction horizon, seconds, default 30 (`planner::DEFAULT_HORIZON_S`; the live
    /// risk map covers it, so a plan with another horizon builds its own map).
    #[schema(exclusive_minimum = 0, maximum = 600)]
    pub horizon_s: Option<f64>,
    /// Plan on the last published risk map while the oldest batch it lacks was accepted
    /// at most this long ago, milliseconds (the answer's `map_lag_batches` and
    /// `map_age_ms` say what it lacked); older, the plan waits for the map of every
    /// accepted batch, and it always waits for a batch that brings a new obstacle. 0:
    /// always wait (read your writes). Default: the server's `--plan-map-max-age-ms` (250).
    #[schema(minimum = 0, maximum = 60000)]
    #[serde(default, deserialize_with = "crate::extract::opt_integer")]
    pub max_map_age_ms: Option<u64>,
    /// Fly a missed mission waypoint again (default true): when the aircraft's telemetry
    /// shows it has just gone past the item before `current_index`, a mission waypoint,
    /// farther than the judges' 100 ft (30.48 m), the plan flies that item again before the
    /// rest (a waypoint is passed three times at most) and warns `waypoint_revisited`.
    /// `false`: never.
    pub revisit_missed: Option<bool>,
    /// Skip a mission waypoint captured on the way (default true): when the aircraft's
    /// telemetry since the base revision pursued the next mission waypoint came within 25 m
    /// of it (three dimensions; the judges' 100 ft less a margin for the telemetry's error)
    /// while the autopilot flew toward it (short of its acceptance radius and finish line)
    /// or toward an avoid item before it, the plan drops the avoid items before it and the
    /// waypoint, goes on to the next item, and warns `waypoint_captured_on_the_way`. The
    /// last item of a stack is never skipped. `false`: never.
    pub skip_captured: Option<bool>,
    /// Put off a waypoint that cannot be reached (default 240): once the next mission
    /// waypoint has been the target for longer than this many seconds (the clock the
    /// answer's `target_pending_s` shows, carried from the base revision), the plan moves
    /// it with the avoid items before it to the end of the stack, flies the waypoints after
    /// it first, and warns `waypoint_deferred`. The last mission waypoint left is never put
    /// off. 0: never.
    #[schema(minimum = 0, maximum = 86400)]
    pub defer_after_s: Option<f64>,
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
        (status = 409, description = "`base_revision` is older than the latest revision; `latest_revision` names the latest", body = Problem, content_type = "application/problem+json"),
    ))]
async fn create_plan(
    State(state): State<AppState>,
    Path(id): Path<MissionId>,
    ApiJson(body): ApiJson<PlanBody>,
) -> Result<Response, ApiError> {
    // Refused at once (503) when the plan pool is full, before any work.
    let ticket = state.plans.admit()?;
    let mut timing = ServerTiming::start();
    // The three reads a plan needs, at once (on PostgreSQL each is a round trip to the
    // database; on SQLite they are answered from memory, `store::recent`).
    let (mission, latest, telemetry) = tokio::join!(
        super::missions::load(&state, &id),
        state.store.latest_plan_revision(&id),
        state.store.list_telemetry(&id, Some(TRACK_SAMPLES)),
    );
    let (mission, latest, telemetry) = (mission?, latest?, telemetry?);
    timing.lap("read");
    let base_revision = body.base_revision.unwrap_or(0);
    if base_revision < 0 || base_revision > latest {
        return Err(ApiError::NoSuchBase {
            base_revision,
            latest,
        });
    }
    if body.base_revision.is_some() && base_revision < latest {
        return Err(ApiError::StaleBase {
            base_revision,
            latest,
        });
    }
    // The base revision's stack, current index and pursuit of its next fixed item (the
    // item's index in that stack and since when it has been the target).
    let mut base_shown_bank = None;
    let mut base_watch = None;
    let (stack, base_current, base_target) = if base_revision == 0 {
        (Vec::new(), 0, None)
    } else {
        let row = state
            .store
            .get_plan_by_revision(&id, base_revision)
            .await?
            .ok_or(ApiError::NoSuchBase {
                base_revision,
                latest,
            })?;
        let base = stored_revision(&row)?;
        base_shown_bank = base.inputs.shown_bank_deg;
        base_watch = base.inputs.watch;
        (base.stack, base.current_index, base.pursuit)
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
    let max_speed = wire::telemetry::MAX_SPEED_MPS;
    if !(speed_mps.is_finite() && speed_mps > 0.0 && speed_mps <= max_speed) {
        return Err(ApiError::field(
            "/aircraft/speed_mps",
            format!("must be in (0, {max_speed}] m/s"),
        ));
    }
    if let Some(r) = a.turn_radius_m
        && !(r.is_finite() && (0.0..=MAX_TURN_RADIUS_M).contains(&r))
    {
        return Err(ApiError::field(
            "/aircraft/turn_radius_m",
            format!("must be in [0, {MAX_TURN_RADIUS_M}] m"),
        ));
    }
    if let Some(r) = a.acceptance_radius_m
        && !valid_acceptance_radius_m(r)
    {
        return Err(ApiError::field(
            "/aircraft/acceptance_radius_m",
            format!("must be in [0, {MAX_ACCEPTANCE_RADIUS_M}] m"),
        ));
    }
    if let Some(p) = a.l1_period_s
        && !valid_l1_period_s(p)
    {
        return Err(ApiError::field(
            "/aircraft/l1_period_s",
            format!(
                "must be in [{}, {}] s",
                L1_PERIOD_RANGE_S.start(),
                L1_PERIOD_RANGE_S.end()
            ),
        ));
    }
    let horizon_s = body.horizon_s.unwrap_or(planner::DEFAULT_HORIZON_S);
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
    if body.max_map_age_ms.is_some_and(|a| a > MAX_DEADLINE_MS) {
        return Err(ApiError::field(
            "/max_map_age_ms",
            format!("must be in [0, {MAX_DEADLINE_MS}]"),
        ));
    }
    let defer_after_s = body
        .defer_after_s
        .unwrap_or(planner::PlanParams::default().defer_after_s);
    if !(defer_after_s.is_finite() && (0.0..=MAX_DEFER_AFTER_S).contains(&defer_after_s)) {
        return Err(ApiError::field(
            "/defer_after_s",
            format!("must be in [0, {MAX_DEFER_AFTER_S}] s (0: never)"),
        ));
    }
    let now = now_s();
    let start = match telemetry.last() {
        Some(t) => Start {
            from_telemetry: true,
            at: with_track_speed(t, &telemetry, &mission.frame()),
        },
        None => stack_start(&mission, &stack, current_index, now),
    };
    // The largest bank the aircraft has shown: carried from the base revision, and what
    // the newest telemetry shows.
    let shown_bank_deg = [
        base_shown_bank,
        shown_bank_deg(&telemetry, &mission.frame()),
    ]
    .into_iter()
    .flatten()
    .reduce(f64::max);
    let turn_radius_m = a.turn_radius_m.unwrap_or_else(|| {
        assumed_turn_radius_m(planned_speed_mps(&start, speed_mps), shown_bank_deg)
            .min(MAX_TURN_RADIUS_M)
    });
    // Putting the next waypoint off is bounded in total (planner::Replan::target_pending_s):
    // the clock runs from the first plan that flew toward it, on the start's clock.
    // A client that keeps no revision (no `base_revision`: each plan from the mission's own
    // waypoints, `current_index` a mission index) still gets the clock of the waypoint it
    // flies toward: the latest revision's, when that revision pursued the same mission
    // waypoint. Without it every such plan started the clock again, and putting a waypoint
    // off was never bounded (`jink simulate --strategies server-mission`: Webster Field with
    // mixed spheres ran out of time in 2 of 40 runs, 786 and 872 avoid targets).
    let next = next_fixed(&stack, mission.content.waypoints.len(), current_index);
    let latest_pursued = if body.base_revision.is_none() && latest > 0 && next.is_some() {
        latest_pursuit(&state, &id, latest).await?
    } else {
        None
    };
    let target_since_s = match (next, base_target) {
        (Some(k), Some((base_k, since))) if k == base_k => Some(since),
        // No base: `k` is the mission index of the waypoint flown toward.
        (Some(k), None) if stack.is_empty() => Some(
            latest_pursued
                .filter(|&(m, _)| m == k)
                .map_or(start.at.t_s, |(_, since)| since),
        ),
        (Some(_), _) => Some(start.at.t_s),
        (None, _) => None,
    };
    // The waypoint the base revision pursued (none before the first plan: nothing says
    // when the mission's own waypoints became the target), and what the track since says
    // of it: passed too wide just now (flown again), or captured on the way, still the next
    // fixed item (skipped: the judges count it within 100 ft, the autopilot switches only
    // within its acceptance radius or past the finish line). A waypoint passed that only
    // the flight ahead would capture is watched: the base revision keeps it and this plan
    // judges it again (planner::judge_pass). The track is read only when the autopilot has
    // just gone past that waypoint, while it is watched, or while an avoid item before it
    // is the target; while it is the item flown toward, the newest telemetry in hand
    // serves.
    let (mut revisit, mut captured, mut watch) = (None, None, None);
    let revisit_on = body.revisit_missed.unwrap_or(true);
    let base_watch = base_watch.filter(|w| revisit_on && current_index == w.stack_index + 1);
    let pursued = base_target.filter(|&(k, _)| revisit_on && current_index == k + 1);
    // Still the next fixed item, and the client lets a captured one be skipped.
    let skippable =
        base_target.filter(|&(k, _)| body.skip_captured != Some(false) && next == Some(k));
    let behind = skippable.filter(|&(k, _)| k > current_index);
    let toward = skippable.filter(|&(k, _)| k == current_index && start.from_telemetry);
    let judged = base_watch.map(|w| w.since_s).or(pursued.map(|(_, s)| s));
    let since = judged
        .into_iter()
        .chain(behind.map(|(_, s)| s))
        .reduce(f64::min);
    if let Some(since) = since {
        let track = state
            .store
            .list_telemetry_since(&id, since - planner::revisit::TRACK_GAP_S, REVISIT_SAMPLES)
            .await?;
        let (base, track) = enu_track(&mission, &stack, &track);
        if let Some(judged) = judged {
            // The track from the pass's own time on, as the simulator reads it.
            let from = track.partition_point(|p| p.t_s < judged - planner::revisit::TRACK_GAP_S);
            match planner::judge_pass(
                &base,
                current_index,
                pursued,
                base_watch,
                &track[from..],
                turn_radius_m,
            ) {
                Some(planner::Pass::Missed(m)) => revisit = Some(m),
                Some(planner::Pass::Watch(w)) => watch = Some(w),
                None => {}
            }
        }
        // A revisit asked in the same plan wins.
        if let Some(pursued) = behind.filter(|_| revisit.is_none()) {
            captured = planner::captured_on_the_way(&base, current_index, pursued, &track);
        }
    }
    // The waypoint flown toward: only the last few seconds of the track count
    // (planner::revisit::FLOWN_TOWARD_S), which the newest telemetry in hand holds unless
    // it comes faster than 6 Hz.
    if let Some(pursued) = toward.filter(|_| revisit.is_none()) {
        let newest = telemetry.last().map_or(pursued.1, |r| r.t_s);
        let from = pursued.1.max(newest - planner::revisit::FLOWN_TOWARD_S);
        let read;
        let rows = if telemetry.first().is_some_and(|r| r.t_s <= from) {
            &telemetry[..]
        } else {
            read = state
                .store
                .list_telemetry_since(&id, from - planner::revisit::TRACK_GAP_S, REVISIT_SAMPLES)
                .await?;
            &read[..]
        };
        let (base, track) = enu_track(&mission, &stack, rows);
        captured = planner::captured_on_the_way(&base, current_index, pursued, &track);
    }
    let max_age = body.max_map_age_ms.map(std::time::Duration::from_millis);
    let (snap, lag) = state.live.plan_snapshot(&state, &mission, max_age).await?;
    timing.lap("snapshot");
    let inputs = PlanInputs {
        seed: body.seed.unwrap_or_else(new_seed),
        strategy: body.strategy.unwrap_or_default().into(),
        deadline_ms: body.deadline_ms,
        horizon_s,
        aircraft: planner::Aircraft {
            speed_mps,
            turn_radius_m,
        },
        turn_radius_assumed: a.turn_radius_m.is_none(),
        shown_bank_deg,
        acceptance_radius_m: a.acceptance_radius_m,
        l1_period_s: a.l1_period_s,
        current_index,
        stack,
        start,
        observations: Observations::Through(snap.seq),
        target_since_s,
        revisit,
        captured,
        watch,
        defer_after_s,
    };
    let (m2, in2) = (mission.clone(), inputs.clone());
    let cancel = CancelOnDrop::default();
    let flag = cancel.flag();
    let computed = ticket
        .run(&state.cpu, move || compute(&m2, &in2, &snap, Some(flag)))
        .await??;
    // The pool's queue and its hop to a worker thread and back: all but the computation.
    timing.lap_split("pool", "compute", computed.compute_ms);
    let plan_id = PlanId(format!("{:016x}", rand::random::<u64>()));
    let revision = latest + 1;
    let out = PlanOut {
        map_lag_batches: lag.batches,
        map_age_ms: lag.age_ms,
        ..plan_out(
            &id,
            &plan_id,
            revision,
            base_revision,
            &inputs,
            &computed,
            now,
        )
    };
    let row = PlanRow {
        id: plan_id.clone(),
        mission_id: id.clone(),
        revision,
        created_at_s: now,
        seed: inputs.seed,
        // The record names the observations (every batch up to the snapshot's).
        inputs: InputsRecord::of(&inputs).to_json()?,
        body: PlanRecord::from_out(&out).to_json()?,
        written_by: out.written_by.clone(),
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
    timing.lap("store");
    tracing::info!(mission = %id, revision, outcome = %out.outcome, added = out.added, ms = out.compute_ms, "plan stored");
    let mut resp = (StatusCode::CREATED, axum::Json(out)).into_response();
    crate::timing::insert(&mut resp, &timing);
    resp.headers_mut().insert(
        header::LOCATION,
        HeaderValue::from_str(&format!("/api/v1/missions/{id}/plans/{plan_id}"))
            .map_err(|e| ApiError::Internal(e.to_string()))?,
    );
    Ok(resp)
}

/// The result of replaying a stored plan.
#[derive(Debug, Serialize, ToSchema)]
pub struct ReplayOut {
    /// The plan replayed.
    pub plan_id: String,
    /// True when the replay reproduced the stored plan exactly (everything but
    /// `compute_ms`, `created_at`, `map_lag_batches` and `map_age_ms`).
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
    ))]
async fn replay_plan(
    State(state): State<AppState>,
    Path((id, plan_id)): Path<(MissionId, PlanId)>,
) -> Result<axum::Json<ReplayOut>, ApiError> {
    let ticket = state.plans.admit()?;
    let mission = super::missions::load(&state, &id).await?;
    let row = state
        .store
        .get_plan(&id, &plan_id)
        .await?
        .ok_or_else(|| ApiError::not_found("plan", plan_id.clone()))?;
    let inputs: PlanInputs = stored_inputs(&row)?;
    let stored = stored_plan_out(&row)?;
    let snap = stored_snapshot(&state, &mission, &inputs).await?;
    let in2 = inputs.clone();
    let cancel = CancelOnDrop::default();
    let flag = cancel.flag();
    let computed = ticket
        .run(&state.cpu, move || {
            compute(&mission, &in2, &snap, Some(flag))
        })
        .await??;
    let replayed = PlanOut {
        written_by: row.written_by.clone(),
        ..plan_out(
            &id,
            &row.id,
            row.revision,
            stored.base_revision,
            &inputs,
            &computed,
            row.created_at_s,
        )
    };
    // What the plan's computation does not decide: its duration, and how far the live
    // map it read lagged (a replay rebuilds exactly that map, so it lags by nothing).
    let strip = |p: &PlanOut| {
        let mut v = serde_json::to_value(p).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            for k in ["compute_ms", "created_at", "map_lag_batches", "map_age_ms"] {
                o.remove(k);
            }
        }
        v
    };
    Ok(axum::Json(ReplayOut {
        plan_id: row.id.0,
        identical: strip(&stored) == strip(&replayed),
        caveat: if inputs.deadline_ms.is_some() {
            Some("deadline".to_string())
        } else if !matches!(inputs.observations, Observations::Through(_)) {
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

/// The mission waypoint revision `revision` pursued (the mission index of its next fixed
/// item) and since when, on the start's clock; `None` when it pursued none or recorded no
/// clock.
async fn latest_pursuit(
    state: &AppState,
    id: &MissionId,
    revision: i64,
) -> Result<Option<(usize, f64)>, ApiError> {
    let Some(row) = state.store.get_plan_by_revision(id, revision).await? else {
        return Ok(None);
    };
    let r = stored_revision(&row)?;
    Ok(r.pursuit
        .and_then(|(k, since)| r.stack[k].mission_index.map(|m| (m, since))))
}

/// What a stored revision flew, as the next plan reads it.
struct StoredRevision {
    stack: Vec<GeoItem>,
    current_index: usize,
    /// Its next fixed item (an index into `stack`) and since when it has been the target.
    pursuit: Option<(usize, f64)>,
    /// The inputs it was planned from.
    inputs: PlanInputs,
}

/// Reads a stored revision's stack, current index, pursuit and inputs.
fn stored_revision(row: &PlanRow) -> Result<StoredRevision, ApiError> {
    let out = stored_plan_out(row)?;
    let stack: Vec<GeoItem> = out.waypoints.iter().map(GeoItem::from).collect();
    let inputs = stored_inputs(row)?;
    // The clock it kept is that of its base's next fixed item. A plan that skipped a
    // waypoint captured on the way, or flew a missed one again, aims at another item,
    // which has been the target since that plan, as in the simulator
    // (sim::strategy::TargetClock::aim). Carried over, the next waypoint counted the
    // skipped one's time as its own and went overdue early.
    let pursuit = next_fixed(&stack, 0, out.current_index).and_then(|k| {
        if same_target(&inputs, &stack[k]) {
            inputs.target_since_s.map(|since| (k, since))
        } else {
            Some((k, inputs.start.at.t_s))
        }
    });
    Ok(StoredRevision {
        stack,
        current_index: out.current_index,
        pursuit,
        inputs,
    })
}

/// Whether `item`, a plan's next fixed item, is the next fixed item of the stack the plan
/// was asked for (`inputs`): the same mission waypoint (by its index; a missed one flown
/// again is an earlier index), or for an item of no mission index the same place.
fn same_target(inputs: &PlanInputs, item: &GeoItem) -> bool {
    if inputs.stack.is_empty() {
        return item.kind == planner::ItemKind::Mission
            && item.mission_index == Some(inputs.current_index);
    }
    let Some(before) = next_fixed(&inputs.stack, 0, inputs.current_index) else {
        return false;
    };
    let b = &inputs.stack[before];
    // A millionth of a degree is about 0.1 m: a place read back through the store.
    let near = |x: f64, y: f64| (x - y).abs() < 1e-6;
    b.kind == item.kind
        && b.mission_index == item.mission_index
        && (item.mission_index.is_some()
            || (near(b.at.lat, item.at.lat)
                && near(b.at.lon, item.at.lon)
                && (b.at.alt_msl_m - item.at.alt_msl_m).abs() < 0.1))
}

/// Index of the first fixed item (not an avoid item) at or after `current_index` in
/// `stack`, or in the mission's own `mission_len` waypoints when `stack` is empty.
fn next_fixed(stack: &[GeoItem], mission_len: usize, current_index: usize) -> Option<usize> {
    if stack.is_empty() {
        return (current_index < mission_len).then_some(current_index);
    }
    stack
        .get(current_index..)?
        .iter()
        .position(|g| g.kind != planner::ItemKind::Avoid)
        .map(|k| current_index + k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::TelemetryRow;

    fn sample(t_s: f64, east_m: f64, speed_mps: Option<f64>) -> TelemetryRow {
        let frame = wire::geodesy::LocalFrame::new(38.0, -76.0);
        let (lat_deg, lon_deg) = frame.to_geodetic([east_m, 0.0]);
        TelemetryRow {
            t_s,
            lat_deg,
            lon_deg,
            alt_msl_m: 100.0,
            heading_deg: 90.0,
            speed_mps,
        }
    }

    #[test]
    fn the_default_turn_radius_is_a_thirty_degree_bank_turn_at_the_speed() {
        // r = v^2 / (g tan 30 deg), computed independently: tan 30 deg = 1/sqrt(3).
        for v in [10.0_f64, 16.0, 20.0, 35.0] {
            let expected = v * v * 3f64.sqrt() / 9.806_65;
            assert!((default_turn_radius_m(v) - expected).abs() < 1e-9, "{v}");
        }
        assert!((default_turn_radius_m(20.0) - 70.6).abs() < 0.1);
        assert!((default_turn_radius_m(16.0) - 45.2).abs() < 0.1);
        // The sim's 20 m/s aircraft at 35 degrees (58 m) is inside the default.
        assert!(default_turn_radius_m(20.0) > 400.0 / (9.806_65 * 35f64.to_radians().tan()));
    }

    #[test]
    fn a_start_without_a_reported_speed_takes_the_ground_speed_of_the_last_two_seconds() {
        let frame = wire::geodesy::LocalFrame::new(38.0, -76.0);
        // 5 Hz, 16 m/s east, no speed reported (the interop forms): the sample 2 s back.
        let track: Vec<TelemetryRow> = (0..20)
            .map(|k| sample(100.0 + 0.2 * f64::from(k), 3.2 * f64::from(k), None))
            .collect();
        let at = with_track_speed(track.last().unwrap(), &track, &frame);
        let v = at.speed_mps.expect("estimated");
        assert!((v - 16.0).abs() < 1e-6, "{v}");
        assert_eq!(at.t_s, track.last().unwrap().t_s);
        assert_eq!(at.lat_deg, track.last().unwrap().lat_deg);

        // A reported speed is kept as it is.
        let mut reported = track.clone();
        reported.last_mut().unwrap().speed_mps = Some(18.0);
        let at = with_track_speed(reported.last().unwrap(), &reported, &frame);
        assert_eq!(at.speed_mps, Some(18.0));

        // No pair 0.5-2 s apart (a lone sample, or one 3 s old): no estimate.
        let lone = [sample(100.0, 0.0, None)];
        assert_eq!(with_track_speed(&lone[0], &lone, &frame).speed_mps, None);
        let gap = [sample(100.0, 0.0, None), sample(103.0, 48.0, None)];
        assert_eq!(with_track_speed(&gap[1], &gap, &frame).speed_mps, None);
        // In a steady turn (20 degrees a second at 20 m/s, 5 Hz) the chord of 2 s is 2 %
        // shorter than the arc flown: the estimate is the arc's speed, through north too.
        let (r_m, w) = (20.0 / 20f64.to_radians(), 20f64.to_radians());
        let turning: Vec<TelemetryRow> = (0..20)
            .map(|k| {
                let t = 0.2 * f64::from(k);
                let psi = -0.5 + w * t; // heading from north, through 0 into the east
                let (e, n) = (r_m * (1.0 - psi.cos()), r_m * psi.sin());
                let mut row = sample(100.0 + t, 0.0, None);
                let (lat, lon) = frame.to_geodetic([e, n]);
                row.lat_deg = lat;
                row.lon_deg = lon;
                row.heading_deg = psi.to_degrees().rem_euclid(360.0);
                row
            })
            .collect();
        let v = with_track_speed(turning.last().unwrap(), &turning, &frame)
            .speed_mps
            .expect("estimated");
        assert!((v - 20.0).abs() < 0.02, "{v}");
        let chord = {
            let (a, b) = (&turning[9], &turning[19]);
            let (pa, pb) = (
                frame.to_enu(a.lat_deg, a.lon_deg),
                frame.to_enu(b.lat_deg, b.lon_deg),
            );
            (pb[0] - pa[0]).hypot(pb[1] - pa[1]) / (b.t_s - a.t_s)
        };
        assert!(chord < 19.8, "the chord alone reads {chord}");
        assert_eq!(arc_over_chord(0.0), 1.0);
        assert_eq!(arc_over_chord(std::f64::consts::PI), 1.0);
        assert!(
            (arc_over_chord(-(60f64.to_radians())) - arc_over_chord(60f64.to_radians())).abs()
                < 1e-12
        );
        assert!(
            (arc_over_chord((360f64 - 40.0).to_radians()) - arc_over_chord(40f64.to_radians()))
                .abs()
                < 1e-9
        );

        // 1 Hz, 20 m/s north, GPS noise of 1 m (1 sigma, each axis; a fixed pseudo-random
        // sequence): over 60 plans the median of the pairs errs about half as much as the
        // one pair 2 s back that was read before.
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut gauss = move || {
            let mut u = || {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let noisy: Vec<TelemetryRow> = (0..66)
            .map(|k| {
                let mut row = sample(100.0 + f64::from(k), 0.0, None);
                let (lat, lon) = frame.to_geodetic([gauss(), 20.0 * f64::from(k) + gauss()]);
                row.lat_deg = lat;
                row.lon_deg = lon;
                row.heading_deg = 0.0;
                row
            })
            .collect();
        let (mut median_sq, mut pair_sq) = (0.0, 0.0);
        for k in 6..66 {
            let v = with_track_speed(&noisy[k], &noisy[..=k], &frame)
                .speed_mps
                .expect("estimated");
            median_sq += (v - 20.0).powi(2);
            let (a, b) = (&noisy[k - 2], &noisy[k]);
            let (pa, pb) = (
                frame.to_enu(a.lat_deg, a.lon_deg),
                frame.to_enu(b.lat_deg, b.lon_deg),
            );
            pair_sq += ((pb[0] - pa[0]).hypot(pb[1] - pa[1]) / 2.0 - 20.0).powi(2);
        }
        let (median_rms, pair_rms) = ((median_sq / 60.0).sqrt(), (pair_sq / 60.0).sqrt());
        assert!(
            median_rms < 0.7 * pair_rms && median_rms < 0.5,
            "median {median_rms:.3} against one pair {pair_rms:.3} m/s"
        );

        // Two samples at the same place: 0 m/s is no speed to time a route by.
        let still = [sample(100.0, 5.0, None), sample(101.0, 5.0, None)];
        assert_eq!(with_track_speed(&still[1], &still, &frame).speed_mps, None);
    }
}
