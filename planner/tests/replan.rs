//! The replanning seam: deterministic for a seed, and the simulator's path (a predictor
//! whose cached map is built by the seam) and the server's path (an already built map
//! from a snapshot) give the same plan for the same inputs.

mod common;

use planner::stack::mission_stack;
use planner::{
    Aircraft, AircraftState, Dynamic, Mission, Replan, ReplanConfig, Strategy, Termination, replan,
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
    Replan {
        mission: m,
        aircraft: Aircraft {
            speed_mps: 20.0,
            turn_radius_m: 40.0,
        },
        state: AircraftState {
            p_m: [0.0, 0.0],
            alt_m: 100.0,
            heading_rad: std::f64::consts::FRAC_PI_2,
            speed_mps: 20.0,
            t_s: 10.0,
        },
        stack,
        current_index: 1,
        strategy: Strategy::Bisection,
        seed,
    }
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
    assert_eq!(g.cell_m, 10.0);
    assert_eq!(g.horizon_s, 60.0);
}
