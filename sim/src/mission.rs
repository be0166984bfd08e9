//! The mission in the simulator is the planner's own [`planner::Mission`] (one domain model:
//! fly zones, waypoints, cylinders); this module adds what only the simulator needs around
//! it: the stack the simulated autopilot flies (seed 002's "Pixhawk stack", made of the
//! planner's [`StackItem`]s) and a few measurements of a mission.
//!
//! # Units
//! ENU metres; altitudes in metres MSL (the simulator's ground is at 0 m MSL).

use serde::{Deserialize, Serialize};

pub use planner::stack::{ItemKind, StackItem};
pub use planner::{Cylinder, FlyZone, Mission, Waypoint};

use crate::geometry::{P2, dist, xy};

/// Length of the straight mission legs: `start -> wp0 -> wp1 -> ...` (horizontal metres).
pub fn straight_length_m(m: &Mission, start_m: [f64; 3]) -> f64 {
    let mut prev = xy(start_m);
    let mut total = 0.0;
    for w in &m.waypoints {
        total += dist(prev, w.p_m);
        prev = w.p_m;
    }
    total
}

/// Path flown over the straight route from `start_m` through the waypoints
/// ([`straight_length_m`]): the judges' path ratio; 1 for a mission of no length.
pub fn path_ratio(m: &Mission, start_m: [f64; 3], path_m: f64) -> f64 {
    let straight = straight_length_m(m, start_m);
    if straight > 0.0 {
        path_m / straight
    } else {
        1.0
    }
}

/// The stack of the mission's own waypoints, flying toward the first.
pub fn initial_stack(m: &Mission) -> Stack {
    Stack {
        items: planner::stack::mission_stack(m),
        current: 0,
    }
}

/// The first fly zone's boundary (the simulator's missions have one), empty when unbounded.
pub fn fly_zone(m: &Mission) -> &[P2] {
    m.fly_zones.first().map_or(&[], |z| &z.boundary_m[..])
}

/// The first fly zone's altitude band `(min, max)`, metres MSL (unbounded without one).
pub fn altitude_band_m(m: &Mission) -> (f64, f64) {
    m.fly_zones
        .first()
        .map_or((f64::NEG_INFINITY, f64::INFINITY), |z| {
            (z.alt_min_m, z.alt_max_m)
        })
}

/// Axis-aligned bounds of the fly zone and the waypoints: `(min, max)`.
pub fn bounds_m(m: &Mission) -> (P2, P2) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let pts = fly_zone(m)
        .iter()
        .copied()
        .chain(m.waypoints.iter().map(|w| w.p_m));
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The waypoint stack the autopilot flies, with the index of the item it flies toward.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stack {
    /// All items, passed ones included (indices never shift before `current`).
    pub items: Vec<StackItem>,
    /// Index of the item being flown toward; `items.len()` when the stack is finished.
    pub current: usize,
}

impl Stack {
    /// The item being flown toward, if any.
    pub fn target(&self) -> Option<&StackItem> {
        self.items.get(self.current)
    }

    /// Index (in the mission) of the first mission waypoint at or after `current`.
    pub fn next_mission_index(&self) -> Option<usize> {
        self.remaining().iter().find_map(|it| it.mission_index)
    }

    /// Items from `current` on.
    pub fn remaining(&self) -> &[StackItem] {
        &self.items[self.current.min(self.items.len())..]
    }

    /// Horizontal length of the route from `from_m` through the remaining items to the next
    /// mission waypoint (included), metres, with that waypoint's mission index; `None` when
    /// no mission waypoint remains.
    pub fn route_to_next_waypoint_m(&self, from_m: P2) -> Option<(usize, f64)> {
        let mut at = from_m;
        let mut len = 0.0;
        for it in self.remaining() {
            len += dist(at, it.p_m);
            at = it.p_m;
            if let Some(i) = it.mission_index {
                return Some((i, len));
            }
        }
        None
    }
}

/// A 3-D point of a stack item: `[east_m, north_m, alt_msl_m]`.
pub fn item_point(it: &StackItem) -> [f64; 3] {
    [it.p_m[0], it.p_m[1], it.alt_m]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_route_to_the_next_waypoint_runs_through_the_avoid_items_before_it() {
        let stack = Stack {
            items: vec![
                StackItem::mission(0, [0.0, 0.0], 100.0),
                StackItem {
                    p_m: [30.0, 40.0],
                    alt_m: 100.0,
                    kind: ItemKind::Avoid,
                    mission_index: None,
                },
                StackItem::mission(1, [30.0, 100.0], 120.0),
                StackItem::mission(2, [500.0, 100.0], 120.0),
            ],
            current: 1,
        };
        // from (0, 0): 50 m to the avoid item, 60 m on to waypoint 1; waypoint 2 not counted
        let (i, len) = stack.route_to_next_waypoint_m([0.0, 0.0]).unwrap();
        assert_eq!(i, 1);
        assert!((len - 110.0).abs() < 1e-9, "{len}");
        let past = Stack {
            current: 3,
            ..stack.clone()
        };
        let (i, len) = past.route_to_next_waypoint_m([500.0, 0.0]).unwrap();
        assert_eq!((i, len), (2, 100.0));
        let done = Stack {
            current: 4,
            ..stack
        };
        assert_eq!(done.route_to_next_waypoint_m([0.0, 0.0]), None);
    }
}
