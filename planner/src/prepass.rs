//! Static pre-pass: seed 004's waypoint insertion applied to every leg blocked by a
//! cylinder, repeated until no leg is blocked or a round limit is reached
//! (DESIGN.md "Planner", first paragraph).
//!
//! Each round walks the current polyline; for a leg that enters some cylinder's safety
//! buffer (at the leg's altitude), the first such cylinder along the leg gets one
//! [`insert_waypoint_among`] call (the other cylinders as obstacles the new legs should
//! also avoid). Inserted points split the leg, so the next round examines the two new legs:
//! this is how a candidate whose new leg still clips the buffer (short legs), or that
//! runs into a neighbouring cylinder, gets fixed. Mission waypoints never move.
//!
//! # Example
//! ```
//! use planner::mission::{Cylinder, Zones};
//! use planner::prepass::{prepass_leg, PrepassParams};
//! let cyl = [Cylinder { center_m: [50.0, 5.0], radius_m: 10.0, top_m: 100.0 }];
//! let leg = prepass_leg([0.0, 0.0], [100.0, 0.0], 50.0, &cyl, &Zones::default(), &PrepassParams::default());
//! assert_eq!(leg.inserted.len(), 1);
//! assert!(!leg.blocked);
//! ```

use crate::geometry::Point;
use crate::insertion::{Circle, DEFAULT_BUFFER_FRACTION, InsertOutcome, insert_waypoint_among};
use crate::mission::{Cylinder, Zones, first_blocking_cylinder};

/// Pre-pass parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrepassParams {
    /// Safety buffer as a fraction of each cylinder's radius. Default 0.2 (seed 004).
    pub buffer_fraction: f64,
    /// Maximum number of rounds over the legs. Default 8.
    pub max_rounds: usize,
    /// Maximum number of waypoints inserted on one leg. Default 16.
    pub max_inserted_per_leg: usize,
}

impl Default for PrepassParams {
    fn default() -> Self {
        Self {
            buffer_fraction: DEFAULT_BUFFER_FRACTION,
            max_rounds: 8,
            max_inserted_per_leg: 16,
        }
    }
}

impl PrepassParams {
    setters! {
        /// Sets the buffer fraction.
        buffer_fraction(buffer_fraction: f64);
        /// Sets the round limit.
        max_rounds(max_rounds: usize);
    }
}

/// The result of the pre-pass on one leg.
#[derive(Debug, Clone, PartialEq)]
pub struct PrepassLeg {
    /// Inserted waypoints between the leg's ends, in flight order.
    pub inserted: Vec<Point>,
    /// True when some sub-leg still enters a cylinder's buffer or leaves the fly zone.
    pub blocked: bool,
    /// Rounds used.
    pub rounds: usize,
}

/// Runs the pre-pass on the leg `a -> b` flown at `alt_m`.
pub fn prepass_leg(
    a: Point,
    b: Point,
    alt_m: f64,
    cylinders: &[Cylinder],
    zones: &Zones,
    params: &PrepassParams,
) -> PrepassLeg {
    let bf = params.buffer_fraction;
    let relevant: Vec<Circle> = cylinders
        .iter()
        .filter(|c| c.matters_at(alt_m))
        .map(|c| Circle {
            center_m: c.center_m,
            radius_m: c.radius_m,
        })
        .collect();
    let relevant_cyl: Vec<Cylinder> = cylinders
        .iter()
        .copied()
        .filter(|c| c.matters_at(alt_m))
        .collect();
    let mut path = vec![a, b];
    let mut rounds = 0;
    let mut others: Vec<Circle> = Vec::with_capacity(relevant.len());
    let mut total_inserted = 0usize;
    while rounds < params.max_rounds {
        rounds += 1;
        let mut changed = false;
        let mut next = Vec::with_capacity(path.len() * 2);
        next.push(path[0]);
        for w in path.windows(2) {
            let (p, q) = (w[0], w[1]);
            if total_inserted < params.max_inserted_per_leg
                && let Some(i) = first_blocking_cylinder(&relevant_cyl, p, q, alt_m, bf)
            {
                others.clear();
                others.extend(
                    relevant
                        .iter()
                        .enumerate()
                        .filter(|(j, _)| *j != i)
                        .map(|(_, c)| *c),
                );
                if let Ok(InsertOutcome::Inserted { waypoint, .. }) =
                    insert_waypoint_among(p, q, relevant[i], bf, zones, &others)
                {
                    next.push(waypoint);
                    total_inserted += 1;
                    changed = true;
                }
            }
            next.push(q);
        }
        path = next;
        if !changed {
            break;
        }
    }
    let blocked = path.windows(2).any(|w| {
        first_blocking_cylinder(&relevant_cyl, w[0], w[1], alt_m, bf).is_some()
            || !zones.contains_segment(w[0], w[1])
    });
    let inserted = path[1..path.len() - 1].to_vec();
    PrepassLeg {
        inserted,
        blocked,
        rounds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::dist_point_segment;

    fn cylinder(center_m: Point, radius_m: f64, top_m: f64) -> Cylinder {
        Cylinder {
            center_m,
            radius_m,
            top_m,
        }
    }

    /// The pre-pass with default parameters and no fly zone.
    fn prepass(from: Point, to: Point, alt_m: f64, cylinders: &[Cylinder]) -> PrepassLeg {
        prepass_leg(
            from,
            to,
            alt_m,
            cylinders,
            &Zones::default(),
            &PrepassParams::default(),
        )
    }

    #[test]
    fn a_short_leg_is_walked_round_the_circle_until_clear() {
        // See insertion::tests::a_short_leg_can_leave_new_legs_inside_the_buffer: one
        // insertion leaves (-15,0)->(0,14) at 10.2 m < 12 m; further rounds fix it.
        let cyl = [cylinder([0.0, 0.0], 10.0, 100.0)];
        let leg = prepass([-15.0, 0.0], [15.0, 0.0], 50.0, &cyl);
        assert!(!leg.blocked, "{leg:?}");
        assert!(leg.inserted.len() >= 2);
        let mut pts = vec![[-15.0, 0.0]];
        pts.extend(&leg.inserted);
        pts.push([15.0, 0.0]);
        for w in pts.windows(2) {
            assert!(dist_point_segment([0.0, 0.0], w[0], w[1]) >= 12.0 - 1e-9);
        }
    }

    #[test]
    fn a_cylinder_below_the_leg_is_ignored() {
        let cyl = [cylinder([50.0, 0.0], 10.0, 40.0)];
        let leg = prepass([0.0, 0.0], [100.0, 0.0], 50.0, &cyl);
        assert!(leg.inserted.is_empty() && !leg.blocked);
        // At 40 m (equal to the top) it matters.
        let leg = prepass([0.0, 0.0], [100.0, 0.0], 40.0, &cyl);
        assert_eq!(leg.inserted.len(), 1);
    }

    #[test]
    fn two_cylinders_in_a_row_each_get_a_waypoint() {
        let cyl = [
            cylinder([100.0, 3.0], 20.0, 100.0),
            cylinder([300.0, -3.0], 20.0, 100.0),
        ];
        let leg = prepass([0.0, 0.0], [400.0, 0.0], 50.0, &cyl);
        assert!(!leg.blocked);
        assert!(leg.inserted.len() >= 2);
    }
}
