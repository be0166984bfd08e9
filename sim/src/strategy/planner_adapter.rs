//! Conversions between the simulator's mission/stack types and the planner's.

use crate::aircraft::{AircraftParams, AircraftState};
use crate::mission::{ItemKind, Mission, Stack, StackItem};

/// The planner's view of a mission.
pub fn to_planner_mission(m: &Mission) -> planner::Mission {
    planner::Mission {
        fly_zones: vec![planner::FlyZone {
            boundary_m: m.fly_zone_m.clone(),
            alt_min_m: m.alt_min_m,
            alt_max_m: m.alt_max_m,
        }],
        cylinders: m
            .cylinders
            .iter()
            .map(|c| planner::Cylinder {
                center_m: c.center_m,
                radius_m: c.radius_m,
                top_m: c.top_m,
            })
            .collect(),
        waypoints: m
            .waypoints_m
            .iter()
            .map(|w| planner::Waypoint {
                p_m: [w[0], w[1]],
                alt_m: w[2],
            })
            .collect(),
    }
}

/// The planner's aircraft.
pub fn to_planner_aircraft(a: &AircraftParams) -> planner::Aircraft {
    planner::Aircraft {
        speed_mps: a.speed_mps,
        turn_radius_m: a.min_turn_radius_m(),
    }
}

/// The planner's stack items.
pub fn to_planner_stack(s: &Stack) -> Vec<planner::StackItem> {
    s.items
        .iter()
        .map(|it| match it.kind {
            ItemKind::Mission(i) => {
                planner::StackItem::mission(i, [it.p_m[0], it.p_m[1]], it.p_m[2])
            }
            ItemKind::Avoid => planner::StackItem::avoid([it.p_m[0], it.p_m[1]], it.p_m[2]),
        })
        .collect()
}

/// Back from the planner's stack items (search items become avoid items: the simulator has no
/// search pattern).
pub fn from_planner_stack(items: &[planner::StackItem], current: usize) -> Stack {
    Stack {
        items: items
            .iter()
            .map(|it| StackItem {
                p_m: [it.p_m[0], it.p_m[1], it.alt_m],
                kind: match (it.kind, it.mission_index) {
                    (planner::ItemKind::Mission, Some(i)) => ItemKind::Mission(i),
                    _ => ItemKind::Avoid,
                },
            })
            .collect(),
        current,
    }
}

/// The planner's aircraft state (compass heading, clockwise from north).
pub fn to_planner_state(s: &AircraftState) -> planner::AircraftState {
    planner::AircraftState {
        p_m: [s.p_m[0], s.p_m[1]],
        alt_m: s.p_m[2],
        heading_rad: std::f64::consts::FRAC_PI_2 - s.heading_rad,
        speed_mps: s.speed_mps,
        t_s: s.t_s,
    }
}
