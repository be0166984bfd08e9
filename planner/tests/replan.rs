//! The replanning seam: deterministic for a seed, and the simulator's path (a predictor
//! whose cached map is built by the seam) and the server's path (an already built map
//! from a snapshot) give the same plan for the same inputs.

mod common;

use planner::stack::mission_stack;
use planner::{
    AircraftState, Dynamic, Mission, Replan, ReplanConfig, Strategy, Termination, replan,
};
use predictor::{Observation, Predictor, PredictorConfig};

fn mission() -> Mission {
    common::one_leg_mission([-100.0, -600.0], [2100.0, 600.0])
}

/// An obstacle crossing the leg northward at 5 m/s, observed for 10 s: it reaches the leg
/// (x = 300 m) when the aircraft does (t = 25 s).
fn fed_predictor() -> Predictor {
    let mut p = Predictor::new(PredictorConfig::default());
    for k in 0..=10 {
        let t = f64::from(k);
        p.observe(
            "7",
            Observation {
                t_s: t,
                p_m: [300.0, -125.0 + 5.0 * t],
                alt_m: 100.0,
                radius_m: 30.0,
            },
        );
    }
    p
}

fn config() -> ReplanConfig {
    let mut c = ReplanConfig::default().horizon_s(30.0);
    c.map = c.map.cell_m(20.0).particles(64);
    c
}

fn request<'a>(m: &'a Mission, stack: &'a [planner::StackItem], seed: u64) -> Replan<'a> {
    let state = AircraftState {
        p_m: [0.0, 0.0],
        alt_m: 100.0,
        heading_rad: std::f64::consts::FRAC_PI_2,
        speed_mps: 20.0,
        t_s: 10.0,
    };
    common::replan_request(m, stack, state, seed)
}

#[test]
fn the_predictor_path_and_the_prebuilt_map_path_give_the_same_plan() {
    let m = mission();
    let stack = mission_stack(&m);
    let cfg = config();
    let r = request(&m, &stack, 5);

    let sim_side = fed_predictor();
    let a = replan(
        &r,
        Dynamic::Predictor(&sim_side),
        &cfg,
        &Termination::none(),
    )
    .unwrap();

    // The server's side: the live snapshot's map, built from its own predictor.
    let snap = fed_predictor();
    let map = planner::live_map(&snap, &m, &cfg).unwrap().unwrap().map;
    let b = common::replan_on_map(&r, &map, &snap, &cfg);

    assert_eq!(a, b);
    assert!(a.dynamic.map_used);
    assert_eq!(a.dynamic.obstacles.len(), 1);
    assert!(a.dynamic.obstacles[0].in_map && a.dynamic.obstacles[0].threat);
    assert_eq!(
        a.dynamic.variability,
        Some(a.dynamic.obstacles[0].stage.variability())
    );
    // Not vacuous: the mover is on the leg, so the plan leaves the straight line.
    assert!(a.plan.items.len() > 2, "{:?}", a.plan.items);
}

#[test]
fn the_seam_is_deterministic_for_a_seed_and_reports_no_map_without_obstacles() {
    let m = mission();
    let stack = mission_stack(&m);
    let cfg = config();
    let run = |seed| {
        let p = fed_predictor();
        replan(
            &request(&m, &stack, seed),
            Dynamic::Predictor(&p),
            &cfg,
            &Termination::none(),
        )
        .unwrap()
    };
    assert_eq!(run(3), run(3));

    let none = replan(
        &request(&m, &stack, 3),
        Dynamic::None,
        &cfg,
        &Termination::none(),
    )
    .unwrap();
    assert!(!none.dynamic.map_used && none.dynamic.obstacles.is_empty());
    assert_eq!(none.plan.items, stack);
}

#[test]
fn the_map_grid_covers_the_fly_zones_and_home_plus_the_margin() {
    let cfg = ReplanConfig::default();
    let g = cfg.map_config(&mission());
    assert_eq!(g.min_m, [-400.0, -900.0]);
    assert_eq!(g.max_m, [2400.0, 900.0]);
    // 5 m cells up to 15 s, kept out of the shared grid; 20 m beyond.
    assert_eq!(g.cell_m, 5.0);
    assert_eq!(
        (g.fine_horizon_s, g.coarse_horizon_s, g.coarse_factor),
        (15.0, 15.0, 2)
    );
    assert!(g.sparse_fine);
    assert_eq!(g.horizon_s, 30.0);
}

/// Risk 0.3 within 60 m of (500, 0) at every time: a sphere circling near a waypoint.
struct Ring;
impl predictor::RiskField for Ring {
    fn risk(&self, p: [f64; 2], _t: f64) -> f64 {
        if (p[0] - 500.0).hypot(p[1]) < 60.0 {
            0.3
        } else {
            0.0
        }
    }
}

#[test]
fn the_time_a_waypoint_has_been_pending_uses_up_the_delay_a_route_may_take_to_reach_it() {
    // The stack flown: a loop north through (250, 450), then the waypoint at (500, 0)
    // inside the ring, met some 48 s ahead instead of 22 s straight. While the waypoint is
    // new, the delay is credited and the ring is read against the looser limit of its
    // later arrival: clear. After 100 s of putting the waypoint off, none is left: the ring
    // counts as if flown straight, and the same stack is no longer clear.
    let m = mission();
    let stack = [
        planner::StackItem::avoid([250.0, 450.0], 100.0),
        planner::StackItem::mission(1, [500.0, 0.0], 100.0),
    ];
    // The delay credit alone: the far limit's overdue budget (the next test) off, and a
    // 60 s horizon, within which the loop meets the ring. The far limit 0.5 (the default
    // until 2026-12-06): at 1 the ring (0.3) met 22 s ahead straight is under its limit
    // there (0.1 + 0.9 * 12 / 50 = 0.32), and the credit has nothing to decide.
    let mut cfg = ReplanConfig::default().horizon_s(60.0);
    cfg.plan.verify.overdue_far_risk_per_s = 0.0;
    cfg.plan.verify.far_risk = 0.5;
    let plan_with = |pending: Option<f64>| {
        let r = Replan {
            current_index: 0,
            strategy: Strategy::None,
            target_pending_s: pending,
            revisit: false,
            captured: false,
            ..request(&m, &stack, 5)
        };
        replan(&r, Dynamic::Field(&Ring), &cfg, &Termination::none())
            .expect("plan")
            .plan
    };
    let fresh = plan_with(None);
    assert_eq!(fresh.items, stack, "strategy none keeps the stack");
    assert!(
        fresh.verification.is_clear(cfg.plan.safe_risk),
        "{:?}",
        fresh.verification
    );
    assert_eq!(fresh.verification, plan_with(Some(0.0)).verification);
    let late = plan_with(Some(100.0));
    assert!(
        !late.verification.is_clear(cfg.plan.safe_risk),
        "{:?}",
        late.verification
    );
    assert!((late.verification.peak_risk - 0.3).abs() < 1e-12);
}

#[test]
fn an_overdue_waypoint_earns_a_looser_far_limit_but_never_a_looser_near_one() {
    // The straight stack to the waypoint at (500, 0) inside the ring (risk 0.3), met 22 s
    // ahead at 20 m/s. The limit there, 0.1 + (far - 0.1) * (22 - 10) / (40 - 10) at a
    // 40 s horizon (the arithmetic is the rule's; the default horizon, 30 s, would clear
    // the ring at the limit alone): 0.26 at a far limit of 0.5 (the default until
    // 2026-12-06; at today's default, 1, nothing is left for the budget to raise, and the
    // limit there is 0.46, clear from the start), so the route is not clear
    // while the waypoint is within its delay credit (60 s) or only just past it (65 s: far
    // 0.55, limit 0.28). Pending 200 s, 140 s overdue, the budget (0.01 a second) has
    // raised the far limit to its cap of 1: 0.46 there, clear.
    let m = mission();
    let stack = [planner::StackItem::mission(1, [500.0, 0.0], 100.0)];
    let plan_with = |cfg: &ReplanConfig, x_m: f64, pending: Option<f64>| {
        let base = request(&m, &stack, 5);
        let r = Replan {
            current_index: 0,
            strategy: Strategy::None,
            target_pending_s: pending,
            state: AircraftState {
                p_m: [x_m, 0.0],
                ..base.state
            },
            ..base
        };
        replan(&r, Dynamic::Field(&Ring), cfg, &Termination::none())
            .expect("plan")
            .plan
            .verification
    };
    let mut cfg = ReplanConfig::default().horizon_s(40.0);
    let safe = cfg.plan.safe_risk;
    assert_eq!(cfg.plan.verify.overdue_far_risk_per_s, 0.01);
    assert_eq!(cfg.plan.verify.overdue_far_risk_max, 1.0);
    assert_eq!(cfg.plan.verify.far_risk, 1.0);
    assert!(plan_with(&cfg, 0.0, None).is_clear(safe));
    cfg.plan.verify.far_risk = 0.5;
    for pending in [None, Some(30.0), Some(60.0), Some(65.0)] {
        let v = plan_with(&cfg, 0.0, pending);
        assert!(!v.is_clear(safe), "pending {pending:?}: {v:?}");
        assert!((v.peak_risk - 0.3).abs() < 1e-12);
    }
    let overdue = plan_with(&cfg, 0.0, Some(200.0));
    assert!(overdue.is_clear(safe), "{overdue:?}");
    // The graded peak is the risk against the limit where it is met, by hand.
    let limit = 0.1 + 0.9 * (22.0 - 10.0) / 30.0;
    assert!(
        (overdue.graded_peak_risk - 0.3 * safe / limit).abs() < 0.005,
        "{overdue:?}"
    );
    // Without the budget the same wait buys nothing.
    let mut off = cfg.clone();
    off.plan.verify.overdue_far_risk_per_s = 0.0;
    assert!(!plan_with(&off, 0.0, Some(200.0)).is_clear(safe));
    // Met 7 s ahead (from 300 m east), within the near window: never clear, however late.
    for pending in [None, Some(200.0), Some(1e4)] {
        let v = plan_with(&cfg, 300.0, pending);
        assert!(!v.is_clear(safe), "pending {pending:?}: {v:?}");
        assert!(v.near_peak_risk > safe, "{v:?}");
    }
}

#[test]
fn a_waypoint_captured_on_the_way_is_skipped_with_the_avoid_items_before_it() {
    // The stack flown: an avoid item, waypoint 0, then the test above's loop to waypoint 1
    // inside the ring. The caller found waypoint 0 captured on the way: the plan goes on
    // with the loop, its diff against the stack as given removes the avoid item and the
    // waypoint, and the 100 s waypoint 0 was pending are not charged to waypoint 1 (they
    // would leave no delay credit, and the loop would not be clear: see the test above).
    let m = mission();
    let stack = [
        planner::StackItem::avoid([-250.0, -300.0], 100.0),
        planner::StackItem::mission(0, [0.0, 300.0], 100.0),
        planner::StackItem::avoid([250.0, 450.0], 100.0),
        planner::StackItem::mission(1, [500.0, 0.0], 100.0),
    ];
    let cfg = ReplanConfig::default();
    let plan_with = |captured: bool, pending: Option<f64>| {
        let r = Replan {
            current_index: 0,
            strategy: Strategy::None,
            target_pending_s: pending,
            captured,
            ..request(&m, &stack, 5)
        };
        replan(&r, Dynamic::Field(&Ring), &cfg, &Termination::none())
            .expect("plan")
            .plan
    };
    let kept = plan_with(false, Some(100.0));
    assert_eq!(kept.items, stack, "not captured: the stack is kept");
    assert!(kept.diff.is_empty());
    let skipped = plan_with(true, Some(100.0));
    assert_eq!(
        (skipped.items.as_slice(), skipped.current_index),
        (&stack[2..], 0)
    );
    assert_eq!(skipped.diff.first_changed, Some(0));
    assert_eq!(
        (skipped.diff.remove, skipped.diff.insert.as_slice()),
        (4, &stack[2..])
    );
    // The pending time is dropped with the waypoint: clear, the same verification as fresh.
    assert!(
        skipped.verification.is_clear(cfg.plan.safe_risk),
        "{:?}",
        skipped.verification
    );
    assert_eq!(
        skipped.verification,
        plan_with(true, None).verification,
        "waypoint 1 is charged nothing of waypoint 0's wait"
    );
    // With a revisit asked too, the revisit wins and nothing is skipped.
    let r = Replan {
        current_index: 1,
        strategy: Strategy::None,
        revisit: true,
        captured: true,
        ..request(&m, &stack, 5)
    };
    let revisit = replan(&r, Dynamic::Field(&Ring), &cfg, &Termination::none())
        .expect("plan")
        .plan;
    assert_eq!(revisit.items.len(), 5, "{:?}", revisit.items);
    assert_eq!(revisit.items[1], stack[0]);
}

/// Risk 1 across the whole corridor of the test below between x = 450 and 750 from 15 s
/// to 38 s, none elsewhere or at other times: what a sphere much wider than the corridor
/// crossing it leaves, without the geometry (the corridor is shut for 23 s and then open).
struct Gate;
impl Gate {
    fn shut(p: [f64; 2], t: f64) -> bool {
        (450.0..=750.0).contains(&p[0]) && (15.0..=38.0).contains(&t)
    }
}
impl predictor::RiskField for Gate {
    fn risk(&self, p: [f64; 2], t: f64) -> f64 {
        if Gate::shut(p, t) { 1.0 } else { 0.0 }
    }
}

#[test]
fn a_hold_circle_is_flown_for_an_overdue_waypoint_for_two_minutes_and_only_then() {
    // A corridor 140 m wide east (y from -70 to 70), the aircraft at its west end on the
    // south side (y = -60) at t = 0, heading east at 20 m/s to the waypoint 2 km on: it
    // reaches the gate at 22.5 s, while it is shut, and cannot get past it before (x = 750
    // by 15 s) nor bend its route enough to arrive after 38 s. Only a wait (a hold circle,
    // 19 s or more) gets it through, and with `hold_overdue` (the default) the replan
    // seam turns the hold on only once the waypoint has been pending longer than the
    // delay credit (60 s), and only for the first `hold_overdue_max_s` (120 s) it is
    // overdue. Defaults otherwise, but for a 40 s horizon (the gate's times are set for
    // it: an overdue waypoint's route is also read past the horizon, at 40 s: open; the
    // default 30 s would read it shut).
    let mut m = mission();
    m.fly_zones = vec![common::rect_zone([-70.0, -70.0], [2200.0, 70.0])];
    m.waypoints = common::waypoints_at_100m(&[[0.0, -60.0], [2000.0, -60.0]]);
    let stack = mission_stack(&m);
    let plan_with = |cfg: &ReplanConfig, pending: Option<f64>| {
        let base = request(&m, &stack, 3);
        let r = Replan {
            target_pending_s: pending,
            state: AircraftState {
                p_m: [0.0, -60.0],
                t_s: 0.0,
                ..base.state
            },
            ..base
        };
        replan(&r, Dynamic::Field(&Gate), cfg, &Termination::none())
            .expect("plan")
            .plan
    };
    let cfg = ReplanConfig::default().horizon_s(40.0);
    assert!(!cfg.plan.hold && cfg.plan.hold_overdue);
    assert_eq!(cfg.plan.verify.delay_credit_s, 60.0);
    assert_eq!(cfg.plan.hold_overdue_max_s, 120.0);
    let held = |cfg: &ReplanConfig, pending: f64| {
        let p = plan_with(cfg, Some(pending));
        if p.outcome != planner::PlanOutcome::Exact {
            return false;
        }
        // Checked independently: the route flown at 20 m/s, densely sampled, to its end.
        let pts: Vec<[f64; 2]> = std::iter::once([0.0, -60.0])
            .chain(p.items[p.current_index..].iter().map(|i| i.p_m))
            .collect();
        let mut t = 0.0;
        for w in pts.windows(2) {
            let l = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
            let r = common::sampled_max(&Gate, w[0], w[1], t, t + l / 20.0);
            assert_eq!(r, 0.0, "{pending}: {w:?} from {t:.1} s meets the shut gate");
            t += l / 20.0;
        }
        // A wait: the route reaches the gate after it opens (38 s against 22.5 straight),
        // so it is 15.5 s longer than straight at least.
        assert!(t >= 2000.0 / 20.0 + 15.5, "{pending}: {t:.1} s");
        true
    };
    // Within the credit (up to 60 s pending): no hold, and nothing else is clear.
    for pending in [None, Some(30.0), Some(60.0)] {
        let p = plan_with(&cfg, pending);
        assert_ne!(p.outcome, planner::PlanOutcome::Exact, "{pending:?}: {p:?}");
    }
    // Overdue (1 s and 110 s past the credit): the hold is tried, and the plan is a wait
    // verified clear.
    for pending in [61.0, 170.0] {
        assert!(held(&cfg, pending), "{pending} s pending: no hold");
    }
    // Past the bound (140 s overdue): the hold is off again and nothing is clear, though
    // with the bound lifted the same request is held.
    assert!(!held(&cfg, 200.0), "200 s pending: held past the bound");
    let mut unbounded = cfg.clone();
    unbounded.plan.hold_overdue_max_s = f64::INFINITY;
    assert!(held(&unbounded, 200.0));
    // The rule off: overdue, still no hold and nothing clear.
    let mut off = cfg.clone();
    off.plan.hold_overdue = false;
    for pending in [61.0, 170.0] {
        assert!(
            !held(&off, pending),
            "{pending} s pending: held with the rule off"
        );
    }
}

/// A sphere of 15 m flying straight east at 18 m/s along y = 0 from x = 0, observed at
/// 5 Hz for 60 s.
fn straight_track() -> Predictor {
    observed_at_5hz("3", 60.0, |t| [18.0 * t, 0.0])
}

/// A predictor that has observed obstacle `id`, a sphere of 15 m at 100 m, at 5 Hz from
/// t = 0 to `secs` along `path`.
fn observed_at_5hz(id: &str, secs: f64, path: impl Fn(f64) -> [f64; 2]) -> Predictor {
    let mut p = Predictor::new(PredictorConfig::default());
    for k in 0..=(secs * 5.0).round() as i32 {
        let t = 0.2 * f64::from(k);
        p.observe(
            id,
            Observation {
                t_s: t,
                p_m: path(t),
                alt_m: 100.0,
                radius_m: 15.0,
            },
        );
    }
    p
}

#[test]
fn the_live_map_reads_a_passing_sphere_at_most_one_slice_longer_each_side_than_it_is_there() {
    // A read takes at worst the worse of the two slices round its time (within the first
    // 15 s, the server's sparse slices, each obstacle where its cloud is between them), so
    // the map holds a point up to one slice interval before the sphere reaches it and after
    // it has left: the interval bounds how much of a gap (a swept waypoint's window) reads
    // as held.
    let m = common::one_leg_mission([-100.0, -600.0], [3100.0, 600.0]);
    let cfg = ReplanConfig::default();
    let live = planner::replan::live_map(&straight_track(), &m, &cfg)
        .unwrap()
        .expect("a map");
    let dt = planner::replan::SLICE_DT_S;
    let horizon = planner::DEFAULT_HORIZON_S;
    assert_eq!(live.map.slices(), (horizon / dt).round() as usize + 1);
    // Points the centre crosses 1.3-4.7 s after the anchor (off the slice times too).
    for ahead in [1.3, 2.0, 2.75, 3.6, 4.7] {
        let tp = live.t0_s + ahead;
        let pt = [18.0 * tp, 0.0];
        // The truth: within radius plus the 5 m buffer for (15 + 5) / 18 s each side.
        let half = 20.0 / 18.0;
        // Read from the anchor on (earlier times read slice 0).
        let held: Vec<f64> = (0..=200)
            .map(|i| tp - 5.0 + 0.05 * f64::from(i))
            .filter(|&t| t >= live.t0_s)
            .filter(|&t| predictor::RiskField::risk(&live.map, pt, t) >= 0.06)
            .collect();
        let (first, last) = (held[0], held[held.len() - 1]);
        // Slack: 9 m at 18 m/s, for the cells and the particles' spread.
        let slack = 0.5;
        let (enter, leave) = (first - tp, last - tp);
        assert!(
            enter <= -half + slack && leave >= half - slack,
            "{ahead} s ahead: held {enter:.2}..{leave:.2} s round the crossing, there ±{half:.2}"
        );
        assert!(
            enter >= -half - dt - slack && leave <= half + dt + slack,
            "{ahead} s ahead: held {enter:.2}..{leave:.2} s, more than a {dt} s slice longer \
             each side than ±{half:.2}"
        );
        assert_eq!(
            held.len(),
            ((last - first) / 0.05).round() as usize + 1,
            "one held run"
        );
    }
}

/// How many reads of a sphere's edge on `cfg`'s live map are wrong by more than `tol_m`:
/// a 30 ft sphere at rest off the cells' corners, read over the first 15 s on rings
/// `tol_m` inside (must be certain) and outside (must be clear) its radius plus buffer.
fn edge_errors(cfg: &ReplanConfig, tol_m: f64) -> usize {
    let m = common::one_leg_mission([-300.0, -300.0], [300.0, 300.0]);
    let c = [43.3, -16.8];
    let mut p = Predictor::new(PredictorConfig::default());
    for k in 0..=30 {
        let o = Observation {
            t_s: 0.1 * f64::from(k),
            p_m: c,
            alt_m: 100.0,
            radius_m: 9.144,
        };
        p.observe("s", o);
    }
    let live = planner::replan::live_map(&p, &m, cfg)
        .unwrap()
        .expect("a map");
    let edge = 9.144 + cfg.map.buffer_m;
    let mut wrong = 0;
    for k in 0..=30 {
        let t = live.t0_s + 0.5 * f64::from(k);
        for i in 0..360 {
            let a = f64::from(i).to_radians();
            let at = |d: f64| [c[0] + d * a.cos(), c[1] + d * a.sin()];
            let inside = predictor::RiskField::risk(&live.map, at(edge - tol_m), t);
            let outside = predictor::RiskField::risk(&live.map, at(edge + tol_m), t);
            wrong += usize::from(inside < 0.99) + usize::from(outside > 0.0);
        }
    }
    wrong
}

#[test]
fn the_live_map_puts_a_spheres_edge_within_a_5_m_cells_diagonal_up_to_15_s_ahead() {
    // The server's map (`ReplanConfig::default`): 5 m cells up to 15 s, read from the
    // obstacles' runs. A particle is splatted from its cell's centre and a read is its
    // cell's, so the edge is off by at most a cell's diagonal (7.07 m); with the 10 m cells
    // of before, by up to 14.1 m, which the same check finds.
    let tol = 5.0 * std::f64::consts::SQRT_2 + 0.05;
    assert_eq!(edge_errors(&ReplanConfig::default(), tol), 0);
    let before = ReplanConfig {
        map: predictor::RiskMapConfig::default().cell_m(10.0),
        ..ReplanConfig::default()
    };
    assert!(
        edge_errors(&before, tol) > 0,
        "10 m cells should miss the edge somewhere"
    );
}

/// An obstacle of radius 15 m flying east at `speed` m/s, `north_m` north of the leg, weaving
/// 20 m either side every 12 s, observed at 5 Hz for 10 s, 30 m behind the aircraft at the
/// end: its cloud spreads across its track, and the leg reads its southern edge.
fn weaving_flyer(speed: f64, north_m: f64) -> Predictor {
    observed_at_5hz("5", 10.0, |t| {
        [
            speed * (t - 10.0) - 30.0,
            north_m + 20.0 * (std::f64::consts::TAU * t / 12.0).sin(),
        ]
    })
}

/// The mission's stack planned with strategy none (flown as given) against `p` on `cfg`,
/// for an aircraft reporting a cruise speed of `cruise` m/s.
fn flown_as_given(p: &Predictor, cfg: &ReplanConfig, cruise: f64) -> planner::Plan {
    flown_as_given_seen(p, cfg, cruise).plan
}

/// [`flown_as_given`], with what the seam reports beside the plan (its near window).
fn flown_as_given_seen(p: &Predictor, cfg: &ReplanConfig, cruise: f64) -> planner::Replanned {
    let m = mission();
    let stack = mission_stack(&m);
    let mut r = Replan {
        strategy: Strategy::None,
        ..request(&m, &stack, 5)
    };
    r.aircraft.speed_mps = cruise;
    replan(&r, Dynamic::Predictor(p), cfg, &Termination::none()).expect("plan")
}

#[test]
fn an_obstacle_faster_than_the_aircraft_counts_twice_within_the_near_window() {
    // The stack straight east along the leg, flown as given (strategy none), beside a
    // weaving flyer at 25 m/s, faster than the 20 m/s aircraft: its near-term risk on the
    // route is read at twice its probability (at most 1), so a route that meets it at
    // 0.06-0.1 within 10 s, clear at its own probability, is not clear. The same flyer
    // with an aircraft whose cruise speed is 30 m/s (its route still timed at the 20 m/s
    // it reports) is not faster, and counts once; met beyond the near window, it counts
    // once too.
    let stack = mission_stack(&mission());
    let plan = |p: &Predictor, weight: u32, cruise: f64| {
        let mut cfg = config();
        cfg.plan.verify.fast_weight = weight;
        // One near window at every cruise speed (PlanParams::calm_near_s would shorten it
        // for the 30 m/s aircraft, which nothing here is as fast as).
        cfg.plan.calm_near_s = 0.0;
        flown_as_given(p, &cfg, cruise)
    };
    assert_eq!(config().plan.verify.fast_weight, 1, "off by default");
    let (mut compared, mut flipped) = (0, 0);
    let mut beyond = 0;
    for north in (90..=250).step_by(4) {
        let p = weaving_flyer(25.0, f64::from(north));
        let once = plan(&p, 1, 20.0);
        let twice = plan(&p, 2, 20.0);
        assert_eq!(once.items, stack);
        let (r1, r2) = (
            once.verification.near_peak_risk,
            twice.verification.near_peak_risk,
        );
        assert!(
            (r2 - (2.0 * r1).min(1.0)).abs() < 1e-6,
            "{north} m north: near-term peak {r1} once, {r2} twice"
        );
        // Slower than the aircraft's cruise speed: its own probability.
        assert_eq!(plan(&p, 2, 30.0).verification, once.verification);
        if r1 > 0.0 {
            compared += 1;
        }
        // Met only beyond the near window: the same peaks and verdict either way (the
        // exposure may differ by what is read between the window's last slice and the
        // next, which reads that slice at the weight).
        if r1 == 0.0 && once.verification.peak_risk > 0.05 {
            let (a, b) = (&once.verification, &twice.verification);
            assert_eq!(
                (a.peak_risk, a.graded_peak_risk, b.near_peak_risk),
                (b.peak_risk, b.graded_peak_risk, 0.0),
                "{north} m north"
            );
            assert_eq!(a.is_clear(0.1), b.is_clear(0.1));
            beyond += 1;
        }
        if (0.06..=0.1).contains(&r1) && once.verification.is_clear(0.1) {
            assert!(!twice.verification.is_clear(0.1), "{north} m north: {r1}");
            flipped += 1;
        }
    }
    assert!(
        compared >= 5 && flipped >= 1 && beyond >= 5,
        "{compared} compared, {flipped} flipped, {beyond} beyond the window"
    );
}

#[test]
fn an_obstacle_faster_than_the_aircraft_keeps_the_longer_near_window_of_its_own() {
    // The flyer of the test above, at 25 m/s beside the 20 m/s aircraft, the stack flown
    // as given. With a 7 s near window and 10 s for obstacles faster than the aircraft
    // (VerifyParams::fast_near_s), its risk is graded as the 10 s window grades it: the
    // same graded peak and verdict as a 10 s window for every obstacle, to the rounding of
    // a weighted particle count. Slower than the aircraft (cruise 30 m/s), it has the
    // 7 s window, exactly as without the longer one. Some of these routes are clear with
    // a 7 s window and not with 10 s: the longer window of its own is what decides them.
    let plan = |p: &Predictor, near: f64, fast_near: f64, cruise: f64| {
        let mut cfg = config();
        cfg.plan.verify.near_s = near;
        cfg.plan.verify.fast_near_s = fast_near;
        flown_as_given(p, &cfg, cruise).verification
    };
    let (mut met, mut decided) = (0, 0);
    for north in (90..=250).step_by(4) {
        let p = weaving_flyer(25.0, f64::from(north));
        let ten = plan(&p, 10.0, 10.0, 20.0);
        let seven = plan(&p, 7.0, 7.0, 20.0);
        let own = plan(&p, 7.0, 10.0, 20.0);
        assert!(
            (own.graded_peak_risk - ten.graded_peak_risk).abs() < 0.005,
            "{north} m north: graded peak {} with its own window, {} with 10 s for all",
            own.graded_peak_risk,
            ten.graded_peak_risk
        );
        if (ten.graded_peak_risk - 0.1).abs() > 0.005 {
            assert_eq!(own.is_clear(0.1), ten.is_clear(0.1), "{north} m north");
        }
        // Not faster than the aircraft: the 7 s window's verification, exactly.
        assert_eq!(plan(&p, 7.0, 10.0, 30.0), plan(&p, 7.0, 7.0, 30.0));
        if ten.graded_peak_risk > 0.0 {
            met += 1;
        }
        if seven.is_clear(0.1) && !ten.is_clear(0.1) {
            assert!(!own.is_clear(0.1), "{north} m north");
            decided += 1;
        }
    }
    assert!(met >= 5 && decided >= 1, "{met} met, {decided} decided");
}

/// Three spheres of 30 m watched at 5 Hz for 10 s, flying east, at t = 10 s over x = 0: a
/// fast one (25 m/s) 300 m north at 100 m, a slow one (10 m/s) 100 m north at 100 m, and a
/// fast one 200 m north at 400 m.
fn three_tracked_spheres() -> Predictor {
    let mut p = Predictor::new(PredictorConfig::default());
    for (id, speed, north, alt) in [
        ("fast", 25.0, 300.0, 100.0),
        ("slow", 10.0, 100.0, 100.0),
        ("high", 25.0, 200.0, 400.0),
    ] {
        for k in 0..=50 {
            let t = 0.2 * f64::from(k);
            p.observe(
                id,
                Observation {
                    t_s: t,
                    p_m: [speed * (t - 10.0), north],
                    alt_m: alt,
                    radius_m: 30.0,
                },
            );
        }
    }
    p
}

#[test]
fn the_nearest_obstacle_faster_than_the_aircraft_is_measured_from_its_edge() {
    // Three spheres of 30 m watched for 10 s, flying east, at t = 10 s over x = 0: a fast
    // one (25 m/s) 300 m north at the aircraft's altitude, a slow one (10 m/s) 100 m north,
    // and a fast one 200 m north but 300 m higher. For a 20 m/s aircraft at the origin
    // flying at 100 m only the first counts: its edge is 270 m away
    // (PlanParams::fast_obstacle_m, which PlanParams::chase_escape_m reads).
    let p = three_tracked_spheres();
    let obstacles: Vec<_> = p.obstacles().collect();
    let near = |speed: f64, alt: [f64; 2]| {
        planner::replan::nearest_fast_obstacle_m(&obstacles, speed, [0.0, 0.0], alt, 5.0)
    };
    let close = |d: Option<f64>, want: f64| d.is_some_and(|d| (d - want).abs() < 2.0);
    assert!(
        close(near(20.0, [100.0, 100.0]), 270.0),
        "{:?}",
        near(20.0, [100.0, 100.0])
    );
    // A route that climbs to 400 m reaches the high one too.
    assert!(
        close(near(20.0, [100.0, 400.0]), 170.0),
        "{:?}",
        near(20.0, [100.0, 400.0])
    );
    // For a 5 m/s aircraft the slow one is faster, and nearest.
    assert!(
        close(near(5.0, [100.0, 100.0]), 70.0),
        "{:?}",
        near(5.0, [100.0, 100.0])
    );
    // For a 30 m/s aircraft none is.
    assert_eq!(near(30.0, [100.0, 400.0]), None);
}

#[test]
fn the_near_window_is_shorter_while_nothing_about_as_fast_as_the_aircraft_is_near() {
    // The three spheres of the test above (edges: the 25 m/s one 270 m away, the 10 m/s
    // one 70 m, the 25 m/s one 300 m higher 170 m). PlanParams::calm_near_s: 7 s while no
    // obstacle at least 0.9 times the aircraft's cruise speed, at the route's altitudes,
    // has its edge within 400 m; the full 10 s otherwise.
    let p = three_tracked_spheres();
    let obstacles: Vec<_> = p.obstacles().collect();
    let defaults = planner::PlanParams::default();
    assert_eq!(
        (
            defaults.calm_near_s,
            defaults.calm_speed_factor,
            defaults.calm_m,
            defaults.verify.near_s
        ),
        (7.0, 0.9, 400.0, 10.0),
        "on by default"
    );
    let window = |params: &planner::PlanParams, cruise: f64, alt: [f64; 2]| {
        planner::replan::calm_near_s(params, &obstacles, cruise, [0.0, 0.0], alt, 5.0)
    };
    let level = [100.0, 100.0];
    // A 20 m/s aircraft: the fast sphere, 270 m off, keeps the full window; only within
    // 250 m would it not.
    assert_eq!(window(&defaults, 20.0, level), 10.0);
    let within_250 = planner::PlanParams {
        calm_m: 250.0,
        ..defaults
    };
    assert_eq!(window(&within_250, 20.0, level), 7.0);
    // Climbing to 400 m the high one, 170 m off, is reached too.
    assert_eq!(window(&within_250, 20.0, [100.0, 400.0]), 10.0);
    // An 11 m/s aircraft: the 10 m/s sphere is at least 0.9 times as fast, 70 m off.
    let within_100 = planner::PlanParams {
        calm_m: 100.0,
        ..defaults
    };
    assert_eq!(window(&within_100, 11.0, level), 10.0);
    // A 12 m/s one: 10 m/s is under 0.9 times its speed, and the fast one is 270 m off.
    assert_eq!(window(&within_100, 12.0, level), 7.0);
    // A 30 m/s aircraft: none is at least 27 m/s.
    assert_eq!(window(&defaults, 30.0, [100.0, 400.0]), 7.0);
    // Off: 0, or a calm window no shorter than the near window.
    for calm in [0.0, 10.0, 12.0] {
        let p = planner::PlanParams {
            calm_near_s: calm,
            ..defaults
        };
        assert_eq!(window(&p, 30.0, level), 10.0, "calm_near_s {calm}");
    }
    // No obstacle at all: calm.
    assert_eq!(
        planner::replan::calm_near_s(&defaults, &[], 20.0, [0.0, 0.0], level, 5.0),
        7.0
    );
}

#[test]
fn a_sphere_at_rest_where_its_tour_turns_back_keeps_the_full_window_near_it() {
    // The judges' out-and-back tour, x = 150 sin(2 pi t / 60) (at most 15.7 m/s), `north`
    // m north of a 15 m/s aircraft at the origin, watched until t = 15 s: at rest where it
    // turns back. Its speed now reads under 3 m/s, but within the last 30 s it flew 15.45
    // m/s, above 0.9 times the aircraft's (ObstacleSummary::recent_max_speed_mps), so a
    // plan near it keeps the full 10 s window (PlanParams::calm_near_s); beyond calm_m it
    // takes 7 s. A sphere that has flown 3 m/s all along is calm near or far.
    let defaults = planner::PlanParams::default();
    let window = |p: &Predictor| {
        let obstacles: Vec<_> = p.obstacles().collect();
        planner::replan::calm_near_s(&defaults, &obstacles, 15.0, [0.0, 0.0], [100.0; 2], 5.0)
    };
    let tour = |north: f64| {
        observed_at_5hz("tour", 15.0, move |t| {
            [150.0 * (std::f64::consts::TAU * t / 60.0).sin(), north]
        })
    };
    let near = tour(250.0);
    let s = near.obstacle("tour").unwrap();
    assert!(s.estimates.speed_mps < 3.0, "{}", s.estimates.speed_mps);
    assert!(s.recent_max_speed_mps > 15.0, "{}", s.recent_max_speed_mps);
    assert_eq!(window(&near), 10.0);
    assert_eq!(window(&tour(500.0)), 7.0);
    let slow = observed_at_5hz("slow", 15.0, |t| [3.0 * t, 250.0]);
    assert_eq!(window(&slow), 7.0);
}

#[test]
fn a_slower_sphere_met_8_s_ahead_is_read_with_the_7_s_window_unless_a_fast_one_is_near() {
    // The stack straight east along the leg, flown as given, for the 20 m/s aircraft.
    // A 15 m sphere flying west at 8 m/s, weaving 20 m either side every 12 s, 230 m ahead
    // of the aircraft at the plan and `north` m off the leg, meets it about 8 s on: between
    // a 7 s window and a 10 s one. A 25 m/s sphere flies east far south of the leg, its
    // edge 365 m from the aircraft (within PlanParams::calm_m) or 585 m (beyond). Through
    // `replan`, with the defaults, the verification is exactly that of a fixed window: 10 s
    // with the fast sphere near, 7 s with it far; and some routes are clear with the 7 s
    // window and not with 10 s, so the switch decides them.
    let plan = |south: f64, north: f64, calm: f64, near: f64| {
        let mut p = observed_at_5hz("slow", 10.0, |t| {
            [
                230.0 - 8.0 * (t - 10.0),
                north + 20.0 * (std::f64::consts::TAU * t / 12.0).sin(),
            ]
        });
        for k in 0..=50 {
            let t = 0.2 * f64::from(k);
            p.observe(
                "fast",
                Observation {
                    t_s: t,
                    p_m: [25.0 * (t - 10.0), -south],
                    alt_m: 100.0,
                    radius_m: 15.0,
                },
            );
        }
        let mut cfg = config();
        cfg.plan.calm_near_s = calm;
        cfg.plan.verify.near_s = near;
        let seen = flown_as_given_seen(&p, &cfg, 20.0);
        // The seam reports the window it verified with.
        let want = if calm > 0.0 && south > 500.0 {
            calm
        } else {
            near
        };
        assert_eq!(seen.near_s, want, "{south} m south, {north} m north");
        seen.plan.verification
    };
    assert_eq!(config().plan.calm_near_s, 7.0, "on by default");
    let (mut met, mut decided) = (0, 0);
    for north in (40..=160).step_by(4) {
        let north = f64::from(north);
        let near = plan(380.0, north, 7.0, 10.0);
        assert_eq!(
            near,
            plan(380.0, north, 0.0, 10.0),
            "{north} m north, fast near"
        );
        let far = plan(600.0, north, 7.0, 10.0);
        assert_eq!(
            far,
            plan(600.0, north, 0.0, 7.0),
            "{north} m north, fast far"
        );
        if far.peak_risk > 0.0 {
            met += 1;
        }
        let ten = plan(600.0, north, 0.0, 10.0);
        if far.is_clear(0.1) && !ten.is_clear(0.1) {
            // Met within the 10 s window but not the 7 s one, where the graded limit
            // already lets it through.
            assert!(ten.near_peak_risk > 0.1, "{north} m north: {ten:?}");
            assert!(far.near_peak_risk < ten.near_peak_risk, "{north} m north");
            decided += 1;
        }
    }
    assert!(met >= 5 && decided >= 2, "{met} met, {decided} decided");
}

#[test]
fn a_waypoint_pursued_longer_than_four_minutes_is_put_off_to_the_end_of_the_stack() {
    // Flying toward an avoid item before waypoint 0, pursued for `pending` seconds; waypoints
    // 1 and 2 follow. Past PlanParams::defer_after_s (240 s) the plan flies 1 and 2 first
    // and waypoint 0 last, without the avoid item that led to it.
    let m = mission();
    let (a, w0, w1, w2) = (
        planner::StackItem::avoid([250.0, 250.0], 100.0),
        planner::StackItem::mission(0, [500.0, 300.0], 100.0),
        planner::StackItem::mission(1, [1000.0, 0.0], 100.0),
        planner::StackItem::mission(2, [1500.0, -300.0], 100.0),
    );
    let stack = [a, w0, w1, w2];
    // Strategy::None flies the stack as given, so the test sees the rewrite alone.
    let plan_with = |stack: &[planner::StackItem], pending: Option<f64>, cfg: &ReplanConfig| {
        let r = Replan {
            current_index: 0,
            strategy: Strategy::None,
            target_pending_s: pending,
            ..request(&m, stack, 5)
        };
        replan(&r, Dynamic::None, cfg, &Termination::none()).expect("plan")
    };
    let cfg = ReplanConfig::default();
    assert_eq!(cfg.plan.defer_after_s, 240.0, "the default");

    let waited = plan_with(&stack, Some(240.0), &cfg);
    assert_eq!(waited.plan.items, stack, "not past the limit: kept");
    assert_eq!(waited.deferred, None);

    let put_off = plan_with(&stack, Some(241.0), &cfg);
    assert_eq!(put_off.plan.items, vec![w1, w2, w0]);
    assert_eq!(
        put_off.deferred,
        Some(planner::Deferred {
            stack_index: 1,
            mission_index: 0,
            pending_s: 241.0
        })
    );
    assert_eq!(put_off.plan.diff.first_changed, Some(0));
    assert_eq!(
        (
            put_off.plan.diff.remove,
            put_off.plan.diff.insert.as_slice()
        ),
        (4, &[w1, w2, w0][..])
    );
    // Waypoint 1 is charged nothing of waypoint 0's wait: the same plan as from that stack
    // fresh.
    let fresh = plan_with(&[w1, w2, w0], None, &cfg);
    assert_eq!(put_off.plan.items, fresh.plan.items);
    assert_eq!(put_off.plan.verification, fresh.plan.verification);

    // Off at 0; and the last waypoint left is waited for however long.
    let mut off = cfg.clone();
    off.plan.defer_after_s = 0.0;
    let kept = plan_with(&stack, Some(1e4), &off);
    assert_eq!(
        (kept.plan.items.as_slice(), kept.deferred),
        (&stack[..], None)
    );
    let last = plan_with(&[a, w0], Some(1e4), &cfg);
    assert_eq!(
        (last.plan.items.as_slice(), last.deferred),
        (&[a, w0][..], None)
    );

    // A waypoint captured on the way is skipped, not put off.
    let r = Replan {
        current_index: 0,
        strategy: Strategy::None,
        target_pending_s: Some(1e4),
        captured: true,
        ..request(&m, &stack, 5)
    };
    let skipped = replan(&r, Dynamic::None, &cfg, &Termination::none()).expect("plan");
    assert_eq!(
        (skipped.plan.items.as_slice(), skipped.deferred),
        (&[w1, w2][..], None)
    );
}

/// Where a route's polyline, flown at `speed` m/s from `state`, first comes within
/// `radius_m` of a disc at `c0` at `t0` moving at `v` (checked every 0.05 s up to
/// `until_s`): an independent reading of a lane.
fn first_in_lane(
    state: &AircraftState,
    items: &[planner::StackItem],
    speed: f64,
    (c0, t0, v, radius_m): ([f64; 2], f64, [f64; 2], f64),
    until_s: f64,
) -> Option<f64> {
    let mut pts = vec![state.p_m];
    pts.extend(items.iter().map(|i| i.p_m));
    let (mut leg, mut along, mut t) = (0, 0.0, state.t_s);
    while t <= until_s && leg + 1 < pts.len() {
        let (a, b) = (pts[leg], pts[leg + 1]);
        let l = (b[0] - a[0]).hypot(b[1] - a[1]);
        if along > l {
            along -= l;
            leg += 1;
            continue;
        }
        let f = if l > 0.0 { along / l } else { 0.0 };
        let p = [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f];
        let c = [c0[0] + v[0] * (t - t0), c0[1] + v[1] * (t - t0)];
        if (p[0] - c[0]).hypot(p[1] - c[1]) <= radius_m {
            return Some(t);
        }
        t += 0.05;
        along += speed * 0.05;
    }
    None
}

#[test]
fn a_sphere_faster_than_the_aircraft_closing_from_behind_is_read_along_its_lane() {
    // A 15 m sphere weaving 40 m either side of a line every 13.3 s at 25 m/s eastward,
    // 60 m behind the 20 m/s aircraft at t = 10 s, on the leg's line and heading east: it
    // closes at 5 m/s. Its predicted cloud spreads across its track, so the route flown
    // as given reads under the safe risk at every point, and the plan keeps to the lane.
    // With lanes of 10 s (PlanParams::chase_lane_s) its disc (15 m and the map's 5 m
    // buffer) carried on at its estimated velocity is read at 0.5 wherever the map reads
    // less: that route is then not clear, its first conflict where an independent flight of
    // its polyline meets the disc, and the plan leaves the lane. For an aircraft whose
    // cruise speed is 30 m/s the sphere is not faster and has no lane.
    let period = 40.0 / 3.0;
    let p = observed_at_5hz("5", 10.0, |t| {
        [
            25.0 * (t - 10.0) - 60.0,
            40.0 + 40.0 * (std::f64::consts::TAU * t / period).sin(),
        ]
    });
    let m = mission();
    let stack = mission_stack(&m);
    let plan = |lane_s: f64, strategy: Strategy, cruise: f64| {
        let mut cfg = config();
        cfg.plan.chase_lane_s = lane_s;
        let mut r = Replan {
            strategy,
            ..request(&m, &stack, 5)
        };
        r.aircraft.speed_mps = cruise;
        replan(&r, Dynamic::Predictor(&p), &cfg, &Termination::none())
            .expect("plan")
            .plan
    };
    assert_eq!(config().plan.chase_lane_s, 10.0, "on by default");
    let e = p.obstacle("5").expect("tracked").estimates;
    let lane = (e.position_m, e.t_s, e.velocity_mps, 20.0);
    let state = request(&m, &stack, 5).state;
    let in_lane = |items: &[planner::StackItem]| {
        first_in_lane(&state, &items[1..], 20.0, lane, state.t_s + 10.0)
    };
    let off = plan(0.0, Strategy::None, 20.0);
    let on = plan(10.0, Strategy::None, 20.0);
    assert!(off.verification.is_clear(0.1), "{:?}", off.verification);
    let met = in_lane(&on.items).expect("the route flown as given meets the lane");
    assert!((15.0..19.5).contains(&met), "met at {met} s");
    assert_eq!(on.verification.near_peak_risk, 0.5);
    assert!(!on.verification.is_clear(0.1));
    match on.verification.conflict {
        // To a step of the check (3 m at 20 m/s).
        Some(planner::Conflict::Risk { t_s, risk, .. }) => {
            assert!(
                (t_s - met).abs() < 0.2 && risk == 0.5,
                "{t_s} s, {risk}; met at {met} s"
            )
        }
        other => panic!("{other:?}"),
    }
    // Not faster than a 30 m/s aircraft: no lane.
    assert_eq!(
        plan(10.0, Strategy::None, 30.0).verification,
        plan(0.0, Strategy::None, 30.0).verification
    );
    // A stale track (last seen 45 s before, so not in the live map) has no lane, though
    // carried on at its velocity it would be on the route: a 25 m/s flyer along the
    // leg's line that would reach x = 100 m at 15 s, with the aircraft.
    let mut with_stale = p.clone();
    for k in 0..=25 {
        let t = -40.0 + 0.2 * f64::from(k);
        with_stale.observe(
            "old",
            Observation {
                t_s: t,
                p_m: [100.0 + 25.0 * (t - 15.0), 0.0],
                alt_m: 100.0,
                radius_m: 15.0,
            },
        );
    }
    let stale_plan = {
        let mut cfg = config();
        cfg.plan.chase_lane_s = 10.0;
        let r = Replan {
            strategy: Strategy::None,
            ..request(&m, &stack, 5)
        };
        replan(
            &r,
            Dynamic::Predictor(&with_stale),
            &cfg,
            &Termination::none(),
        )
        .expect("plan")
        .plan
    };
    assert_eq!(stale_plan.verification, on.verification);
    // Without lanes the plan keeps to the lane; with them it leaves it.
    let kept = plan(0.0, Strategy::Bisection, 20.0);
    assert!(in_lane(&kept.items).is_some(), "{:?}", kept.items);
    let left = plan(10.0, Strategy::Bisection, 20.0);
    assert_eq!(in_lane(&left.items), None, "{:?}", left.items);
    assert!(left.verification.is_clear(0.1), "{:?}", left.verification);
}
