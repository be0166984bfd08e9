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
use crate::turn::sharp_avoid_items;

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
    /// Radii of the hold circles ([`hold_candidates`]), in units of the turn radius.
    /// Default `[1.5, 2.5]`.
    pub hold_radii_r: [f64; 2],
    /// Avoid points per hold circle. Default 6 (a 60 degree turn at each).
    pub hold_points: usize,
    /// Turns of the escape manoeuvres ([`escape_candidates`]), degrees either side.
    /// Default 0, 30, ..., 180.
    pub escape_turns_deg: [f64; 7],
    /// Straight runs after the escape turn, metres. Default 60, 150, 300.
    pub escape_runs_m: [f64; 3],
    /// Lengths of the straight final approach of a re-approach
    /// ([`reapproach_candidates`]), in units of the turn radius. Default `[3, 5]`.
    pub reapproach_r: [f64; 2],
    /// Directions of the final approach tried, degrees apart (all round). Default 45.
    pub reapproach_step_deg: f64,
}

impl Default for DetourParams {
    fn default() -> Self {
        Self {
            ranges_r: [3.0, 5.0, 8.0, 12.0, 18.0],
            bearing_step_deg: 20.0,
            max_bearing_deg: 160.0,
            hold_radii_r: [1.5, 2.5],
            hold_points: 6,
            escape_turns_deg: [0.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0],
            escape_runs_m: [60.0, 150.0, 300.0],
            reapproach_r: [3.0, 5.0],
            reapproach_step_deg: 45.0,
        }
    }
}

/// Candidate tails that replace the avoid items between the last fixed item before `target`
/// (or the aircraft, when there is none) and `target` (an index into `tail`, a fixed item)
/// by detours through one avoid point, or two (the second halfway between the first and the
/// target, pushed out to the same side). Every fixed item is kept: the items up to that
/// last fixed one and from `target` on are unchanged. `from` is the aircraft's position;
/// `alt_m` the altitude cylinders are checked at (the lower of the aircraft's and the
/// target's). The avoid points are at the target's altitude, so an aircraft below it climbs
/// through the detour rather than arriving low (a detour at its own altitude left the
/// aircraft 30-60 m under a waypoint it then missed).
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
        out.extend(
            leg.inserted
                .iter()
                .map(|&q| StackItem::avoid(q, goal.alt_m)),
        );
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
            one.push(StackItem::avoid(w, goal.alt_m));
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
                two.push(StackItem::avoid(w, goal.alt_m));
                join(w, w2, &mut two);
                two.push(StackItem::avoid(w2, goal.alt_m));
                join(w2, goal.p_m, &mut two);
                two.extend_from_slice(&tail[target..]);
                out.push(two);
            }
        }
    }
    out
}

/// Hold patterns (a wait in space and time; beyond seed 002, whose bisection can only
/// bend a route, never delay it): one circle flown from the aircraft's position and
/// heading, turning left or right, of each radius in [`DetourParams::hold_radii_r`] turn
/// radii, through [`DetourParams::hold_points`] avoid points ending where it began, then
/// each of `tails` unchanged. A sphere crossing a corridor ahead (between a cylinder and
/// the fly zone's edge, say) passes while the aircraft circles. `heading_rad` is the
/// compass heading (clockwise from north). Circles that leave the fly zone or touch a
/// cylinder (grown by a fifth) at `alt_m` are not proposed. The caller verifies each one
/// on the time axis, so a hold wins only when it is clear and nothing shorter is.
#[allow(clippy::too_many_arguments)]
pub fn hold_candidates(
    from: Point,
    heading_rad: f64,
    tails: &[&[StackItem]],
    alt_m: f64,
    turn_radius_m: f64,
    cylinders: &[Cylinder],
    zones: &Zones,
    params: &DetourParams,
) -> Vec<Vec<StackItem>> {
    let n = params.hold_points.max(3);
    // ENU direction angle (counter-clockwise from east) of the compass heading.
    let th = std::f64::consts::FRAC_PI_2 - heading_rad;
    let step = std::f64::consts::TAU / n as f64;
    let mut out = Vec::new();
    for &k in &params.hold_radii_r {
        let r = k * turn_radius_m.max(1.0);
        for side in [1.0f64, -1.0] {
            // Left (side 1): the centre is to the left and the circle runs counter-clockwise.
            let c = add(from, scale([-th.sin() * side, th.cos() * side], r));
            let phi0 = th - side * std::f64::consts::FRAC_PI_2;
            let pts: Vec<Point> = (1..=n)
                .map(|i| {
                    if i == n {
                        return from;
                    }
                    let phi = phi0 + side * step * i as f64;
                    add(c, scale([phi.cos(), phi.sin()], r))
                })
                .collect();
            let mut ring = pts.clone();
            ring.insert(0, from);
            let clear = ring.windows(2).all(|w| zones.contains_segment(w[0], w[1]))
                && !cylinders.iter().any(|cy| {
                    cy.matters_at(alt_m)
                        && ring.windows(2).any(|w| {
                            crate::geometry::dist_point_segment(cy.center_m, w[0], w[1])
                                < cy.radius_m * 1.2
                        })
                });
            if !clear {
                continue;
            }
            for tail in tails {
                let mut cand: Vec<StackItem> =
                    pts.iter().map(|&q| StackItem::avoid(q, alt_m)).collect();
                cand.extend_from_slice(tail);
                out.push(cand);
            }
        }
    }
    out
}

/// Escape manoeuvres for danger (a conflict within the near window that no detour clears,
/// [`crate::PlanParams::danger_risk`]): from `from` at compass heading `heading_rad`, turn
/// at `turn_radius_m` by each of `turn_deg` to either side, then fly straight each of
/// `run_m`; one avoid point where that ends, then each of `tails`. A fixed wing pursuing
/// that point flies exactly the turn and the run. Unlike the lattice these may leave the
/// fly zone (the danger ranking puts a near-term collision above a boundary excursion);
/// a point inside a cylinder at `alt_m` is not proposed. Deterministic.
#[allow(clippy::too_many_arguments)]
pub fn escape_candidates(
    from: Point,
    heading_rad: f64,
    tails: &[&[StackItem]],
    alt_m: f64,
    turn_radius_m: f64,
    cylinders: &[Cylinder],
    turn_deg: &[f64],
    run_m: &[f64],
) -> Vec<Vec<StackItem>> {
    let th = std::f64::consts::FRAC_PI_2 - heading_rad;
    let r = turn_radius_m.max(1.0);
    let mut out = Vec::new();
    for &deg in turn_deg {
        for side in [1.0f64, -1.0] {
            if deg == 0.0 && side < 0.0 {
                continue;
            }
            let phi = side * deg.to_radians();
            // The arc's end: centre to the side, swept by phi.
            let c = add(from, scale([-th.sin() * side, th.cos() * side], r));
            let start = th - side * std::f64::consts::FRAC_PI_2;
            let a = start + phi;
            let arc_end = add(c, scale([a.cos(), a.sin()], r));
            let dir = th + phi;
            for &run in run_m {
                let q = add(arc_end, scale([dir.cos(), dir.sin()], run));
                if cylinders
                    .iter()
                    .any(|cy| cy.matters_at(alt_m) && dist(cy.center_m, q) < cy.radius_m)
                {
                    continue;
                }
                for tail in tails {
                    let mut cand = vec![StackItem::avoid(q, alt_m)];
                    cand.extend_from_slice(tail);
                    out.push(cand);
                }
            }
        }
    }
    out
}

/// Candidate tails that set up a straight final approach to the fixed item `target` (an
/// index into `tail`) that a flown path passed outside the capture distance: one avoid point
/// `L` before it (`L` each of [`DetourParams::reapproach_r`] turn radii) on approach
/// directions all round (every [`DetourParams::reapproach_step_deg`], starting with the
/// leg's own), inserted before `target`, and also replacing the avoid items between the
/// previous fixed item and `target`. A point outside the fly zone or inside a cylinder at
/// `alt_m` is not proposed. `from` is the aircraft's position.
///
/// Approaches whose turns can be flown at `turn_radius_m` as drawn (at the approach point
/// and at an avoid item just before it, by [`crate::turn::turn_violations`]) come alone
/// when there are any: a point too close behind the aircraft for the turn onto the
/// approach would leave the plan with an avoid item it reports as too sharp. When none
/// can (a waypoint a few tens of metres after the previous one, where every approach turns
/// back on itself), all are proposed, and the aircraft loops round the approach point: the
/// caller's flown check decides whether that captures the waypoint. Deterministic.
#[allow(clippy::too_many_arguments)]
pub fn reapproach_candidates(
    from: Point,
    tail: &[StackItem],
    target: usize,
    alt_m: f64,
    turn_radius_m: f64,
    cylinders: &[Cylinder],
    zones: &Zones,
    params: &DetourParams,
) -> Vec<Vec<StackItem>> {
    let Some(w) = tail.get(target) else {
        return vec![];
    };
    let prev = if target == 0 {
        from
    } else {
        tail[target - 1].p_m
    };
    let base = {
        let d = sub(w.p_m, prev);
        if d[0].hypot(d[1]) > 1e-6 {
            d[1].atan2(d[0])
        } else {
            0.0
        }
    };
    // The avoid items just before the target (after the previous fixed item).
    let first_avoid = tail[..target]
        .iter()
        .rposition(|i| i.is_fixed())
        .map_or(0, |k| k + 1);
    let step = params.reapproach_step_deg.max(1.0).to_radians();
    let n = (std::f64::consts::TAU / step).round().max(1.0) as usize;
    let (mut out, mut sharp) = (Vec::new(), Vec::new());
    for k in 0..n {
        let a = base + k as f64 * step;
        for &l in &params.reapproach_r {
            let q = sub(w.p_m, scale([a.cos(), a.sin()], l * turn_radius_m.max(1.0)));
            if !zones.contains(q)
                || cylinders
                    .iter()
                    .any(|cy| cy.matters_at(alt_m) && dist(cy.center_m, q) < cy.radius_m * 1.2)
            {
                continue;
            }
            let approach = StackItem::avoid(q, w.alt_m);
            let mut inserted = tail[..target].to_vec();
            inserted.push(approach);
            inserted.extend_from_slice(&tail[target..]);
            let mut keep = |cand: Vec<StackItem>, k: usize| {
                if turn_flyable(from, &cand, k, turn_radius_m) {
                    out.push(cand);
                } else {
                    sharp.push(cand);
                }
            };
            keep(inserted, target);
            if first_avoid < target {
                let mut replaced = tail[..first_avoid].to_vec();
                replaced.push(approach);
                replaced.extend_from_slice(&tail[target..]);
                keep(replaced, first_avoid);
            }
        }
    }
    if out.is_empty() { sharp } else { out }
}

/// Whether the turns at `cand[k]` (the approach point) and at an avoid item just before it,
/// whose turn the approach point changes, can be flown at radius `r` on the route from
/// `from` through `cand` ([`sharp_avoid_items`], the rule a plan's avoid items are reported
/// by): an approach point too close to the aircraft, or to a sharp neighbour, would leave
/// the plan with an avoid item it says cannot be flown.
fn turn_flyable(from: Point, cand: &[StackItem], k: usize, r: f64) -> bool {
    !sharp_avoid_items(from, cand, r)
        .iter()
        .any(|&i| i == k || i + 1 == k)
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
    fn detour_points_are_at_the_target_altitude_whatever_the_check_altitude() {
        // The aircraft at 60 m (the check altitude passed), the target at 120 m: the avoid
        // points carry 120 m, so the autopilot climbs through the detour.
        let zones = rectangle(-500.0, -500.0, 500.0, 2000.0);
        let tail = vec![StackItem::mission(0, [0.0, 1000.0], 120.0)];
        let c = detour_candidates(
            [0.0, 0.0],
            &tail,
            0,
            60.0,
            40.0,
            &[],
            &zones,
            &PrepassParams::default(),
            &DetourParams::default(),
        );
        assert!(!c.is_empty());
        for cand in &c {
            assert!(cand.iter().all(|it| it.alt_m == 120.0), "{cand:?}");
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

    #[test]
    fn a_hold_is_a_flyable_circle_from_the_aircraft_back_to_it_then_the_tail() {
        use crate::stack::ItemKind;
        use crate::turn::{reachable_from_heading, turn_violations};
        let zones = rectangle(-1000.0, -1000.0, 1000.0, 2000.0);
        let tail = north(1000.0, 1500.0);
        let r = 40.0;
        for heading in [0.0f64, 1.0, 2.5, -2.0] {
            let c = hold_candidates(
                [0.0, 0.0],
                heading,
                &[&tail],
                100.0,
                r,
                &[],
                &zones,
                &DetourParams::default(),
            );
            // Two radii, two sides.
            assert_eq!(c.len(), 4, "{heading}");
            let mut sides = Vec::new();
            for cand in &c {
                assert!(cand.ends_with(&tail));
                let ring = &cand[..cand.len() - tail.len()];
                assert_eq!(ring.len(), 6);
                assert_eq!(ring.last().unwrap().p_m, [0.0, 0.0]);
                assert!(ring.iter().all(|it| it.kind == ItemKind::Avoid));
                // The first point is ahead, reachable from the heading at the turn radius.
                let first = ring[0].p_m;
                let ahead = first[0] * heading.sin() + first[1] * heading.cos();
                assert!(ahead > 0.0, "{heading} {first:?}");
                assert!(reachable_from_heading([0.0, 0.0], heading, first, r));
                // A circle: every point as far from the centre, every turn flyable.
                let mut pts = vec![[0.0, 0.0]];
                pts.extend(ring.iter().map(|it| it.p_m));
                let centre = [
                    pts[..6].iter().map(|q| q[0]).sum::<f64>() / 6.0,
                    pts[..6].iter().map(|q| q[1]).sum::<f64>() / 6.0,
                ];
                let rad: Vec<f64> = pts.iter().map(|&q| dist(q, centre)).collect();
                assert!(
                    rad.iter()
                        .all(|&d| (d - rad[0]).abs() < 1e-6 && d >= 1.5 * r - 1e-6)
                );
                assert!(turn_violations(&pts, r, None).is_empty(), "{pts:?}");
                // Left or right of the heading.
                let side = centre[0] * heading.cos() - centre[1] * heading.sin();
                sides.push(side.signum());
            }
            assert!(sides.contains(&1.0) && sides.contains(&-1.0));
        }
    }

    #[test]
    fn no_hold_leaves_the_zone_or_touches_a_cylinder() {
        // A corridor 260 m wide: only the 1.5 R circles (120 m across) fit, and a cylinder
        // to the east takes the right-hand one.
        let zones = rectangle(-130.0, -100.0, 130.0, 2000.0);
        let tail = north(1000.0, 1500.0);
        let cyl = Cylinder {
            center_m: [90.0, 40.0],
            radius_m: 10.0,
            top_m: 200.0,
        };
        let c = hold_candidates(
            [0.0, 0.0],
            0.0,
            &[&tail],
            100.0,
            40.0,
            &[cyl],
            &zones,
            &DetourParams::default(),
        );
        assert_eq!(c.len(), 1, "{c:?}");
        assert!(c[0].iter().all(|it| it.p_m[0] <= 0.0 + 1e-9));
    }

    #[test]
    fn an_escape_turns_at_the_turn_radius_then_runs_straight() {
        // Heading east (compass 90 degrees) at the origin, turn radius 40 m: a quarter turn
        // left ends at (40, 40) heading north, a quarter turn right at (40, -40) heading
        // south; 150 m on, the avoid points are (40, 190) and (40, -190). No turn: straight
        // east. Each is followed by the tail.
        let tail = vec![StackItem::mission(1, [2000.0, 0.0], 100.0)];
        let east = std::f64::consts::FRAC_PI_2;
        let escapes = |cylinders: &[Cylinder], turns: &[f64]| {
            escape_candidates(
                [0.0, 0.0],
                east,
                &[&tail],
                100.0,
                40.0,
                cylinders,
                turns,
                &[150.0],
            )
        };
        let c = escapes(&[], &[0.0, 90.0]);
        let firsts: Vec<Point> = c.iter().map(|t| t[0].p_m).collect();
        let near = |p: Point, q: Point| dist(p, q) < 1e-9;
        assert_eq!(c.len(), 3, "{firsts:?}");
        for want in [[150.0, 0.0], [40.0, 190.0], [40.0, -190.0]] {
            assert!(
                firsts.iter().any(|&p| near(p, want)),
                "{want:?} not in {firsts:?}"
            );
        }
        assert!(c.iter().all(|t| t.len() == 2 && t[1] == tail[0]));
        // A point inside a cylinder is not proposed.
        let cyl = Cylinder {
            center_m: [40.0, 190.0],
            radius_m: 20.0,
            top_m: 200.0,
        };
        let c = escapes(&[cyl], &[90.0]);
        assert_eq!(c.len(), 1);
        assert!(near(c[0][0].p_m, [40.0, -190.0]));
    }

    #[test]
    fn when_no_approach_can_be_flown_as_drawn_every_one_is_proposed() {
        // W1 45 m east of W0 with a 40 m turn radius: an approach point 120 or 200 m before
        // W1, reached from W0, turns back by more than 150 degrees whichever side it is on,
        // so none is flyable as drawn; all 8 (4 directions x 2 lengths, inserted: no avoid
        // item to replace) are proposed, for the flown check to judge.
        let tail = vec![
            StackItem::mission(0, [0.0, 400.0], 100.0),
            StackItem::mission(1, [45.0, 400.0], 100.0),
            StackItem::mission(2, [45.0, -150.0], 100.0),
        ];
        let params = DetourParams {
            reapproach_step_deg: 90.0,
            ..DetourParams::default()
        };
        let c = reapproach_candidates(
            [0.0, 0.0],
            &tail,
            1,
            100.0,
            40.0,
            &[],
            &Zones::default(),
            &params,
        );
        assert_eq!(c.len(), 8, "{c:?}");
        for t in &c {
            assert_eq!(t.len(), 4);
            assert_eq!((t[0], t[2], t[3]), (tail[0], tail[1], tail[2]));
            let route: Vec<Point> = std::iter::once([0.0, 0.0])
                .chain(t.iter().map(|i| i.p_m))
                .collect();
            let bad = crate::turn::turn_violations(&route, 40.0, None);
            assert!(bad.iter().any(|v| v.index == 2), "{t:?} {bad:?}");
        }
    }

    #[test]
    fn a_reapproach_puts_one_point_before_the_waypoint_on_every_side() {
        // W0 (fixed), an avoid item, then W1 at (0, 400) reached from the avoid item at
        // (100, 300); turn radius 40 m, approach lengths 3 and 5 radii, every 90 degrees.
        let w1 = StackItem::mission(1, [0.0, 400.0], 120.0);
        let tail = vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::avoid([100.0, 300.0], 100.0),
            w1,
            StackItem::mission(2, [0.0, 900.0], 100.0),
        ];
        let params = DetourParams {
            reapproach_step_deg: 90.0,
            ..DetourParams::default()
        };
        let cands = |cylinders: &[Cylinder]| {
            reapproach_candidates(
                [0.0, -100.0],
                &tail,
                2,
                100.0,
                40.0,
                cylinders,
                &Zones::default(),
                &params,
            )
        };
        let c = cands(&[]);
        // 4 directions x 2 lengths, each inserted and replacing the avoid item, less those
        // whose turn at the approach point (or at the avoid item before it) cannot be flown
        // at 40 m: only the approaches that replace the avoid item, back along its leg or
        // from the south-west, are left. From the north-east and north-west the approach
        // turns back on itself before W1; inserted after the avoid item, it turns too close
        // to it.
        let flyable = |t: &Vec<StackItem>| {
            let route: Vec<Point> = std::iter::once([0.0, -100.0])
                .chain(t.iter().map(|i| i.p_m))
                .collect();
            crate::turn::turn_violations(&route, 40.0, None)
                .iter()
                .all(|v| t[v.index - 1].is_fixed())
        };
        assert_eq!(c.len(), 4, "{c:?}");
        assert!(c.iter().all(flyable));
        assert!(
            c.iter()
                .all(|t| t.len() == 4 && t[1].kind == crate::stack::ItemKind::Avoid)
        );
        assert!(c.iter().all(|t| t[1].p_m[1] < 400.0), "{c:?}");
        for t in &c {
            let k = t.iter().position(|i| *i == w1).unwrap();
            let a = t[k - 1];
            assert_eq!(a.kind, crate::stack::ItemKind::Avoid);
            // On the waypoint's own altitude, 120 m or 200 m out.
            assert_eq!(a.alt_m, 120.0);
            let l = dist(a.p_m, w1.p_m);
            assert!((l - 120.0).abs() < 1e-9 || (l - 200.0).abs() < 1e-9, "{l}");
            // Every fixed item kept, in order.
            let fixed: Vec<_> = t.iter().filter(|i| i.is_fixed()).collect();
            assert_eq!(fixed.len(), 3);
        }
        // The first direction is the leg's own (from the avoid item to W1): the point lies
        // back along it.
        let u = [
            -std::f64::consts::FRAC_1_SQRT_2,
            std::f64::consts::FRAC_1_SQRT_2,
        ];
        let want = [w1.p_m[0] - 120.0 * u[0], w1.p_m[1] - 120.0 * u[1]];
        assert!(dist(c[0][1].p_m, want) < 1e-6, "{:?}", c[0][1]);
        // A point inside a cylinder (grown by a fifth) is not proposed.
        let cyl = Cylinder {
            center_m: want,
            radius_m: 10.0,
            top_m: 200.0,
        };
        assert_eq!(cands(&[cyl]).len(), 3);
    }
}
