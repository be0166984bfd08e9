//! Strategy plug-in point: what the ground station (or the onboard computer, for the reactive
//! avoiders) decides from what it would really know.
//!
//! A [`Strategy`] is called every [`Strategy::period_s`] with a [`View`]: the aircraft's own
//! state, the mission, the stack it flies, the obstacle telemetry received so far (noisy,
//! with dropouts -- never ground truth) and, for strategies that ask for one, a simulated
//! LiDAR scan. It answers a [`Command`]: keep the stack, replace it, or steer directly for a
//! while.

use serde::{Deserialize, Serialize};

use crate::aircraft::{AircraftParams, AircraftState};
use crate::lidar::{LidarParams, Scan};
use crate::mission::{Mission, Stack};
use crate::scenario::MovingSphere;
use crate::telemetry::ObstacleObservation;

pub mod bisection;
pub mod constant_velocity;
pub mod insertion;
pub mod oracle;
pub mod reactive;
pub mod route;
pub mod tangent;

/// What a strategy may look at.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// Mission time, seconds.
    pub t_s: f64,
    /// The aircraft's own state (its autopilot knows it).
    pub own: AircraftState,
    /// Its positions as sent to the judges `(t, ENU x, y, altitude)`, oldest first (what a
    /// ground station has kept).
    pub own_track: &'a [(f64, [f64; 3])],
    /// Aircraft performance.
    pub aircraft: &'a AircraftParams,
    /// The mission (fly zone, waypoints, cylinders: all given by the judges up front).
    pub mission: &'a Mission,
    /// The stack being flown.
    pub stack: &'a Stack,
    /// Per moving obstacle, the telemetry received up to `t_s`, in time order.
    pub tracks: &'a [&'a [ObstacleObservation]],
    /// The latest LiDAR scan, when the strategy asked for a scanner.
    pub scan: Option<&'a Scan>,
    /// Ground truth of the moving spheres: only the oracle may look.
    pub truth: &'a [MovingSphere],
}

/// A strategy's answer.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Keep flying the stack.
    Keep,
    /// Upload a new stack.
    Replace(Stack),
    /// Fly this turn rate (rad/s, counter-clockwise positive) for `hold_s`, then resume the stack.
    Steer {
        /// Commanded turn rate, rad/s.
        turn_rate_rad_s: f64,
        /// How long, seconds.
        hold_s: f64,
    },
}

/// A decision procedure run in closed loop.
pub trait Strategy: Send {
    /// Replanning period, seconds.
    fn period_s(&self) -> f64;
    /// The scanner this strategy needs, if any.
    fn lidar(&self) -> Option<LidarParams> {
        None
    }
    /// Decides from what the aircraft would know.
    fn decide(&mut self, view: &View<'_>) -> Command;
    /// Milliseconds of the last [`Strategy::decide`] spent on work `jink serve` does when
    /// obstacle telemetry arrives, not while it answers a plan request: feeding the
    /// predictor and building the live risk map (the server keeps both in its live state
    /// and rebuilds the map in the background per batch). The run reports the rest of the
    /// call as the replan time, this part separately. `None`: no such work.
    fn take_live_ms(&mut self) -> Option<f64> {
        None
    }
    /// The same part of the last [`Strategy::decide`] in the thread's CPU time
    /// ([`crate::cpu::thread_cpu_ms`]), milliseconds. `None`: no such work, or no CPU clock.
    fn take_live_cpu_ms(&mut self) -> Option<f64> {
        None
    }
}

/// The predictor stage a Monte Carlo bisection run is forced to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForcedStage {
    /// Stage 1, a growing disc.
    NoFly,
    /// Stage 2, uniform turn rates.
    Random,
    /// Stage 3, the obstacle's own turn histogram.
    Advanced,
    /// Stage 4, histogram conditioned on the previous turn.
    Memory,
}

/// The strategies the simulator knows, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StrategyKind {
    /// Fly the mission's waypoints unchanged.
    None,
    /// The planner's seed 004 waypoint insertion around cylinders (static pre-pass only).
    Insertion,
    /// Shortest path around cylinders on a tangent graph (static only).
    Tangent,
    /// Tangent graph plus detours around constant-velocity extrapolations of the spheres.
    ConstantVelocity,
    /// Monte Carlo bisection with the predictor forced to one stage.
    Bisection(ForcedStage),
    /// Monte Carlo bisection with automatic staging.
    BisectionAuto,
    /// Tangent graph plus the onboard offset algorithm and Bezier pilot on a LiDAR.
    ReactiveOffset,
    /// Tangent graph plus the onboard sector avoider on a LiDAR.
    ReactiveSectors,
    /// Monte Carlo bisection against the spheres' true future: the ceiling.
    Oracle,
    /// `mc-auto` asked of a running `jink serve` over HTTP: the mission uploaded, the
    /// obstacle and aircraft telemetry posted as a ground station would, each plan asked
    /// with `POST .../plan` and flown as answered. Built by the factory a program
    /// registers with [`register_server`] (`jink simulate` does; this crate cannot start
    /// the service itself). Not in [`StrategyKind::ALL`]: asked for by name only.
    Server,
    /// [`StrategyKind::Server`] as a client that tells the service the least: aircraft
    /// telemetry without a speed (as the interop telemetry forms send it) and plan requests
    /// without `aircraft` (the service's defaults: 20 m/s, 40 m turn radius).
    ServerBare,
    /// [`StrategyKind::Server`] as a client that keeps no revision: every plan request
    /// goes without `base_revision` (the mission's own waypoints, DESIGN.md's default),
    /// with `current_index` the mission index of the next mission waypoint of the stack it
    /// flies, and flies each answer from the answer's `current_index`.
    ServerMission,
}

/// Builds the [`StrategyKind::Server`], [`StrategyKind::ServerBare`] or
/// [`StrategyKind::ServerMission`] strategy for one run from the run's seed.
pub type ServerFactory = Box<dyn Fn(StrategyKind, u64) -> Box<dyn Strategy> + Send + Sync>;

static SERVER: std::sync::OnceLock<ServerFactory> = std::sync::OnceLock::new();

/// Registers how [`StrategyKind::Server`], [`StrategyKind::ServerBare`] and
/// [`StrategyKind::ServerMission`] are built (once per process).
///
/// # Errors
/// The factory given back when one is registered already.
pub fn register_server(factory: ServerFactory) -> Result<(), ServerFactory> {
    SERVER.set(factory)
}

/// Stands in for a `server` run no program registered: it cannot plan, so it says so.
#[derive(Debug, Clone, Copy)]
struct Unregistered;

impl Strategy for Unregistered {
    fn period_s(&self) -> f64 {
        1e9
    }
    fn decide(&mut self, _view: &View<'_>) -> Command {
        panic!("the `server` strategy needs a running service: run it with `jink simulate`")
    }
}

impl StrategyKind {
    /// Every strategy, in report order.
    pub const ALL: [StrategyKind; 12] = [
        Self::None,
        Self::Insertion,
        Self::Tangent,
        Self::ConstantVelocity,
        Self::Bisection(ForcedStage::NoFly),
        Self::Bisection(ForcedStage::Random),
        Self::Bisection(ForcedStage::Advanced),
        Self::Bisection(ForcedStage::Memory),
        Self::BisectionAuto,
        Self::ReactiveOffset,
        Self::ReactiveSectors,
        Self::Oracle,
    ];

    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Insertion => "insertion",
            Self::Tangent => "tangent",
            Self::ConstantVelocity => "cv",
            Self::Bisection(ForcedStage::NoFly) => "mc-nofly",
            Self::Bisection(ForcedStage::Random) => "mc-random",
            Self::Bisection(ForcedStage::Advanced) => "mc-advanced",
            Self::Bisection(ForcedStage::Memory) => "mc-memory",
            Self::BisectionAuto => "mc-auto",
            Self::ReactiveOffset => "offset",
            Self::ReactiveSectors => "sectors",
            Self::Oracle => "oracle",
            Self::Server => "server",
            Self::ServerBare => "server-bare",
            Self::ServerMission => "server-mission",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .chain([Self::Server, Self::ServerBare, Self::ServerMission])
            .find(|k| k.name() == s)
    }

    /// Builds a fresh instance for one run; `seed` feeds every random choice it makes.
    pub fn build(self, seed: u64) -> Box<dyn Strategy> {
        match self {
            Self::None => Box::new(Hold(1e9)),
            Self::Insertion => Box::new(FirstThen::new(insertion::insertion_stack, Hold(1.0))),
            Self::Tangent => Box::new(FirstThen::new(tangent::tangent_command, Hold(1.0))),
            Self::ConstantVelocity => Box::new(constant_velocity::ConstantVelocity::default()),
            Self::Bisection(stage) => Box::new(bisection::Bisection::new(Some(stage), seed)),
            Self::BisectionAuto => Box::new(bisection::Bisection::new(None, seed)),
            Self::ReactiveOffset => Box::new(FirstThen::new(
                tangent::tangent_command,
                reactive::Onboard::new(reactive::Offset::default()),
            )),
            Self::ReactiveSectors => Box::new(FirstThen::new(
                tangent::tangent_command,
                reactive::Onboard::new(reactive::Sectors::default()),
            )),
            Self::Oracle => Box::new(oracle::Oracle::new(seed)),
            Self::Server | Self::ServerBare | Self::ServerMission => SERVER.get().map_or_else(
                || Box::new(Unregistered) as Box<dyn Strategy>,
                |f| f(self, seed),
            ),
        }
    }
}

/// What the server keeps across plan revisions, kept across calls the same way: since when
/// the stack's next fixed item has been the target ([`planner::Replan::target_pending_s`],
/// and the evidence for flying a missed waypoint again, [`planner::revisit`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct TargetClock {
    /// The next fixed item (its position, bit for bit) and since when, mission seconds.
    target: Option<([u64; 2], f64)>,
    /// A waypoint passed that the flight ahead may yet capture ([`planner::Watch`]), with its
    /// position bit for bit: judged again at the next call.
    watch: Option<([u64; 2], planner::Watch)>,
}

fn position_bits(i: &planner::StackItem) -> [u64; 2] {
    [i.p_m[0].to_bits(), i.p_m[1].to_bits()]
}

impl TargetClock {
    /// Seconds the next fixed item of `view`'s stack has been the target (0 when it has
    /// just become the target), `None` when no fixed item is left.
    pub fn pending_s(&mut self, view: &View<'_>) -> Option<f64> {
        self.aim(&view.stack.items, view.stack.current, view.t_s);
        self.target.map(|(_, since)| view.t_s - since)
    }

    /// The stack `items` is flown from `current` at `t_s`: its next fixed item keeps its
    /// clock while it stays the target, and one that has just become the target (a plan
    /// made at `t_s` skipped a waypoint captured on the way, or flies a missed one again)
    /// has been the target since `t_s`. The server keeps the same clock in its revisions.
    pub fn aim(&mut self, items: &[planner::StackItem], current: usize, t_s: f64) {
        let next = planner::next_fixed(items, current).map(|j| position_bits(&items[j]));
        self.target = match (next, self.target) {
            (Some(k), Some((old, since))) if k == old => Some((k, since)),
            (Some(k), _) => Some((k, t_s)),
            (None, _) => None,
        };
    }

    /// The mission waypoint `view`'s autopilot has just gone past too wide
    /// ([`planner::judge_pass`]): the item before the current one, when it was the target
    /// at the last call or is under watch, and the track since it became the target. A pass
    /// only the flight ahead would capture is watched and judged again at the next call, as
    /// the server keeps it in the plan it stores. Call before [`TargetClock::pending_s`].
    pub fn missed(&mut self, view: &View<'_>) -> Option<planner::Missed> {
        let k = view.stack.current.checked_sub(1)?;
        let bits = position_bits(view.stack.items.get(k)?);
        let watch = self
            .watch
            .take()
            .filter(|(b, w)| *b == bits && w.stack_index == k)
            .map(|(_, w)| w);
        let pursued = self.target.filter(|(b, _)| *b == bits).map(|(_, s)| (k, s));
        let since = watch.map(|w| w.since_s).or(pursued.map(|p| p.1))?;
        let track = track_since(view, since);
        match planner::judge_pass(
            &view.stack.items,
            view.stack.current,
            pursued,
            watch,
            &track,
            view.aircraft.planner_aircraft().turn_radius_m,
        )? {
            planner::Pass::Missed(m) => Some(m),
            planner::Pass::Watch(w) => {
                self.watch = Some((bits, w));
                None
            }
        }
    }

    /// The mission waypoint ahead that `view`'s aircraft captured on its way, flying toward
    /// it or toward an avoid item before it ([`planner::captured_on_the_way`]): the next
    /// fixed item, when it was the target at the last call, and the track since it became
    /// the target. Call before [`TargetClock::pending_s`].
    pub fn captured(&self, view: &View<'_>) -> Option<planner::Captured> {
        let (bits, since) = self.target?;
        let (items, cur) = (&view.stack.items, view.stack.current);
        let j = planner::next_fixed(items, cur)?;
        if position_bits(&items[j]) != bits {
            return None;
        }
        planner::captured_on_the_way(items, cur, (j, since), &track_since(view, since))
    }
}

/// `view`'s own track from a sample gap before `since` on.
fn track_since(view: &View<'_>, since: f64) -> Vec<planner::TrackPoint> {
    let from = view
        .own_track
        .partition_point(|(t, _)| *t < since - planner::revisit::TRACK_GAP_S);
    view.own_track[from..]
        .iter()
        .map(|&(t_s, p)| planner::TrackPoint {
            t_s,
            p_m: [p[0], p[1]],
            alt_m: p[2],
        })
        .collect()
}

/// Replans `view`'s stack through the server's seam ([`planner::replan`]) with `dynamic`
/// risk, `cfg` and plan seed `seed`, without a deadline (reproducible), carrying `clock`
/// from the last call as the server carries it from the base revision: the new stack, or
/// the old one kept on bad input (a non-finite state).
pub fn replan_command(
    view: &View<'_>,
    dynamic: planner::Dynamic<'_>,
    cfg: &planner::ReplanConfig,
    seed: u64,
    clock: &mut TargetClock,
) -> Command {
    let revisit = clock.missed(view).is_some();
    let captured = !revisit && clock.captured(view).is_some();
    let r = planner::Replan {
        mission: view.mission,
        aircraft: view.aircraft.planner_aircraft(),
        state: view.own.planner_state(),
        stack: &view.stack.items,
        current_index: view.stack.current,
        strategy: planner::Strategy::Bisection,
        seed,
        target_pending_s: clock.pending_s(view),
        revisit,
        captured,
    };
    // The service is told the autopilot's acceptance radius and L1 period
    // (`aircraft.acceptance_radius_m`, `aircraft.l1_period_s`).
    let mut cfg = cfg.clone();
    cfg.plan.verify.acceptance_m = view.aircraft.acceptance_radius_m;
    cfg.plan.verify.l1_s = view.aircraft.l1_s();
    let read = trace_plans().then(|| trace_field(&dynamic)).flatten();
    match planner::replan(&r, dynamic, &cfg, &planner::Termination::none()) {
        Ok(p) => {
            if trace_plans() {
                if let Some(d) = p.deferred {
                    eprintln!(
                        "deferred waypoint {} (stack item {}) at t={:.1} s, pursued {:.1} s",
                        d.mission_index, d.stack_index, view.t_s, d.pending_s
                    );
                }
                trace_plan(view, &r, &p.plan, p.near_s);
                if let Some(read) = read {
                    trace_target(view, read, &p.plan);
                }
            }
            // The plan's next fixed item is flown from now on.
            clock.aim(&p.plan.items, p.plan.current_index, view.t_s);
            Command::Replace(Stack {
                items: p.plan.items,
                current: p.plan.current_index,
            })
        }
        Err(_) => Command::Keep,
    }
}

/// Whether `JINK_SIM_TRACE` is set: every plan of the bisection strategies is then printed
/// on stderr, one line each (a diagnostic for one seed at a time, `--threads 1`; the
/// simulation itself is unchanged). Public so that the `server` strategies print theirs.
pub fn trace_plans() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("JINK_SIM_TRACE").is_some())
}

/// Items of the chosen stack a `JINK_SIM_TRACE` plan line lists, from the current one.
const TRACE_ITEMS: usize = 5;
/// Spheres nearer the aircraft than this a `JINK_SIM_TRACE` plan line lists, metres.
const TRACE_NEAR_M: f64 = 600.0;

/// One line of `JINK_SIM_TRACE`: time, position and altitude, current index, the next
/// fixed item of the plan (position and altitude), how long it has been pending, whether a
/// missed waypoint is flown again, the outcome, the near window it was verified with
/// (`planner::Replanned::near_s`) and the chosen route's verification; then the
/// chosen stack's next items and the true spheres near the aircraft (position now and 5 s
/// on, how many observations the planner had of each, behaviour).
fn trace_plan(view: &View<'_>, r: &planner::Replan<'_>, plan: &planner::Plan, near_s: f64) {
    let v = &plan.verification;
    let next = planner::next_fixed(&plan.items, plan.current_index)
        .map(|j| &plan.items[j])
        .map(|i| format!("({:.0}, {:.0}, {:.0})", i.p_m[0], i.p_m[1], i.alt_m))
        .unwrap_or_else(|| "none".into());
    eprintln!(
        "plan t={:.1} s pos=({:.0}, {:.0}) alt={:.0} current_index={} next_fixed={} \
         pending_s={:?} revisit={} captured={} outcome={:?} near_s={near_s} \
         near_peak={:.2} graded_peak={:.2} peak={:.2} exposure_m={:.0} length_m={:.0} \
         added={} conflict={:?}",
        view.t_s,
        r.state.p_m[0],
        r.state.p_m[1],
        r.state.alt_m,
        plan.current_index,
        next,
        r.target_pending_s,
        r.revisit,
        r.captured,
        plan.outcome,
        v.near_peak_risk,
        v.graded_peak_risk,
        v.peak_risk,
        v.exposure_m,
        v.length_m,
        plan.added,
        v.conflict,
    );
    // The route chosen: the stack's next items (avoid items marked `a`).
    let items: Vec<String> = plan
        .items
        .iter()
        .skip(plan.current_index)
        .take(TRACE_ITEMS)
        .map(|i| {
            let mark = if i.kind == planner::ItemKind::Avoid {
                "a"
            } else {
                ""
            };
            format!("({:.0}, {:.0}){mark}", i.p_m[0], i.p_m[1])
        })
        .collect();
    eprintln!("   stack {}", items.join(" "));
    // The truth the plan did not have: each sphere within TRACE_NEAR_M, now and 5 s on.
    for (k, s) in view.truth.iter().enumerate() {
        let p = s.track.at(view.t_s);
        let d = (p[0] - r.state.p_m[0]).hypot(p[1] - r.state.p_m[1]);
        if d < TRACE_NEAR_M {
            let q = s.track.at(view.t_s + 5.0);
            let seen = view.tracks.get(k).map_or(0, |t| t.len());
            eprintln!(
                "   sphere {k} radius={:.0} speed={:.1} at=({:.0}, {:.0}, {:.0}) in_5s=({:.0}, {:.0}) \
                 distance={d:.0} observations={seen} {:?}",
                s.radius_m, s.speed_mps, p[0], p[1], p[2], q[0], q[1], s.behaviour
            );
        }
    }
}

/// Seconds ahead the `JINK_SIM_TRACE` target lines cover, one character a second.
const TRACE_TARGET_S: usize = 30;

/// `JINK_SIM_TRACE`, under a plan line: the risk the plan read at its next mission item,
/// a digit a second from now to [`TRACE_TARGET_S`] ahead (`0`-`9`, risk times 9 rounded;
/// the map or field the plan was given, all altitudes), and under it the truth there (`#`
/// where a true sphere, grown by the map's buffer, holds the item's position and altitude,
/// `.` where none does). So a run that circles an overdue waypoint shows whether the
/// prediction saw the waypoint's clear windows or the planner did not time its approach.
fn trace_target(
    view: &View<'_>,
    (field, buffer_m): (&dyn predictor::RiskField, f64),
    plan: &planner::Plan,
) {
    let Some(j) = planner::next_fixed(&plan.items, plan.current_index) else {
        return;
    };
    let w = plan.items[j];
    let (read, truth) = target_timeline(field, buffer_m, view.truth, &w, view.t_s);
    eprintln!("   target ({:.0}, {:.0}) risk  {read}", w.p_m[0], w.p_m[1]);
    eprintln!("   target ({:.0}, {:.0}) truth {truth}", w.p_m[0], w.p_m[1]);
}

/// The two timelines of [`trace_target`] for `item` from `t0_s`: the risk `field` reads at
/// its position, one digit a second, and `#` / `.` for whether a sphere of `truth`, grown
/// by `buffer_m`, holds its position and altitude then.
fn target_timeline(
    field: &dyn predictor::RiskField,
    buffer_m: f64,
    truth: &[MovingSphere],
    item: &planner::StackItem,
    t0_s: f64,
) -> (String, String) {
    let (mut read, mut held) = (String::new(), String::new());
    for k in 0..=TRACE_TARGET_S {
        let t = t0_s + k as f64;
        let r = field.risk(item.p_m, t).clamp(0.0, 1.0);
        read.push(char::from_digit((r * 9.0).round() as u32, 10).unwrap_or('9'));
        let inside = truth.iter().any(|s| {
            let q = s.track.at(t);
            let d = (q[0] - item.p_m[0])
                .hypot(q[1] - item.p_m[1])
                .hypot(q[2] - item.alt_m);
            d < s.radius_m + buffer_m
        });
        held.push(if inside { '#' } else { '.' });
    }
    (read, held)
}

/// What a plan given `dynamic` reads risk from, and the buffer its spheres are grown by
/// (the map's own; the default map's for a field), for [`trace_target`].
fn trace_field<'a>(dynamic: &planner::Dynamic<'a>) -> Option<(&'a dyn predictor::RiskField, f64)> {
    match *dynamic {
        planner::Dynamic::Map { map, .. } => Some((map, map.config().buffer_m)),
        planner::Dynamic::Field(f) => Some((f, predictor::RiskMapConfig::default().buffer_m)),
        _ => None,
    }
}

/// Keeps the stack, deciding every `.0` seconds: the "none" strategy (never, in effect),
/// and the static strategies after their first call (every second).
#[derive(Debug, Clone, Copy)]
pub struct Hold(pub f64);

impl Strategy for Hold {
    fn period_s(&self) -> f64 {
        self.0
    }
    fn decide(&mut self, _view: &View<'_>) -> Command {
        Command::Keep
    }
}

/// A strategy in two parts: `first` decides the first call only (the static plan around
/// the cylinders, which never move), `then` every later call; `then` sets the period and
/// the scanner.
#[derive(Debug, Clone)]
pub struct FirstThen<F, S> {
    first: Option<F>,
    then: S,
}

impl<F, S> FirstThen<F, S> {
    /// `first` at the first call, then `then`.
    pub fn new(first: F, then: S) -> Self {
        Self {
            first: Some(first),
            then,
        }
    }
}

impl<F, S> Strategy for FirstThen<F, S>
where
    F: FnOnce(&View<'_>) -> Command + Send,
    S: Strategy,
{
    fn period_s(&self) -> f64 {
        self.then.period_s()
    }
    fn lidar(&self) -> Option<LidarParams> {
        self.then.lidar()
    }
    fn decide(&mut self, view: &View<'_>) -> Command {
        match self.first.take() {
            Some(first) => first(view),
            None => self.then.decide(view),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::StackItem;

    /// A view at `t_s` of `stack`, the aircraft having flown `track` (its last point now).
    fn view<'a>(
        t_s: f64,
        stack: &'a Stack,
        track: &'a [(f64, [f64; 3])],
        mission: &'a Mission,
        aircraft: &'a AircraftParams,
    ) -> View<'a> {
        let p_m = track.last().map_or([0.0; 3], |(_, p)| *p);
        View {
            t_s,
            own: AircraftState {
                t_s,
                p_m,
                heading_rad: std::f64::consts::FRAC_PI_2,
                speed_mps: 20.0,
            },
            own_track: track,
            aircraft,
            mission,
            stack,
            tracks: &[],
            scan: None,
            truth: &[],
        }
    }

    #[test]
    fn the_clock_flags_a_waypoint_pursued_at_the_last_call_and_passed_too_wide() {
        let mission = Mission::default();
        let aircraft = AircraftParams::default();
        let items = vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::mission(1, [0.0, 1000.0], 100.0),
        ];
        // Northward 40 m east of waypoint 0, at 5 Hz from 200 m south of it.
        let track: Vec<(f64, [f64; 3])> = (0..=60)
            .map(|k| {
                let k = f64::from(k);
                (0.2 * k, [40.0, -200.0 + 4.0 * k, 100.0])
            })
            .collect();
        let mut clock = TargetClock::default();
        // The first call: waypoint 0 becomes the target at t = 0.
        let before = Stack {
            items: items.clone(),
            current: 0,
        };
        let v0 = view(0.0, &before, &track[..1], &mission, &aircraft);
        assert_eq!(clock.missed(&v0), None);
        assert_eq!(clock.pending_s(&v0), Some(0.0));
        // 12 s later the autopilot has gone on to waypoint 1: missed, 40 m off.
        let after = Stack { items, current: 1 };
        let v1 = view(12.0, &after, &track, &mission, &aircraft);
        let m = clock.missed(&v1).expect("passed 40 m off");
        assert_eq!((m.stack_index, m.mission_index), (0, 0));
        assert!((m.closest_m - 40.0).abs() < 1e-9);
        // Once the clock has moved on to waypoint 1, waypoint 0 is no longer its business.
        assert_eq!(clock.pending_s(&v1), Some(0.0));
        assert_eq!(clock.missed(&v1), None);
    }

    #[test]
    fn the_clock_watches_a_pass_the_flight_ahead_may_capture_and_flags_it_once_flown_away() {
        let mission = Mission::default();
        let aircraft = AircraftParams::default();
        assert!(aircraft.planner_aircraft().turn_radius_m > 20.0);
        // Waypoint 0 at the origin, the next item far to the north-east: northward 35 m
        // west of it, the autopilot switches 20 m short; the turn for the next item would
        // capture it.
        let ne = vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::mission(1, [400.0, 400.0], 100.0),
        ];
        let mut track: Vec<(f64, [f64; 3])> = (0..=45)
            .map(|k| {
                let k = f64::from(k);
                (0.2 * k, [-35.0, -200.0 + 4.0 * k, 100.0])
            })
            .collect();
        let mut clock = TargetClock::default();
        let before = Stack {
            items: ne.clone(),
            current: 0,
        };
        let v0 = view(0.0, &before, &track[..1], &mission, &aircraft);
        assert_eq!(clock.missed(&v0), None);
        assert_eq!(clock.pending_s(&v0), Some(0.0));
        let passed = Stack {
            items: ne.clone(),
            current: 1,
        };
        let v1 = view(9.0, &passed, &track, &mission, &aircraft);
        assert_eq!(clock.missed(&v1), None, "the turn ahead may capture it");
        assert_eq!(clock.pending_s(&v1), Some(0.0));
        // The plan then sent it west, through an avoid item, and it flew west: flagged at
        // the next call, once.
        track.extend((1..=5).map(|k| {
            let k = f64::from(k);
            (9.0 + 0.2 * k, [-35.0 - 4.0 * k, -20.0, 100.0])
        }));
        let west = Stack {
            items: vec![ne[0], StackItem::avoid([-300.0, -100.0], 100.0), ne[1]],
            current: 1,
        };
        let v2 = view(10.0, &west, &track, &mission, &aircraft);
        let m = clock.missed(&v2).expect("flown away from it");
        assert_eq!((m.stack_index, m.mission_index), (0, 0));
        assert!((m.closest_m - 35f64.hypot(20.0)).abs() < 1e-6, "{m:?}");
        assert_eq!(clock.pending_s(&v2), Some(1.0));
        assert_eq!(clock.missed(&v2), None);
    }

    #[test]
    fn a_target_a_plan_puts_next_has_been_pending_since_that_plan() {
        let mission = Mission::default();
        let aircraft = AircraftParams::default();
        let (w0, w1) = (
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::mission(1, [0.0, 1000.0], 100.0),
        );
        let track = [(0.0, [0.0, -200.0, 100.0])];
        let mut clock = TargetClock::default();
        let both = Stack {
            items: vec![w0, w1],
            current: 0,
        };
        assert_eq!(
            clock.pending_s(&view(0.0, &both, &track, &mission, &aircraft)),
            Some(0.0)
        );
        // The plan at 5 s keeps waypoint 0 next: its clock runs on.
        clock.aim(&both.items, 0, 5.0);
        assert_eq!(
            clock.pending_s(&view(6.0, &both, &track, &mission, &aircraft)),
            Some(6.0)
        );
        // The plan at 7 s skipped it (captured on the way): waypoint 1 is the target from
        // 7 s, not from 0 s and not only from the next call.
        let skipped = Stack {
            items: vec![w1],
            current: 0,
        };
        clock.aim(&skipped.items, 0, 7.0);
        assert_eq!(
            clock.pending_s(&view(8.0, &skipped, &track, &mission, &aircraft)),
            Some(1.0)
        );
    }

    #[test]
    fn the_clock_flags_a_waypoint_pursued_at_the_last_call_and_captured_on_the_way() {
        let mission = Mission::default();
        let aircraft = AircraftParams::default();
        // The autopilot flies toward an avoid item far north-east; waypoint 0 comes next.
        let stack = Stack {
            items: vec![
                StackItem::avoid([300.0, 400.0], 100.0),
                StackItem::mission(0, [0.0, 0.0], 100.0),
                StackItem::mission(1, [0.0, 1000.0], 100.0),
            ],
            current: 0,
        };
        // Northward `east` m east of waypoint 0, at 5 Hz from 200 m south of it.
        let track = |east: f64| -> Vec<(f64, [f64; 3])> {
            (0..=60)
                .map(|k| {
                    let k = f64::from(k);
                    (0.2 * k, [east, -200.0 + 4.0 * k, 100.0])
                })
                .collect()
        };
        let (near, wide) = (track(15.0), track(40.0));
        let mut clock = TargetClock::default();
        let v0 = view(0.0, &stack, &near[..1], &mission, &aircraft);
        assert_eq!(clock.captured(&v0), None);
        assert_eq!(clock.pending_s(&v0), Some(0.0));
        // 12 s later, still toward the avoid item: waypoint 0 was passed 15 m off.
        let v1 = view(12.0, &stack, &near, &mission, &aircraft);
        let c = clock.captured(&v1).expect("captured 15 m off");
        assert_eq!((c.stack_index, c.mission_index), (1, 0));
        assert!((c.closest_m - 15.0).abs() < 1e-9);
        // 40 m off: not captured.
        assert_eq!(
            clock.captured(&view(12.0, &stack, &wide, &mission, &aircraft)),
            None
        );
        // Not pursued at the last call (a new clock has never seen it as the target).
        assert_eq!(TargetClock::default().captured(&v1), None);
    }

    /// A field of risk 1 from 8 s to 12 s after its start, 0 elsewhere.
    struct Window;
    impl predictor::RiskField for Window {
        fn risk(&self, _p: [f64; 2], t: f64) -> f64 {
            if (8.0..=12.0).contains(&t) { 1.0 } else { 0.0 }
        }
    }

    #[test]
    fn the_target_timelines_show_the_read_risk_and_the_truth_second_by_second() {
        // A sphere of 20 m flying east at 10 m/s along y = 0, at 100 m, from x = -100 at
        // t = 0; the item is at the origin. Sampled every 0.1 s for 60 s.
        let sphere = |alt_m: f64| MovingSphere {
            radius_m: 20.0,
            speed_mps: 10.0,
            behaviour: crate::behaviour::Behaviour::Random {
                max_turn_rate_rad_s: 0.0,
            },
            track: crate::behaviour::Trajectory {
                dt_s: 0.1,
                samples_m: (0..=600)
                    .map(|i| [-100.0 + f64::from(i), 0.0, alt_m])
                    .collect(),
            },
        };
        let item = planner::StackItem::mission(0, [0.0, 0.0], 100.0);
        // At its altitude, grown by 5 m, it holds the item while |x| < 25 m: t in
        // (7.5, 12.5), whole seconds 8 to 12.
        let (read, truth) = target_timeline(&Window, 5.0, &[sphere(100.0)], &item, 0.0);
        assert_eq!(read.len(), TRACE_TARGET_S + 1);
        assert_eq!(&read[..14], "00000000999990");
        assert_eq!(&truth[..14], "........#####.");
        assert!(truth[14..].chars().all(|c| c == '.'));
        // 30 m above the item: out of reach grown by 5 m; grown by 15 m it holds the item
        // while x^2 + 30^2 < 35^2, |x| < 18 m: t in (8.2, 11.8), seconds 9 to 11.
        let (_, above) = target_timeline(&Window, 5.0, &[sphere(130.0)], &item, 0.0);
        assert!(above.chars().all(|c| c == '.'));
        let (_, grown) = target_timeline(&Window, 15.0, &[sphere(130.0)], &item, 0.0);
        assert_eq!(&grown[..14], ".........###..");
        // The timelines start at t0: two seconds later everything moves two places left.
        let (read2, truth2) = target_timeline(&Window, 5.0, &[sphere(100.0)], &item, 2.0);
        assert_eq!(&read2[..12], &read[2..14]);
        assert_eq!(&truth2[..12], &truth[2..14]);
    }
}
