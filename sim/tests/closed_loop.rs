//! Closed-loop behaviour of the simulator as a whole.

use sim::run::{RunConfig, run};
use sim::scenario::{Family, ScenarioParams, generate};
use sim::strategy::StrategyKind;

fn strip_latency(mut r: sim::run::RunResult) -> sim::run::RunResult {
    r.latencies_ms.clear();
    r.live_ms.clear();
    r.cpu_ms.clear();
    r.metrics.live_p95_ms = 0.0;
    r.metrics.replan_cpu_p95_ms = 0.0;
    r.metrics.replan_cpu_max_ms = 0.0;
    r.metrics.replan_p50_ms = 0.0;
    r.metrics.replan_p95_ms = 0.0;
    r.metrics.replan_max_ms = 0.0;
    r
}

#[test]
fn the_same_seed_reproduces_a_run_exactly() {
    let p = ScenarioParams::default();
    for k in [
        StrategyKind::None,
        StrategyKind::ConstantVelocity,
        StrategyKind::BisectionAuto,
    ] {
        let a = run(&generate(Family::Mixed, 11, &p), k, &RunConfig::default());
        // The Monte Carlo strategy times its live-state update (predictor and map, the
        // server's per-batch work) apart from the plan, once per replan; the others have
        // no live state.
        if k == StrategyKind::BisectionAuto {
            assert_eq!(a.live_ms.len(), a.latencies_ms.len());
            assert_eq!(a.latencies_ms.len(), a.metrics.replans);
            assert!(a.metrics.live_p95_ms > 0.0, "{:?}", a.metrics);
        } else {
            assert!(a.live_ms.is_empty(), "{}", k.name());
        }
        let a = strip_latency(a);
        let b = strip_latency(run(
            &generate(Family::Mixed, 11, &p),
            k,
            &RunConfig::default(),
        ));
        assert_eq!(a, b, "{}", k.name());
        assert!(!a.track.is_empty());
    }
}

#[test]
fn an_unobstructed_mission_is_flown_and_every_waypoint_captured() {
    // static family, cylinders removed: nothing to hit, every waypoint within 100 ft
    let mut s = generate(Family::Static, 3, &ScenarioParams::default());
    s.mission.cylinders.clear();
    let r = run(&s, StrategyKind::None, &RunConfig::default());
    assert!(r.metrics.completed);
    assert_eq!(r.metrics.waypoints_captured, r.metrics.waypoints);
    assert_eq!(r.metrics.sphere_score, 1.0);
    assert_eq!(r.metrics.cylinder_score, 1.0);
    // turns at the waypoints add a little to the straight legs, never less than them
    assert!(
        r.metrics.path_ratio >= 1.0 && r.metrics.path_ratio < 1.6,
        "{}",
        r.metrics.path_ratio
    );
}

#[test]
fn the_tangent_graph_hits_fewer_cylinders_than_flying_straight() {
    // Over 12 static scenarios: flying the legs straight hits cylinders that the tangent
    // graph goes around (it can still clip one when a waypoint turn overshoots).
    let p = ScenarioParams::default();
    let (mut none, mut tangent) = (0, 0);
    for seed in 0..12 {
        let s = generate(Family::Static, seed, &p);
        none += run(&s, StrategyKind::None, &RunConfig::default())
            .metrics
            .cylinders_hit;
        tangent += run(&s, StrategyKind::Tangent, &RunConfig::default())
            .metrics
            .cylinders_hit;
    }
    assert!(
        none > 0 && tangent * 2 < none,
        "none {none}, tangent {tangent}"
    );
}

#[test]
fn route_added_by_replans_counts_only_changes_of_the_way_to_the_next_waypoint() {
    // Flying the mission unchanged never replaces the stack: nothing added or removed.
    // The tangent graph replaces it once, at the start, with each leg on its shortest way
    // round the cylinders: never shorter than the straight first leg, longer where a
    // cylinder stands on it. A replanning strategy both lengthens and shortens its route.
    let p = ScenarioParams::default();
    let mut lengthened = 0;
    for seed in 0..12 {
        let s = generate(Family::Static, seed, &p);
        let none = run(&s, StrategyKind::None, &RunConfig::default()).metrics;
        assert_eq!((none.route_added_m, none.route_removed_m), (0.0, 0.0));
        let t = run(&s, StrategyKind::Tangent, &RunConfig::default()).metrics;
        assert!(t.route_removed_m < 1e-6, "seed {seed}: {t:?}");
        if t.route_added_m > 1.0 {
            lengthened += 1;
        }
    }
    assert!(lengthened > 0, "no first leg was routed round a cylinder");
    let s = generate(Family::Mixed, 4, &p);
    let r = run(&s, StrategyKind::BisectionAuto, &RunConfig::default()).metrics;
    assert!(r.route_added_m > 0.0 && r.route_removed_m > 0.0, "{r:?}");
}

#[test]
fn a_waypoint_the_autopilot_would_pass_too_wide_is_captured_with_a_straight_approach() {
    // A hairpin: W1 45-50 m to the side of W0 (a turn the 58 m radius cannot make), then
    // back. Flown as given, the autopilot switches past W1 at its finish line 40-60 m wide
    // of it; the planner sees that on its modelled flight (verify) and sets up a straight
    // approach. Judged by the simulator's own aircraft and scoring (100 ft, 3-D).
    let base = generate(Family::Static, 3, &ScenarioParams::default());
    for (dx, dy) in [(-20.0, 40.0), (0.0, 45.0), (10.0, 50.0)] {
        let mut s = base.clone();
        s.mission.cylinders.clear();
        s.spheres.clear();
        let w0 = s.mission.waypoints[0];
        let d = [w0.p_m[0] - s.start_m[0], w0.p_m[1] - s.start_m[1]];
        let n = d[0].hypot(d[1]);
        let (u, v) = ([d[0] / n, d[1] / n], [-d[1] / n, d[0] / n]);
        let mut w1 = w0;
        w1.p_m = [
            w0.p_m[0] + dx * u[0] + dy * v[0],
            w0.p_m[1] + dx * u[1] + dy * v[1],
        ];
        let mut w2 = w0;
        w2.p_m = [w1.p_m[0] - 300.0 * u[0], w1.p_m[1] - 300.0 * u[1]];
        s.mission.waypoints = vec![w0, w1, w2];
        let flown = run(&s, StrategyKind::None, &RunConfig::default()).metrics;
        assert_eq!(
            flown.waypoints_captured, 2,
            "({dx}, {dy}): the hairpin is missed as given"
        );
        let planned = run(&s, StrategyKind::BisectionAuto, &RunConfig::default()).metrics;
        assert_eq!(planned.waypoints_captured, 3, "({dx}, {dy}): {planned:?}");
        assert!(planned.completed);
    }
}

/// `mc-auto` in closed loop on `family` seed `seed`: the run completes, every waypoint
/// is captured, nothing is hit.
fn flies_every_waypoint_clear(family: Family, seed: u64) {
    let s = generate(family, seed, &ScenarioParams::default());
    let r = run(&s, StrategyKind::BisectionAuto, &RunConfig::default()).metrics;
    assert!(r.completed, "{r:?}");
    assert_eq!(r.waypoints_captured, r.waypoints, "{r:?}");
    assert_eq!((r.spheres_hit, r.cylinders_hit), (0, 0), "{r:?}");
}

#[test]
fn an_overdue_waypoint_is_not_put_off_past_the_horizon_until_the_scenario_ends() {
    // `mixed` seed 147: with the delay credit spent, every plan was `exact` or ranked by
    // a risk that stopped at the 60 s horizon, and a route that looped away first reached
    // the waypoint's crowded neighbourhood after it, where nothing was read: the loop won
    // at every replan and the scenario ended with 4 of 6 waypoints (commit c7973c4). Read
    // past the horizon for an overdue waypoint (planner::verify::VerifyParams::
    // read_past_horizon), it flies all 6 in 383 s. Since 2026-12-06 the far limit is 1
    // (VerifyParams::far_risk), so risk read past the horizon only ranks unclear routes
    // and no longer makes one unclear; the seed flies all 6 in 274.8 s (288.1 s at 0.5).
    flies_every_waypoint_clear(Family::Mixed, 147);
}

#[test]
fn a_waypoint_in_a_slow_spheres_neighbourhood_is_not_put_off_until_the_scenario_ends() {
    // `mixed` seed 21: a slow sphere keeps the first waypoint's neighbourhood at far risk
    // 0.2-0.4. Graded on each route's own clock, a detour that reached it later read that
    // risk against a looser limit; every replan put it off again, and for 370 s the
    // aircraft flew 3-4 km detours round it: 2 of 5 waypoints when the scenario ended.
    // The delay credit (planner::verify::VerifyParams::delay_credit_s) runs out after 60 s
    // of putting the waypoint off.
    // Since 06982f4 the same seed ends with 3 of 5 again (no hit), for another reason: the
    // turner's spurious laps (a circle matched for 10 s, 25 m off at +10 s inside a 14 m
    // disc) are refused, and manoeuvre replay's honest spread keeps the neighbourhood at
    // risk (the test was ignored for it). With each leg reading the map for its own
    // altitudes (planner::cost::leg_bands) it flies all 5 again, in 360 s (waypoint 1, at
    // 130 m, reached by 246 s where it took 300; the mission's waypoints lie between 70 and
    // 130 m, its spheres at their altitudes).
    flies_every_waypoint_clear(Family::Mixed, 21);
}

#[test]
fn the_plans_model_flies_the_autopilots_own_l1_distance_when_the_aircraft_banks_hard() {
    // Issue 10's bank at 14 m/s: a 21 m turn radius, but ArduPlane's L1 distance (period
    // 17 s, damping 0.75) is 57 m whatever the radius, so the simulated autopilot swings
    // wide of a right-angle corner. A small cylinder is put where its flight overshoots
    // the corner most, clear of the legs; the verifier must find it on its modelled L1
    // flight (Webster Field at 14 m/s, spline seed 82: a cylinder clipped 0.5 m deep when
    // the model's L1 was capped at twice the turn radius, 42 m, and overshot 8 m less).
    // An autopilot with a longer period (25 s: L1 84 m) overshoots further still: told
    // the period (`aircraft.l1_period_s`), the verifier finds that cylinder too; not
    // told, it flies the default 17 s and passes it.
    use planner::cost::{ALL_ALTITUDES, LegEnv};
    use planner::mission::Zones;
    use planner::verify::l1_seconds;
    use sim::aircraft::{AircraftParams, Autopilot};
    use sim::mission::{Stack, StackItem};

    let items = vec![
        StackItem::mission(0, [0.0, 300.0], 100.0),
        StackItem::mission(1, [300.0, 300.0], 100.0),
    ];
    // The cylinder at the widest point of the simulated autopilot's flight, and the
    // verification of the legs with `l1_s`.
    let check = |period_s: f64, l1_s: f64| {
        let params = AircraftParams::default()
            .speed_mps(14.0)
            .max_bank_deg(43.3)
            .l1_period_s(period_s);
        let radius_m = params.min_turn_radius_m();
        assert!((radius_m - 21.2).abs() < 0.1, "{radius_m}");
        assert!(params.l1_distance_m() > 2.0 * radius_m + 10.0);
        let mut ap = Autopilot::new(params, [0.0, 0.0, 100.0], [0.0, 1.0]);
        let start = ap.state.planner_state();
        let mut stack = Stack {
            items: items.clone(),
            current: 0,
        };
        let mut widest = [0.0, f64::NEG_INFINITY];
        while stack.current < 2 && ap.state.t_s < 120.0 {
            ap.step(&mut stack, 0.1);
            if stack.current == 1 && ap.state.p_m[1] > widest[1] {
                widest = [ap.state.p_m[0], ap.state.p_m[1]];
            }
        }
        assert_eq!(stack.current, 2, "the autopilot flies both legs");
        assert!(
            widest[1] > 315.0,
            "the overshoot north of the leg: {widest:?}"
        );
        let cylinders = [planner::Cylinder {
            center_m: [widest[0], widest[1] + 2.0],
            radius_m: 3.0,
            top_m: 500.0,
        }];
        let zones = Zones::default();
        let env_at = |alt_m| LegEnv {
            risk: &predictor::NoRisk,
            zones: &zones,
            cylinders: &cylinders,
            alt_m,
            band_m: ALL_ALTITUDES,
            band_hint: predictor::NO_BAND_HINT,
            buffer_fraction: 0.0,
            speed_mps: 14.0,
            horizon_end_s: 60.0,
        };
        let verify = planner::VerifyParams {
            l1_s,
            ..planner::VerifyParams::default()
        };
        let v = planner::verify_route(&env_at, &start, &items, 14.0, radius_m, 0.1, &verify);
        assert_eq!(v.polyline_cylinder_hits, 0, "the legs pass it: {v:?}");
        v
    };
    // ArduPlane's default period, the model's default.
    let v = check(17.0, planner::VerifyParams::default().l1_s);
    assert!(v.cylinder_hits >= 1, "the modelled flight enters it: {v:?}");
    assert!(!v.is_clear(0.1), "{v:?}");
    // A 25 s period, told.
    let v = check(25.0, l1_seconds(25.0));
    assert!(v.cylinder_hits >= 1, "told the period: {v:?}");
    // Not told: the default model turns inside the longer period's overshoot.
    let v = check(25.0, planner::VerifyParams::default().l1_s);
    assert_eq!(v.cylinder_hits, 0, "the default period passes it: {v:?}");
}
