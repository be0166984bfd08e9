//! One closed-loop run: a scenario, a strategy, the aircraft, the telemetry, the judges.
//!
//! The world advances in steps of `dt_s` (0.1 s). The strategy is called every period with
//! what the aircraft would know (its own state, the obstacle telemetry received so far, a
//! LiDAR scan if it asked for one); its command changes the stack or steers the aircraft.
//! The run ends when the stack is finished or at the scenario's time limit. The aircraft's
//! telemetry as sent to the judges (at `judge_rate_hz`) is then scored as they did.
//!
//! Everything is reproducible from the scenario's seed, except the measured replan latencies.

use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::aircraft::{AircraftParams, AircraftState, Autopilot, SteerOverride};
use crate::geometry::xy;
use crate::lidar::{cross_sections, scan};
use crate::mission::{ItemKind, initial_stack, path_ratio};
use crate::scenario::Scenario;
use crate::scoring::{JudgeReport, judge};
use crate::strategy::{Command, StrategyKind, View};
use crate::telemetry::{ObstacleObservation, TelemetryParams, sample_streams};

/// Run parameters. Defaults: the default aircraft, telemetry 2 Hz / 1 m / 5% dropouts,
/// judges' telemetry 5 Hz, step 0.1 s, track recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    /// Aircraft.
    pub aircraft: AircraftParams,
    /// Obstacle telemetry.
    pub telemetry: TelemetryParams,
    /// Rate of the aircraft telemetry the judges score, Hz.
    pub judge_rate_hz: f64,
    /// Simulation step, seconds.
    pub dt_s: f64,
    /// Keep the aircraft's track in the result (for plots).
    pub record_track: bool,
    /// Noise on the aircraft's own state as strategies see it (its telemetry).
    pub own_noise: OwnNoise,
}

/// Gaussian noise on the aircraft's own state as the strategies see it (the telemetry a
/// ground station receives: an autopilot's heading and GPS position are estimates). The
/// flown aircraft and the judges' scoring keep the true state. Zero by default.
///
/// Deterministic: drawn from the scenario's seed, one draw per decision, so every strategy
/// with the same replan period sees the same noise on a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct OwnNoise {
    /// Standard deviation of the heading, degrees.
    pub heading_deg: f64,
    /// Standard deviation of each horizontal coordinate, metres.
    pub position_m: f64,
}

impl OwnNoise {
    /// `state` as the telemetry reports it: heading and horizontal position disturbed.
    fn apply(&self, state: AircraftState, rng: &mut ChaCha8Rng) -> AircraftState {
        if self.heading_deg <= 0.0 && self.position_m <= 0.0 {
            return state;
        }
        let mut g = || -> f64 { StandardNormal.sample(rng) };
        let mut out = state;
        out.heading_rad += self.heading_deg.max(0.0).to_radians() * g();
        out.p_m[0] += self.position_m.max(0.0) * g();
        out.p_m[1] += self.position_m.max(0.0) * g();
        out
    }
}

impl Default for RunConfig {
    fn default() -> Self {
        Self {
            aircraft: AircraftParams::default(),
            telemetry: TelemetryParams::default(),
            judge_rate_hz: 5.0,
            dt_s: 0.1,
            record_track: true,
            own_noise: OwnNoise::default(),
        }
    }
}

/// The numbers of one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMetrics {
    /// Judges' sphere score `(fraction not hit)^3`.
    pub sphere_score: f64,
    /// Judges' cylinder score.
    pub cylinder_score: f64,
    /// Spheres hit / total.
    pub spheres_hit: usize,
    /// Spheres in the scenario.
    pub spheres: usize,
    /// Cylinders hit.
    pub cylinders_hit: usize,
    /// Cylinders in the scenario.
    pub cylinders: usize,
    /// Mission waypoints captured within 100 ft.
    pub waypoints_captured: usize,
    /// Mission waypoints.
    pub waypoints: usize,
    /// The interop server's in-order waypoint score (2019-2021): each waypoint of the
    /// best in-order sequence of passes graded `max(0, 1 - d / 100 ft)`, summed
    /// ([`crate::scoring::in_order_waypoint_score`]); at most `waypoints`. 0 in reports
    /// written before it was kept.
    #[serde(default)]
    pub waypoint_score: f64,
    /// Whether the stack was finished before the time limit.
    pub completed: bool,
    /// Flight time, seconds.
    pub mission_time_s: f64,
    /// Horizontal path flown, metres.
    pub path_length_m: f64,
    /// Flown length / straight mission legs.
    pub path_ratio: f64,
    /// Smallest clearance to any obstacle surface, metres (negative inside).
    pub min_clearance_m: f64,
    /// Avoid waypoints the aircraft actually reached (switched past).
    pub waypoints_added: usize,
    /// Distinct avoid waypoints the aircraft flew toward (a replanning strategy that moves
    /// its avoid point every period counts each new one).
    pub avoid_targets: usize,
    /// Route added by replans, metres: summed over the replans that changed the stack, how
    /// much longer the new stack's route to the next mission waypoint is than the route of
    /// the stack it replaced, both measured from the aircraft's position at that moment
    /// (only when both lead to the same waypoint). A planner that keeps changing its mind
    /// about the way round piles this up; one that plans once and flies it adds nothing.
    #[serde(default)]
    pub route_added_m: f64,
    /// Route removed by replans, metres: the same sum for the replans that shortened it.
    #[serde(default)]
    pub route_removed_m: f64,
    /// Seconds outside the fly zone or its altitude band.
    pub boundary_violation_s: f64,
    /// Separate excursions out of the fly zone.
    pub boundary_excursions: usize,
    /// Strategy calls.
    pub replans: usize,
    /// Median strategy latency, ms (wall clock: not reproducible).
    pub replan_p50_ms: f64,
    /// 95th percentile, ms.
    pub replan_p95_ms: f64,
    /// Maximum, ms.
    pub replan_max_ms: f64,
    /// 95th percentile of the replan time in the thread's CPU time
    /// ([`crate::cpu::thread_cpu_ms`]), ms: the work itself, which a loaded machine does
    /// not inflate (0 where no CPU clock can be read).
    #[serde(default)]
    pub replan_cpu_p95_ms: f64,
    /// Maximum, the same way, ms.
    #[serde(default)]
    pub replan_cpu_max_ms: f64,
    /// 95th percentile of the live-state update before each replan (feeding the predictor,
    /// building the live map), ms: work the server does when telemetry arrives, reported
    /// apart from the replan time ([`crate::strategy::Strategy::take_live_ms`]); 0 for a
    /// strategy without a live state.
    #[serde(default)]
    pub live_p95_ms: f64,
}

/// A run's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// Scenario seed.
    pub seed: u64,
    /// Strategy.
    pub strategy: StrategyKind,
    /// Numbers.
    pub metrics: RunMetrics,
    /// What the judges saw.
    pub judge: JudgeReport,
    /// Aircraft track `[t, x, y, z]` every step (empty unless recorded).
    pub track: Vec<[f64; 4]>,
    /// Strategy latencies (the plan's part), ms.
    #[serde(skip)]
    pub latencies_ms: Vec<f64>,
    /// Live-state update latencies, ms ([`RunMetrics::live_p95_ms`]).
    #[serde(skip)]
    pub live_ms: Vec<f64>,
    /// Strategy latencies (the plan's part) in the thread's CPU time, ms
    /// ([`RunMetrics::replan_cpu_p95_ms`]; empty without a CPU clock).
    #[serde(skip)]
    pub cpu_ms: Vec<f64>,
}

/// Percentile by nearest rank of an unsorted slice (0 for an empty one).
pub fn percentile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let k = ((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1;
    s[k]
}

/// Runs `strategy` on `scenario` with precomputed telemetry `streams` (see
/// [`crate::telemetry::sample_streams`]).
pub fn run_with_streams(
    scenario: &Scenario,
    streams: &[Vec<ObstacleObservation>],
    strategy: StrategyKind,
    cfg: &RunConfig,
) -> RunResult {
    let m = &scenario.mission;
    let mut stack = initial_stack(m);
    let first = stack.target().map_or(xy(scenario.start_m), |t| t.p_m);
    let mut ap = Autopilot::new(cfg.aircraft, scenario.start_m, first);
    let mut strat = strategy.build(scenario.seed ^ 0x5EED_0F5A);
    let lidar = strat.lidar();
    let period = strat.period_s();
    let cylinders: Vec<_> = m
        .cylinders
        .iter()
        .map(|c| (c.center_m, c.radius_m, c.top_m))
        .collect();
    let mut next_decide = 0.0;
    let mut received = vec![0usize; streams.len()];
    let mut latencies_ms = Vec::new();
    let mut live_ms = Vec::new();
    let mut cpu_ms = Vec::new();
    let mut track = Vec::new();
    let judge_every = ((1.0 / cfg.judge_rate_hz) / cfg.dt_s).round().max(1.0) as usize;
    let mut judge_tel = vec![(0.0, ap.state.p_m)];
    let mut path_len = 0.0;
    let mut added = 0;
    let mut avoid_targets = 0;
    let (mut route_added, mut route_removed) = (0.0, 0.0);
    let mut last_target = stack.target().map(|t| t.p_m);
    let mut step = 0usize;
    let mut inside = vec![false; scenario.spheres.len()];
    let mut zone_out = false;
    let mut own_rng = ChaCha8Rng::seed_from_u64(scenario.seed ^ 0x004E_0153);
    if cfg.record_track {
        track.push([0.0, ap.state.p_m[0], ap.state.p_m[1], ap.state.p_m[2]]);
    }
    while ap.state.t_s < scenario.duration_s - 1e-9 && stack.target().is_some() {
        let t = ap.state.t_s;
        if t >= next_decide - 1e-9 {
            next_decide += period;
            for (i, s) in streams.iter().enumerate() {
                received[i] = s.partition_point(|o| o.t_s <= t + 1e-9);
            }
            let tracks: Vec<&[ObstacleObservation]> = streams
                .iter()
                .zip(&received)
                .map(|(s, n)| &s[..*n])
                .collect();
            let sc = lidar.map(|lp| {
                let spheres: Vec<([f64; 3], f64)> = scenario
                    .spheres
                    .iter()
                    .map(|s| (s.track.at(t), s.radius_m))
                    .collect();
                let secs = cross_sections(ap.state.p_m[2], &cylinders, &spheres);
                scan(&lp, xy(ap.state.p_m), ap.state.heading_rad, &secs)
            });
            let view = View {
                t_s: t,
                own: cfg.own_noise.apply(ap.state, &mut own_rng),
                own_track: &judge_tel,
                aircraft: &cfg.aircraft,
                mission: m,
                stack: &stack,
                tracks: &tracks,
                scan: sc.as_ref(),
                truth: &scenario.spheres,
            };
            let t0 = Instant::now();
            let cpu0 = crate::cpu::thread_cpu_ms();
            let cmd = strat.decide(&view);
            let total_ms = t0.elapsed().as_secs_f64() * 1e3;
            let cpu_total = crate::cpu::since(cpu0);
            let live = strat.take_live_ms();
            latencies_ms.push(total_ms - live.unwrap_or(0.0));
            let live_cpu = strat.take_live_cpu_ms();
            cpu_ms.extend(cpu_total.map(|c| c - live_cpu.unwrap_or(0.0)));
            live_ms.extend(live);
            match cmd {
                Command::Keep => {}
                Command::Replace(s) => {
                    let here = xy(ap.state.p_m);
                    let before = stack.route_to_next_waypoint_m(here);
                    ap.replace_stack(&mut stack, s);
                    if let (Some((wb, lb)), Some((wa, la))) =
                        (before, stack.route_to_next_waypoint_m(here))
                        && wb == wa
                    {
                        route_added += (la - lb).max(0.0);
                        route_removed += (lb - la).max(0.0);
                    }
                    if let Some(t) = stack.target()
                        && t.kind == ItemKind::Avoid
                        && last_target != Some(t.p_m)
                    {
                        avoid_targets += 1;
                    }
                    last_target = stack.target().map(|t| t.p_m);
                }
                Command::Steer {
                    turn_rate_rad_s,
                    hold_s,
                } => {
                    ap.steer = Some(SteerOverride {
                        turn_rate_rad_s,
                        until_s: t + hold_s,
                    });
                }
            }
        }
        let before = xy(ap.state.p_m);
        for idx in ap.step(&mut stack, cfg.dt_s) {
            if stack.items[idx].kind == ItemKind::Avoid {
                added += 1;
            }
            if let Some(t) = stack.target()
                && t.kind == ItemKind::Avoid
                && last_target != Some(t.p_m)
            {
                avoid_targets += 1;
            }
            last_target = stack.target().map(|t| t.p_m);
        }
        path_len += crate::geometry::dist(before, xy(ap.state.p_m));
        if crate::strategy::trace_plans() {
            trace_inside(scenario, &ap.state, &mut inside);
            trace_zone(scenario, &ap.state, &mut zone_out);
        }
        step += 1;
        if step.is_multiple_of(judge_every) {
            judge_tel.push((ap.state.t_s, ap.state.p_m));
        }
        if cfg.record_track {
            track.push([
                ap.state.t_s,
                ap.state.p_m[0],
                ap.state.p_m[1],
                ap.state.p_m[2],
            ]);
        }
    }
    if judge_tel.last().is_some_and(|l| l.0 < ap.state.t_s) {
        judge_tel.push((ap.state.t_s, ap.state.p_m));
    }
    let jr = judge(&judge_tel, scenario, m);
    let metrics = RunMetrics {
        sphere_score: jr.sphere_score,
        cylinder_score: jr.cylinder_score,
        spheres_hit: jr.sphere_hits.iter().filter(|h| **h).count(),
        spheres: jr.sphere_hits.len(),
        cylinders_hit: jr.cylinder_hits.iter().filter(|h| **h).count(),
        cylinders: jr.cylinder_hits.len(),
        waypoints_captured: jr.waypoints_captured.iter().filter(|h| **h).count(),
        waypoints: jr.waypoints_captured.len(),
        waypoint_score: jr.waypoint_score,
        completed: stack.target().is_none(),
        mission_time_s: ap.state.t_s,
        path_length_m: path_len,
        path_ratio: path_ratio(m, scenario.start_m, path_len),
        min_clearance_m: jr.min_clearance_m,
        waypoints_added: added,
        avoid_targets,
        route_added_m: route_added,
        route_removed_m: route_removed,
        boundary_violation_s: jr.boundary_violation_s,
        boundary_excursions: jr.boundary_excursions,
        replans: latencies_ms.len(),
        replan_p50_ms: percentile(&latencies_ms, 0.5),
        replan_p95_ms: percentile(&latencies_ms, 0.95),
        replan_max_ms: latencies_ms.iter().copied().fold(0.0, f64::max),
        replan_cpu_p95_ms: percentile(&cpu_ms, 0.95),
        replan_cpu_max_ms: cpu_ms.iter().copied().fold(0.0, f64::max),
        live_p95_ms: percentile(&live_ms, 0.95),
    };
    RunResult {
        seed: scenario.seed,
        strategy,
        metrics,
        judge: jr,
        track,
        latencies_ms,
        live_ms,
        cpu_ms,
    }
}

/// `JINK_SIM_TRACE`: one stderr line each time the aircraft leaves or re-enters the fly
/// zone (its boundary or its altitude band, as the judges count time out of the zone), with
/// where and which limit.
fn trace_zone(scenario: &Scenario, own: &crate::aircraft::AircraftState, out: &mut bool) {
    let (horizontal, vertical) = crate::scoring::outside_zone(&scenario.mission, own.p_m);
    if (horizontal || vertical) != *out {
        *out = horizontal || vertical;
        eprintln!(
            "{} zone t={:.1} s pos=({:.0}, {:.0}, {:.0}){}",
            if *out { "exit" } else { "enter" },
            own.t_s,
            own.p_m[0],
            own.p_m[1],
            own.p_m[2],
            match (horizontal, vertical) {
                (true, true) => " boundary and altitude",
                (true, false) => " boundary",
                (false, true) => " altitude",
                (false, false) => "",
            }
        );
    }
}

/// Runs `strategy` on `scenario`, drawing the telemetry from the scenario's seed.
pub fn run(scenario: &Scenario, strategy: StrategyKind, cfg: &RunConfig) -> RunResult {
    let streams = sample_streams(scenario, &cfg.telemetry);
    run_with_streams(scenario, &streams, strategy, cfg)
}

/// Telemetry parameters re-exported for callers building a [`RunConfig`].
pub type Telemetry = TelemetryParams;

/// `JINK_SIM_TRACE`: one stderr line each time the aircraft enters or leaves a sphere
/// (which sphere, when, the aircraft's and the sphere's positions), between the plan lines.
fn trace_inside(scenario: &Scenario, own: &crate::aircraft::AircraftState, inside: &mut [bool]) {
    for (k, s) in scenario.spheres.iter().enumerate() {
        let c = s.track.at(own.t_s);
        let d = ((own.p_m[0] - c[0]).powi(2)
            + (own.p_m[1] - c[1]).powi(2)
            + (own.p_m[2] - c[2]).powi(2))
        .sqrt()
            - s.radius_m;
        if (d < 0.0) != inside[k] {
            inside[k] = d < 0.0;
            eprintln!(
                "{} sphere {k} t={:.1} s pos=({:.0}, {:.0}, {:.0}) centre=({:.0}, {:.0}, {:.0}) radius={:.0}",
                if d < 0.0 { "enter" } else { "leave" },
                own.t_s,
                own.p_m[0],
                own.p_m[1],
                own.p_m[2],
                c[0],
                c[1],
                c[2],
                s.radius_m
            );
        }
    }
}
