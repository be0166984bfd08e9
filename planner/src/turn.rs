//! Turn-radius feasibility of a polyline for a fixed-wing aircraft (DESIGN.md "Planner",
//! step 5: "check every turn against the turn radius").
//!
//! The aircraft cuts each corner with a circular fillet of radius `R`. A turn by angle
//! `theta` at a vertex needs a tangent length `R * tan(theta / 2)` along both adjacent
//! legs; the path is flyable when, on every leg, the tangent lengths needed at its two
//! ends fit in the leg's length. A vertex is flagged when its tangent exceeds its share of
//! an adjacent leg: half the leg, or the whole leg when the other end does not turn (so no
//! flag means flyable, and a flag names the vertex to fix). A turn of (nearly) 180 degrees
//! is never feasible. At the
//! start, the aircraft flies with a known heading: the first waypoint must lie outside
//! both turning circles of radius `R` tangent to that heading.
//!
//! # Units
//! Metres and radians; `heading_rad` is a compass heading (clockwise from north, 0 =
//! north), i.e. the direction `[sin h, cos h]` in ENU.

use crate::geometry::{Point, add, dist, perp, scale, turn_angle_rad};
use crate::stack::StackItem;

/// A vertex whose turn cannot be flown at the given radius.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TurnViolation {
    /// Index of the vertex in the polyline (0 = the start, when a heading was given).
    pub index: usize,
    /// Turn angle at the vertex, radians.
    pub angle_rad: f64,
}

/// Tangent length a fillet of radius `r` needs for a turn of `angle_rad`.
#[inline]
pub fn fillet_tangent_m(angle_rad: f64, r: f64) -> f64 {
    if angle_rad >= std::f64::consts::PI - 1e-6 {
        return f64::INFINITY;
    }
    r * (angle_rad / 2.0).tan()
}

/// Whether a target point can be reached from `start` flying `heading_rad` without
/// turning tighter than `r`: it must lie outside both turning circles.
pub fn reachable_from_heading(start: Point, heading_rad: f64, target: Point, r: f64) -> bool {
    let dir = [heading_rad.sin(), heading_rad.cos()];
    let left = add(start, scale(perp(dir), r));
    let right = add(start, scale(perp(dir), -r));
    dist(left, target) >= r - 1e-9 && dist(right, target) >= r - 1e-9
}

/// Indices into `tail` of the avoid items whose turns cannot be flown at radius `r` on the
/// route from `from` (the aircraft) through `tail`, by [`turn_violations`] without a start
/// heading: the rule a plan's `turn_violations` reports by, and the one its candidates are
/// kept to.
pub fn sharp_avoid_items(from: Point, tail: &[StackItem], r: f64) -> Vec<usize> {
    let route: Vec<Point> = std::iter::once(from)
        .chain(tail.iter().map(|i| i.p_m))
        .collect();
    turn_violations(&route, r, None)
        .into_iter()
        .filter(|v| v.index >= 1 && !tail[v.index - 1].is_fixed())
        .map(|v| v.index - 1)
        .collect()
}

/// Vertices of `points` whose turns cannot be flown at turn radius `r`. With
/// `start_heading_rad`, vertex 0 is checked as the start (see the module docs).
pub fn turn_violations(
    points: &[Point],
    r: f64,
    start_heading_rad: Option<f64>,
) -> Vec<TurnViolation> {
    let n = points.len();
    let mut out = Vec::new();
    if n < 2 || r <= 0.0 {
        return out;
    }
    let mut tangent = vec![0.0; n];
    let mut angle = vec![0.0; n];
    for i in 1..n - 1 {
        angle[i] = turn_angle_rad(points[i - 1], points[i], points[i + 1]);
        tangent[i] = fillet_tangent_m(angle[i], r);
    }
    let mut bad = vec![false; n];
    if let Some(h) = start_heading_rad
        && !reachable_from_heading(points[0], h, points[1], r)
    {
        bad[0] = true;
    }
    // Each turn may use half of an adjacent leg, or all of it when the leg's other end
    // does not turn: a vertex within its share never conflicts with its neighbours, so a
    // flagged vertex is the one to fix (and a sharp fixed waypoint does not blame an
    // inserted neighbour that turns gently).
    for i in 1..n - 1 {
        for j in [i - 1, i + 1] {
            let len = dist(points[i], points[j]);
            let share = if tangent[j] > 0.0 { 0.5 * len } else { len };
            if tangent[i] > share + 1e-9 {
                bad[i] = true;
            }
        }
    }
    for i in 0..n {
        if bad[i] {
            out.push(TurnViolation {
                index: i,
                angle_rad: angle[i],
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn a_right_angle_needs_one_radius_each_way() {
        // 90 degrees: tangent = R tan(45) = R. Legs of 100 m, R = 40: 40 <= 100 fits.
        let pts = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0]];
        assert_relative_eq!(
            fillet_tangent_m(std::f64::consts::FRAC_PI_2, 40.0),
            40.0,
            epsilon = 1e-12
        );
        assert!(turn_violations(&pts, 40.0, None).is_empty());
        // R = 120 needs 120 m > 100 m on each leg: vertex 1 is infeasible.
        let v = turn_violations(&pts, 120.0, None);
        assert_eq!(v.len(), 1);
        assert_eq!(v[0].index, 1);
    }

    #[test]
    fn two_close_turns_share_a_leg() {
        // Zig-zag: 90-degree turns at (100,0) and (100,50): each needs 40 m on the 50 m
        // middle leg -> 80 > 50, both flagged.
        let pts = [[0.0, 0.0], [100.0, 0.0], [100.0, 50.0], [200.0, 50.0]];
        let v = turn_violations(&pts, 40.0, None);
        assert_eq!(v.iter().map(|t| t.index).collect::<Vec<_>>(), vec![1, 2]);
    }

    #[test]
    fn a_point_behind_a_slow_turn_is_unreachable_from_the_heading() {
        // Heading north (0 rad), R = 50: turning circles centred (+-50, 0). The point
        // (30, 10) is 20.6 m from (50, 0): inside the right circle.
        assert!(!reachable_from_heading([0.0, 0.0], 0.0, [30.0, 10.0], 50.0));
        assert!(reachable_from_heading([0.0, 0.0], 0.0, [0.0, 200.0], 50.0));
    }
}
