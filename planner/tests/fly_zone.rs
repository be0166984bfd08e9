//! The fly-zone boundary rule (issue 10) at the planner level: the judges' missions put
//! waypoints exactly on fly-zone vertices, and a leg that touches the boundary at a vertex or
//! runs along an edge is inside the zone, so such a mission plans normally.

use planner::mission::Zones;
use planner::stack::mission_stack;
use planner::{
    Aircraft, AircraftState, Cylinder, FlyZone, Mission, PlanOutcome, PlanParams, PlanRequest,
    Waypoint, plan,
};
use predictor::NoRisk;

/// An L-shaped zone (the square [0, 2000]^2 without its north-east quarter): reflex vertex
/// at (1000, 1000).
fn l_zone() -> FlyZone {
    FlyZone {
        boundary_m: vec![
            [0.0, 0.0],
            [2000.0, 0.0],
            [2000.0, 1000.0],
            [1000.0, 1000.0],
            [1000.0, 2000.0],
            [0.0, 2000.0],
        ],
        alt_min_m: 30.0,
        alt_max_m: 300.0,
    }
}

/// Waypoints on the reflex vertex, on a convex vertex, then along the east edge to the
/// south-east vertex, then diagonally back through the reflex vertex into the other arm.
fn waypoints_on_the_boundary() -> Vec<Waypoint> {
    [
        [1000.0, 1000.0],
        [1500.0, 500.0],
        [2000.0, 1000.0],
        [2000.0, 0.0],
        [500.0, 1500.0],
    ]
    .into_iter()
    .map(|p_m| Waypoint { p_m, alt_m: 100.0 })
    .collect()
}

fn plan_from(mission: &Mission, start: [f64; 2]) -> planner::Plan {
    let stack = mission_stack(mission);
    let req = PlanRequest {
        mission,
        aircraft: Aircraft {
            speed_mps: 20.0,
            turn_radius_m: 40.0,
        },
        stack: &stack,
        current_index: 0,
        state: AircraftState {
            p_m: start,
            alt_m: 100.0,
            heading_rad: 0.0,
            speed_mps: 20.0,
            t_s: 0.0,
        },
        params: PlanParams::default(),
        seed: 1,
    };
    plan(&req, &NoRisk).unwrap()
}

#[test]
fn the_boundary_legs_are_inside_the_zone() {
    let zones = Zones::new(&[l_zone()]);
    let w: Vec<[f64; 2]> = waypoints_on_the_boundary().iter().map(|w| w.p_m).collect();
    for p in &w {
        assert!(zones.contains(*p), "{p:?}");
    }
    for leg in w.windows(2) {
        assert!(zones.contains_segment(leg[0], leg[1]), "{leg:?}");
    }
    // The chord across the missing quarter, between two boundary points, is not.
    assert!(!zones.contains_segment([2000.0, 1000.0], [1000.0, 2000.0]));
}

#[test]
fn a_mission_with_waypoints_on_fly_zone_vertices_plans_normally() {
    let mission = Mission {
        fly_zones: vec![l_zone()],
        cylinders: vec![],
        waypoints: waypoints_on_the_boundary(),
    };
    let p = plan_from(&mission, [500.0, 500.0]);
    assert_eq!(p.outcome, PlanOutcome::Exact, "{p:?}");
    // No hard violation (the risk would be 1) and nothing to avoid: the stack is flown as is.
    assert_eq!(p.risk, 0.0);
    assert_eq!(p.base_risk, 0.0);
    assert_eq!(p.added, 0);
    assert_eq!(p.diff.first_changed, None);
}

#[test]
fn a_cylinder_next_to_a_vertex_waypoint_is_still_avoided_inside_the_zone() {
    // A cylinder on the leg from the reflex vertex to (1500, 500): the detour must stay in
    // the zone, and the vertex waypoint itself is no violation.
    let mission = Mission {
        fly_zones: vec![l_zone()],
        cylinders: vec![Cylinder {
            center_m: [1250.0, 750.0],
            radius_m: 60.0,
            top_m: 200.0,
        }],
        waypoints: waypoints_on_the_boundary(),
    };
    let p = plan_from(&mission, [500.0, 500.0]);
    assert_eq!(p.outcome, PlanOutcome::Exact, "{p:?}");
    assert_eq!(p.risk, 0.0);
    assert!(p.added >= 1);
    let zones = Zones::new(&mission.fly_zones);
    let route: Vec<[f64; 2]> = std::iter::once([500.0, 500.0])
        .chain(p.items.iter().map(|i| i.p_m))
        .collect();
    for leg in route.windows(2) {
        assert!(zones.contains_segment(leg[0], leg[1]), "{leg:?}");
    }
}
