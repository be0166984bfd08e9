//! Detour candidates: the safety net when the Monte Carlo bisection's best route is not
//! verified clear (issue 10, "a manoeuvre library as a safety net"; beyond seed 002).
//!
//! The bisection searches the perpendicular bisector of each leg, which cannot express
//! every escape: turning away early and letting a crossing obstacle pass (a delay), or a
//! wide swing around a slow one. This module proposes, for the stretch from the aircraft to
//! the first fixed item (mission or search waypoint) after the first conflict, routes
//! through one or two avoid points on a polar lattice around the aircraft (ranges from a few
//! turn radii out to most of the horizon's reach, bearings every 20 degrees up to 160
//! degrees either side of the direction to that item), each joined to its neighbours with
//! the static pre-pass around cylinders. The caller verifies every candidate
//! ([`crate::verify`]) and keeps the best, so a candidate only has to be plausible.
//!
//! Deterministic: the lattice is fixed; no random draw.
//!
//! # Units
//! ENU metres, metres MSL.

use crate::geometry::{Point, add, dist, scale, sub};
use crate::mission::{Cylinder, Zones};
use crate::prepass::{PrepassParams, prepass_leg};
use crate::stack::StackItem;

/// Lattice parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetourParams {
    /// Ranges of the avoid points from the aircraft, in units of the turn radius (each at
    /// least 60 m). Default `[3, 5, 8, 12, 18]`.
    pub ranges_r: [f64; 5],
    /// Bearing step, degrees. Default 20.
    pub bearing_step_deg: f64,
    /// Largest bearing either side of the direction to the target, degrees. Default 160.
    pub max_bearing_deg: f64,
}

impl Default for DetourParams {
    fn default() -> Self {
        Self {
            ranges_r: [3.0, 5.0, 8.0, 12.0, 18.0],
            bearing_step_deg: 20.0,
            max_bearing_deg: 160.0,
        }
    }
}

/// Candidate tails that replace the avoid items between the last fixed item before `target`
/// (or the aircraft, when there is none) and `target` (an index into `tail`, a fixed item)
/// by detours through one avoid point, or two (the second halfway between the first and the
/// target, pushed out to the same side). Every fixed item is kept: the items up to that
/// last fixed one and from `target` on are unchanged. `from` is the aircraft's position;
/// `alt_m` the altitude the detour is flown at.
#[allow(clippy::too_many_arguments)]
pub fn detour_candidates(
    from: Point,
    tail: &[StackItem],
    target: usize,
    alt_m: f64,
    turn_radius_m: f64,
    cylinders: &[Cylinder],
    zones: &Zones,
    prepass: &PrepassParams,
    params: &DetourParams,
) -> Vec<Vec<StackItem>> {
    let Some(goal) = tail.get(target) else {
        return Vec::new();
    };
    // A mission or search waypoint before the target stays in the route: the detour starts
    // there, not at the aircraft.
    let start = tail[..target]
        .iter()
        .rposition(StackItem::is_fixed)
        .map_or(0, |i| i + 1);
    let (kept, from) = match start {
        0 => (&tail[..0], from),
        _ => (&tail[..start], tail[start - 1].p_m),
    };
    let to = sub(goal.p_m, from);
    let d_goal = dist(from, goal.p_m);
    if d_goal < 1e-6 {
        return Vec::new();
    }
    let base = to[1].atan2(to[0]);
    let join = |a: Point, b: Point, out: &mut Vec<StackItem>| {
        let leg = prepass_leg(a, b, alt_m, cylinders, zones, prepass);
        out.extend(leg.inserted.iter().map(|&q| StackItem::avoid(q, alt_m)));
    };
    let mut out = Vec::new();
    let steps = (params.max_bearing_deg / params.bearing_step_deg).floor() as i32;
    for &k in &params.ranges_r {
        let range = (k * turn_radius_m).max(60.0);
        for j in -steps..=steps {
            if j == 0 {
                continue;
            }
            let b = base + (f64::from(j) * params.bearing_step_deg).to_radians();
            let w = add(from, scale([b.cos(), b.sin()], range));
            if !zones.contains(w)
                || cylinders
                    .iter()
                    .any(|c| c.matters_at(alt_m) && dist(c.center_m, w) < c.radius_m * 1.2)
            {
                continue;
            }
            // One point.
            let mut one = kept.to_vec();
            join(from, w, &mut one);
            one.push(StackItem::avoid(w, alt_m));
            join(w, goal.p_m, &mut one);
            one.extend_from_slice(&tail[target..]);
            out.push(one);
            // Two points: the second halfway to the target, as far out as the first.
            let u = scale(to, 1.0 / d_goal);
            let rel = sub(w, from);
            let along = rel[0] * u[0] + rel[1] * u[1];
            let side = sub(rel, scale(u, along));
            let w2 = add(scale(add(w, goal.p_m), 0.5), side);
            if zones.contains(w2)
                && !cylinders
                    .iter()
                    .any(|c| c.matters_at(alt_m) && dist(c.center_m, w2) < c.radius_m * 1.2)
            {
                let mut two = kept.to_vec();
                join(from, w, &mut two);
                two.push(StackItem::avoid(w, alt_m));
                join(w, w2, &mut two);
                two.push(StackItem::avoid(w2, alt_m));
                join(w2, goal.p_m, &mut two);
                two.extend_from_slice(&tail[target..]);
                out.push(two);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Candidates from the origin at 100 m, turn radius 40 m, no cylinder, default lattice.
    fn candidates(zones: &Zones, tail: &[StackItem], target: usize) -> Vec<Vec<StackItem>> {
        detour_candidates(
            [0.0, 0.0],
            tail,
            target,
            100.0,
            40.0,
            &[],
            zones,
            &PrepassParams::default(),
            &DetourParams::default(),
        )
    }

    /// The fly zone `[x0, x1] x [y0, y1]`, metres.
    fn rectangle(x0: f64, y0: f64, x1: f64, y1: f64) -> Zones {
        Zones::single(&[[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    }

    /// Mission waypoints 0 and 1 due north at `y0` and `y1` metres, 100 m up.
    fn north(y0: f64, y1: f64) -> Vec<StackItem> {
        vec![
            StackItem::mission(0, [0.0, y0], 100.0),
            StackItem::mission(1, [0.0, y1], 100.0),
        ]
    }

    #[test]
    fn candidates_keep_the_fixed_items_and_stay_in_the_zone() {
        let zones = rectangle(-500.0, -500.0, 500.0, 2000.0);
        let tail = north(1000.0, 1500.0);
        let c = candidates(&zones, &tail, 0);
        assert!(c.len() > 20, "{}", c.len());
        for cand in &c {
            assert!(cand.ends_with(&tail));
            assert!(cand.iter().all(|it| zones.contains(it.p_m)));
        }
    }

    #[test]
    fn a_target_after_a_waypoint_keeps_the_waypoint_and_detours_from_it() {
        // The conflict is on the leg from waypoint 0 to waypoint 1 (the target): waypoint 0
        // must stay, and the detour points lie between it and the target.
        let zones = rectangle(-2000.0, -500.0, 2000.0, 3000.0);
        let tail = north(1000.0, 2000.0);
        let c = candidates(&zones, &tail, 1);
        assert!(!c.is_empty());
        for cand in &c {
            assert_eq!(cand.first(), Some(&tail[0]), "{cand:?}");
            assert!(cand.ends_with(&tail[1..]));
            let fixed: Vec<_> = cand.iter().filter(|it| it.is_fixed()).collect();
            assert_eq!(fixed, vec![&tail[0], &tail[1]]);
        }
    }
}
