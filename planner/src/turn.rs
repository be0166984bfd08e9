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

/// Centres of the two circles of radius `r` an aircraft at `start` flying `heading_rad`
/// turns on: `[left, right]`.
fn turning_centres(start: Point, heading_rad: f64, r: f64) -> [Point; 2] {
    let left = perp([heading_rad.sin(), heading_rad.cos()]);
    [add(start, scale(left, r)), add(start, scale(left, -r))]
}

/// Whether a target point can be reached from `start` flying `heading_rad` without
/// turning tighter than `r`: it must lie outside both turning circles.
pub fn reachable_from_heading(start: Point, heading_rad: f64, target: Point, r: f64) -> bool {
    turning_centres(start, heading_rad, r)
        .iter()
        .all(|&c| dist(c, target) >= r - 1e-9)
}

/// Metres an aircraft at `start` with compass heading `heading_rad` flies beyond the
/// straight line to `target` when it first turns at radius `r` toward it and then flies
/// straight (the shorter of the two circle-then-straight paths, left or right, that reach
/// it): `0` for a target dead ahead, about `r * (phi - sin phi)` for one far off at
/// `phi` radians off the heading, `pi * r` for one far behind. A route's polyline starts at
/// the aircraft's position whatever its heading; this is what that leaves out (the route
/// ranking adds it with [`crate::verify::VerifyParams::turn_in_weight`] above 0, off by
/// default: [`crate::verify::Verification::turn_in_m`]). `0` when `r` is not positive.
pub fn turn_in_m(start: Point, heading_rad: f64, target: Point, r: f64) -> f64 {
    let d = dist(start, target);
    if r <= 0.0 || d < 1e-9 {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    // side +1: the left circle, flown counter-clockwise; -1: the right one, clockwise. A
    // target inside one circle is reached round the other (it cannot be inside both).
    for (c, side) in turning_centres(start, heading_rad, r)
        .into_iter()
        .zip([1.0, -1.0])
    {
        let dc = dist(c, target);
        if dc < r {
            continue;
        }
        let tangent = (dc * dc - r * r).max(0.0).sqrt();
        let a0 = (start[1] - c[1]).atan2(start[0] - c[0]);
        let g = (target[1] - c[1]).atan2(target[0] - c[0]);
        // Where the straight leaves the circle, as an angle round the centre.
        let b = g - side * (r / dc).min(1.0).acos();
        let swept = (side * (b - a0)).rem_euclid(std::f64::consts::TAU);
        // A sweep within a hair of a whole circle is no sweep (rounding dead ahead).
        let swept = if swept > std::f64::consts::TAU - 1e-9 {
            0.0
        } else {
            swept
        };
        best = best.min(r * swept + tangent);
    }
    if best.is_finite() {
        (best - d).max(0.0)
    } else {
        0.0
    }
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

    /// Metres a pursuit at the turn rate `v / r` (turn toward the target as hard as
    /// allowed, then straight at it) flies from `start` on `heading_rad` until within
    /// 0.05 m of `target`: an independent reading of the turn onto a first leg.
    fn pursuit_m(start: Point, heading_rad: f64, target: Point, r: f64) -> f64 {
        let (v, dt) = (20.0, 0.0005);
        let (mut p, mut th) = (start, std::f64::consts::FRAC_PI_2 - heading_rad);
        let mut flown = 0.0;
        while dist(p, target) > 0.05 {
            let want = (target[1] - p[1]).atan2(target[0] - p[0]);
            let err = (want - th + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            th += err.clamp(-v / r * dt, v / r * dt);
            p = add(p, [v * dt * th.cos(), v * dt * th.sin()]);
            flown += v * dt;
            assert!(flown < 1e5, "the pursuit never got there");
        }
        flown
    }

    #[test]
    fn the_turn_onto_a_first_leg_is_what_a_hard_turn_then_straight_flies_beyond_the_leg() {
        let r = 35.0;
        let start = [10.0, -20.0];
        for heading_deg in [0.0f64, 37.0, 200.0] {
            let h = heading_deg.to_radians();
            // Bearings off the heading, either side (short of dead astern, where the
            // pursuit's side is a coin toss), at 3 to 20 turn radii.
            for off_deg in [0.0f64, 20.0, -45.0, 90.0, -120.0, 170.0] {
                for k in [3.0, 8.0, 20.0] {
                    let b = h + off_deg.to_radians();
                    let target = add(start, [k * r * b.sin(), k * r * b.cos()]);
                    let extra = turn_in_m(start, h, target, r);
                    let flown = pursuit_m(start, h, target, r);
                    assert!(
                        (dist(start, target) + extra - flown).abs() < 0.3,
                        "heading {heading_deg} off {off_deg} at {k} r: {extra} extra, \
                         flown {flown} for {}",
                        dist(start, target)
                    );
                }
            }
        }
        // Dead ahead nothing; far behind half a circle; far off at phi about r (phi - sin
        // phi); no radius, nothing.
        assert!(turn_in_m(start, 0.0, [10.0, 500.0], r) < 1e-6);
        let behind = turn_in_m(start, 0.0, [10.0, -20.0 - 50.0 * r], r);
        assert!(
            (behind - std::f64::consts::PI * r).abs() < 0.05 * r,
            "{behind}"
        );
        let phi = std::f64::consts::FRAC_PI_2;
        let abeam = turn_in_m(start, 0.0, [10.0 + 100.0 * r, -20.0], r);
        assert!((abeam - r * (phi - phi.sin())).abs() < 0.02 * r, "{abeam}");
        assert_eq!(turn_in_m(start, 0.0, [10.0, -500.0], 0.0), 0.0);
    }

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
