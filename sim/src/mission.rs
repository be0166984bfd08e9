//! Mission geometry in the simulator's ENU frame: fly zone, waypoints, cylinders, and the
//! waypoint stack the aircraft flies (seed 002's "Pixhawk stack").
//!
//! # Units
//! ENU metres; altitudes in metres MSL (the simulator's ground is at 0 m MSL).

use serde::{Deserialize, Serialize};

use crate::geometry::{P2, dist, xy};

/// A stationary obstacle: a cylinder from the ground up to `top_m` (MSL).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Cylinder {
    /// Centre, ENU metres.
    pub center_m: P2,
    /// Radius, metres.
    pub radius_m: f64,
    /// Top, metres MSL. The cylinder matters only at or below this altitude.
    pub top_m: f64,
}

/// A mission as planner-like ENU geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mission {
    /// Fly-zone boundary (open ring), ENU metres.
    pub fly_zone_m: Vec<P2>,
    /// Lowest allowed altitude, metres MSL.
    pub alt_min_m: f64,
    /// Highest allowed altitude, metres MSL.
    pub alt_max_m: f64,
    /// Where the aircraft starts (take-off / hand-over point), ENU metres and MSL.
    pub start_m: [f64; 3],
    /// Ordered mission waypoints, ENU metres and MSL.
    pub waypoints_m: Vec<[f64; 3]>,
    /// Stationary obstacles.
    pub cylinders: Vec<Cylinder>,
}

impl Mission {
    /// From the planner's mission geometry (the first fly zone is used), starting at
    /// `start_m` (e.g. the home position at the first waypoint's altitude).
    pub fn from_planner(m: &planner::Mission, start_m: [f64; 3]) -> Self {
        let zone = m.fly_zones.first();
        Self {
            fly_zone_m: zone.map(|z| z.boundary_m.clone()).unwrap_or_default(),
            alt_min_m: zone.map_or(0.0, |z| z.alt_min_m),
            alt_max_m: zone.map_or(f64::INFINITY, |z| z.alt_max_m),
            start_m,
            waypoints_m: m
                .waypoints
                .iter()
                .map(|w| [w.p_m[0], w.p_m[1], w.alt_m])
                .collect(),
            cylinders: m
                .cylinders
                .iter()
                .map(|c| Cylinder {
                    center_m: c.center_m,
                    radius_m: c.radius_m,
                    top_m: c.top_m,
                })
                .collect(),
        }
    }

    /// Length of the straight mission legs: start -> wp0 -> wp1 -> ... (horizontal metres).
    pub fn straight_length_m(&self) -> f64 {
        let mut prev = xy(self.start_m);
        let mut total = 0.0;
        for w in &self.waypoints_m {
            total += dist(prev, xy(*w));
            prev = xy(*w);
        }
        total
    }

    /// The stack of the mission's own waypoints, flying toward the first.
    pub fn initial_stack(&self) -> Stack {
        Stack {
            items: self
                .waypoints_m
                .iter()
                .enumerate()
                .map(|(i, p)| StackItem {
                    p_m: *p,
                    kind: ItemKind::Mission(i),
                })
                .collect(),
            current: 0,
        }
    }

    /// Axis-aligned bounds of the fly zone: `(min, max)`.
    pub fn bounds_m(&self) -> (P2, P2) {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let pts = self
            .fly_zone_m
            .iter()
            .copied()
            .chain(self.waypoints_m.iter().map(|w| xy(*w)));
        for p in pts {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }
}

/// What a stack item is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ItemKind {
    /// The mission's waypoint with this index.
    Mission(usize),
    /// A waypoint inserted by an avoidance strategy.
    Avoid,
}

/// One waypoint of the stack.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StackItem {
    /// Position, ENU metres and MSL.
    pub p_m: [f64; 3],
    /// Mission waypoint or inserted avoidance point.
    pub kind: ItemKind,
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
        self.items[self.current.min(self.items.len())..]
            .iter()
            .find_map(|it| match it.kind {
                ItemKind::Mission(i) => Some(i),
                ItemKind::Avoid => None,
            })
    }

    /// Items from `current` on.
    pub fn remaining(&self) -> &[StackItem] {
        &self.items[self.current.min(self.items.len())..]
    }
}
