//! Waypoint insertion around one circular obstacle (seed 004, Ian G. Harris, "Algorithm to
//! Insert a Waypoint to Avoid an Obstacle").
//!
//! Given a leg `w1 -> w2` and an obstacle of radius `r`, with buffer `b = buffer_fraction * r`
//! (default 20%):
//! 1. the leg's line meets the safety-buffer circle (radius `r + b`) at `s1`, `s2`: the secant;
//! 2. `m` is the secant's midpoint and the perpendicular bisector is the line through `m`
//!    perpendicular to the leg;
//! 3. the bisector meets the outer circle (radius `r + 2b`) at the two candidates `f1`, `f2`;
//! 4. one candidate is inserted: `w1 -> f -> w2`.
//!
//! Everything is vector maths (direction and its normal), never slopes, so vertical,
//! horizontal and oblique legs are the same case.
//!
//! Where the seed picks the candidate at random, this picks deterministically: candidates
//! outside the fly zone (point or either new leg) are discarded; among the rest, one whose
//! two new legs both stay out of the buffer circle (and out of the `others` obstacles'
//! buffers) wins over one that does not; ties go to the shorter detour `|w1 f| + |f w2|`.
//!
//! A candidate on the `r + 2b` circle does not always give clear legs: when an endpoint
//! is close to the buffer (a short leg relative to the radius), the new leg `w1 -> f` can
//! still clip the buffer circle. This function then still inserts the best candidate and
//! reports `legs_clear: false`; the static pre-pass ([`crate::prepass`]) repeats the
//! insertion on the still-blocked new leg, which walks the path further round the circle
//! until it clears (bounded by a round limit).
//!
//! # Example
//! ```
//! use planner::insertion::{insert_waypoint, Circle, InsertOutcome};
//! let out = insert_waypoint(
//!     [0.0, 0.0],
//!     [100.0, 0.0],
//!     Circle { center_m: [50.0, 5.0], radius_m: 10.0 },
//!     0.2,
//!     None,
//! )
//! .unwrap();
//! let InsertOutcome::Inserted { waypoint, .. } = out else { panic!() };
//! assert!((waypoint[0] - 50.0).abs() < 1e-9 && (waypoint[1] + 9.0).abs() < 1e-9);
//! ```

use crate::geometry::{
    Point, add, dist, dist_point_segment, lerp, line_circle_params, perp, scale, sub, unit,
};
use crate::mission::Zones;

/// Default buffer as a fraction of the obstacle radius (seed 004: 20%).
pub const DEFAULT_BUFFER_FRACTION: f64 = 0.2;

/// A circular obstacle in ENU metres.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Circle {
    /// Centre, ENU metres.
    pub center_m: Point,
    /// Radius, metres.
    pub radius_m: f64,
}

/// Which end of the leg.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Endpoint {
    /// `from` (w1).
    From,
    /// `to` (w2).
    To,
}

/// What the insertion did. "No insertion possible" is an outcome, not an error.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum InsertOutcome {
    /// The leg misses the safety buffer (or only touches it): nothing to insert.
    NotNeeded,
    /// `waypoint` (one of `candidates`) goes between `from` and `to`.
    Inserted {
        /// The chosen waypoint.
        waypoint: Point,
        /// The seed's `f1` (left of the leg direction) and `f2` (right).
        candidates: [Point; 2],
        /// Index of `waypoint` in `candidates`.
        chosen: usize,
        /// Whether both new legs stay out of the buffer circle and the other obstacles'
        /// buffers. `false` means: insert again on the blocked new leg (the pre-pass does).
        legs_clear: bool,
    },
    /// An endpoint lies inside the safety buffer: no single inserted waypoint can keep
    /// the leg `b` away. Move the endpoint, lower the buffer, or accept the risk.
    EndpointInBuffer {
        /// The offending end.
        endpoint: Endpoint,
    },
    /// Both candidates (or the legs to them) leave the fly zone.
    NoCandidate {
        /// The seed's `f1`, `f2`, both rejected.
        candidates: [Point; 2],
    },
}

/// Bad input to [`insert_waypoint`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InsertError {
    /// A coordinate, radius or buffer is NaN or infinite: fix the caller's data.
    #[error("non-finite input")]
    NonFinite,
    /// The obstacle radius is zero or negative: send a positive radius.
    #[error("obstacle radius must be positive, got {0}")]
    NonPositiveRadius(f64),
    /// The buffer fraction is negative: send 0 or more (0.2 is the seed's default).
    #[error("buffer fraction must be >= 0, got {0}")]
    NegativeBuffer(f64),
}

/// Seed 004 insertion for one leg and one obstacle, optionally inside a fly-zone
/// boundary (ENU metres). See the module docs for the choice rule.
///
/// # Errors
/// [`InsertError`] for non-finite input, a non-positive radius or a negative buffer.
pub fn insert_waypoint(
    from: Point,
    to: Point,
    obstacle: Circle,
    buffer_fraction: f64,
    fly_zone: Option<&[Point]>,
) -> Result<InsertOutcome, InsertError> {
    let zones = fly_zone.map(Zones::single).unwrap_or_default();
    insert_waypoint_among(from, to, obstacle, buffer_fraction, &zones, &[])
}

/// [`insert_waypoint`] with prepared fly zones and other obstacles the new legs should
/// also keep clear of (each grown by the same buffer fraction).
///
/// # Errors
/// As [`insert_waypoint`].
pub fn insert_waypoint_among(
    from: Point,
    to: Point,
    obstacle: Circle,
    buffer_fraction: f64,
    zones: &Zones,
    others: &[Circle],
) -> Result<InsertOutcome, InsertError> {
    let finite = from
        .iter()
        .chain(to.iter())
        .chain(obstacle.center_m.iter())
        .all(|v| v.is_finite())
        && obstacle.radius_m.is_finite()
        && buffer_fraction.is_finite();
    if !finite {
        return Err(InsertError::NonFinite);
    }
    if obstacle.radius_m <= 0.0 {
        return Err(InsertError::NonPositiveRadius(obstacle.radius_m));
    }
    if buffer_fraction < 0.0 {
        return Err(InsertError::NegativeBuffer(buffer_fraction));
    }
    let c = obstacle.center_m;
    let b = buffer_fraction * obstacle.radius_m;
    let r_buffer = obstacle.radius_m + b;
    let r_outer = obstacle.radius_m + 2.0 * b;

    if dist(from, c) < r_buffer {
        return Ok(InsertOutcome::EndpointInBuffer {
            endpoint: Endpoint::From,
        });
    }
    if dist(to, c) < r_buffer {
        return Ok(InsertOutcome::EndpointInBuffer {
            endpoint: Endpoint::To,
        });
    }
    // Step 1: the secant. Both ends are outside the circle, so the segment enters it
    // exactly when the line's entry parameter lies inside (0, 1).
    let Some((t0, t1)) = line_circle_params(from, to, c, r_buffer) else {
        return Ok(InsertOutcome::NotNeeded);
    };
    if t1 <= 0.0 || t0 >= 1.0 {
        return Ok(InsertOutcome::NotNeeded);
    }
    let s1 = lerp(from, to, t0);
    let s2 = lerp(from, to, t1);
    // Step 2: midpoint and the bisector's direction (the leg's left normal).
    let m = lerp(s1, s2, 0.5);
    let Some(dir) = unit(sub(to, from)) else {
        return Ok(InsertOutcome::NotNeeded);
    };
    let n = perp(dir);
    // Step 3: bisector m + s n meets |x - c| = r_outer. m is the foot of the perpendicular
    // from c, so w = m - c is parallel to n and s = -(w.n) +- sqrt((w.n)^2 - |w|^2 + R^2).
    let w = sub(m, c);
    let wn = w[0] * n[0] + w[1] * n[1];
    let disc = (wn * wn - (w[0] * w[0] + w[1] * w[1]) + r_outer * r_outer).max(0.0);
    let root = disc.sqrt();
    let f1 = add(m, scale(n, -wn + root));
    let f2 = add(m, scale(n, -wn - root));
    let candidates = [f1, f2];

    // Step 4: choose, deterministically.
    let clear_of = |p: Point, q: Point| {
        dist_point_segment(c, p, q) >= r_buffer - 1e-9
            && others.iter().all(|o| {
                dist_point_segment(o.center_m, p, q) >= o.radius_m * (1.0 + buffer_fraction) - 1e-9
            })
    };
    let mut best: Option<(bool, f64, usize)> = None;
    for (i, &f) in candidates.iter().enumerate() {
        if !(zones.contains_segment(from, f) && zones.contains_segment(f, to)) {
            continue;
        }
        let clear = clear_of(from, f) && clear_of(f, to);
        let len = dist(from, f) + dist(f, to);
        let better = match best {
            None => true,
            Some((bc, bl, _)) => (clear && !bc) || (clear == bc && len < bl - 1e-9),
        };
        if better {
            best = Some((clear, len, i));
        }
    }
    Ok(match best {
        Some((legs_clear, _, chosen)) => InsertOutcome::Inserted {
            waypoint: candidates[chosen],
            candidates,
            chosen,
            legs_clear,
        },
        None => InsertOutcome::NoCandidate { candidates },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Seed 004 with the default 20% buffer, for inputs known to be valid.
    fn insert(
        from: Point,
        to: Point,
        center_m: Point,
        radius_m: f64,
        zone: Option<&[Point]>,
    ) -> InsertOutcome {
        insert_waypoint(from, to, Circle { center_m, radius_m }, 0.2, zone).unwrap()
    }

    fn inserted(out: InsertOutcome) -> (Point, [Point; 2], bool) {
        match out {
            InsertOutcome::Inserted {
                waypoint,
                candidates,
                legs_clear,
                ..
            } => (waypoint, candidates, legs_clear),
            other => panic!("expected an insertion, got {other:?}"),
        }
    }

    #[test]
    fn seed_004_worked_example_horizontal_leg() {
        // w1 = (0,0), w2 = (100,0), obstacle (50,5) r = 10 -> b = 0.2*10 = 2,
        // buffer radius 12, outer radius 14.
        // Secant on y = 0: (x-50)^2 + 5^2 = 144 -> x = 50 +- sqrt(119) = 50 +- 10.9087,
        // s1 = (39.0913, 0), s2 = (60.9087, 0), midpoint m = (50, 0), bisector x = 50.
        // Outer circle on x = 50: (y-5)^2 = 196 -> y = 19 or y = -9.
        // f1 (left of +x, i.e. +y) = (50, 19), f2 = (50, -9).
        // Detours: via (50,-9): 2*sqrt(50^2+9^2) = 2*50.8035 = 101.607;
        //          via (50,19): 2*sqrt(50^2+19^2) = 2*53.4883 = 106.977 -> f2 wins.
        // Leg (0,0)->(50,-9) distance to (50,5): |50*5 - (-9)*50| / 50.8035 = 700/50.8035
        // = 13.78 >= 12: clear (the foot is at t = 2455/2581 = 0.951, inside the segment).
        let out = insert([0.0, 0.0], [100.0, 0.0], [50.0, 5.0], 10.0, None);
        let (f, cands, clear) = inserted(out);
        assert_relative_eq!(cands[0][0], 50.0, epsilon = 1e-9);
        assert_relative_eq!(cands[0][1], 19.0, epsilon = 1e-9);
        assert_relative_eq!(cands[1][1], -9.0, epsilon = 1e-9);
        assert_relative_eq!(f[0], 50.0, epsilon = 1e-9);
        assert_relative_eq!(f[1], -9.0, epsilon = 1e-9);
        assert!(clear);
        assert_relative_eq!(
            dist_point_segment([50.0, 5.0], [0.0, 0.0], f),
            700.0 / (2581.0f64).sqrt(),
            epsilon = 1e-9
        );
    }

    #[test]
    fn vertical_leg_needs_no_slope() {
        // The same example rotated +90 degrees: w1 = (0,0), w2 = (0,100), obstacle (-5,50).
        // Direction +y, left normal (-1, 0). Secant midpoint (0, 50); candidates at
        // x = -5 +- 14 -> f1 = (-19, 50) (left), f2 = (9, 50). The shorter is (9, 50).
        let out = insert([0.0, 0.0], [0.0, 100.0], [-5.0, 50.0], 10.0, None);
        let (f, cands, _) = inserted(out);
        assert_relative_eq!(cands[0][0], -19.0, epsilon = 1e-9);
        assert_relative_eq!(f[0], 9.0, epsilon = 1e-9);
        assert_relative_eq!(f[1], 50.0, epsilon = 1e-9);
    }

    #[test]
    fn a_leg_through_the_centre_gets_symmetric_candidates_and_picks_the_first() {
        // Obstacle on the leg: m = centre = (50,0), candidates (50, +-14), equal detours
        // 2*sqrt(2500+196); the tie keeps the first (left, +y).
        let out = insert([0.0, 0.0], [100.0, 0.0], [50.0, 0.0], 10.0, None);
        let (f, _, _) = inserted(out);
        assert_relative_eq!(f[1], 14.0, epsilon = 1e-9);
    }

    #[test]
    fn tangent_and_missing_legs_need_nothing() {
        // Buffer radius 12 at (50, 12): y = 0 touches it exactly -> not needed.
        let f = |y| insert([0.0, 0.0], [100.0, 0.0], [50.0, y], 10.0, None);
        assert_eq!(f(12.0), InsertOutcome::NotNeeded);
        assert_eq!(f(30.0), InsertOutcome::NotNeeded);
        // Circle beyond the end of the segment (line hits it, segment does not).
        let out = insert([0.0, 0.0], [100.0, 0.0], [150.0, 0.0], 10.0, None);
        assert_eq!(out, InsertOutcome::NotNeeded);
    }

    #[test]
    fn an_endpoint_inside_the_buffer_is_an_outcome() {
        // w2 = (100,0) is 11 m from (100, 11): inside the 12 m buffer, outside the 10 m disc.
        let out = insert([0.0, 0.0], [100.0, 0.0], [100.0, 11.0], 10.0, None);
        assert_eq!(
            out,
            InsertOutcome::EndpointInBuffer {
                endpoint: Endpoint::To
            }
        );
    }

    #[test]
    fn the_fly_zone_overrules_the_shorter_side() {
        // As the worked example, but the zone is y in [-5, 100]: (50,-9) is outside,
        // so (50, 19) is chosen although longer.
        let zone = [[-10.0, -5.0], [110.0, -5.0], [110.0, 100.0], [-10.0, 100.0]];
        let out = insert([0.0, 0.0], [100.0, 0.0], [50.0, 5.0], 10.0, Some(&zone));
        let (f, _, _) = inserted(out);
        assert_relative_eq!(f[1], 19.0, epsilon = 1e-9);
        // A zone excluding both sides: no candidate.
        let thin = [[-10.0, -5.0], [110.0, -5.0], [110.0, 5.0], [-10.0, 5.0]];
        let out = insert([0.0, 0.0], [100.0, 0.0], [50.0, 5.0], 10.0, Some(&thin));
        assert!(matches!(out, InsertOutcome::NoCandidate { .. }));
    }

    #[test]
    fn a_short_leg_can_leave_new_legs_inside_the_buffer() {
        // w1 = (-15,0), w2 = (15,0), obstacle (0,0) r = 10: b = 2, buffer 12, outer 14.
        // Secant x = +-12, m = (0,0), candidates (0, +-14).
        // Leg (-15,0)->(0,14): distance from origin = |(-15)*14 - 0*15| / sqrt(15^2+14^2)
        // = 210 / 20.518 = 10.235 < 12: the new leg clips the buffer -> legs_clear = false.
        let out = insert([-15.0, 0.0], [15.0, 0.0], [0.0, 0.0], 10.0, None);
        let (f, _, clear) = inserted(out);
        assert_relative_eq!(f[1].abs(), 14.0, epsilon = 1e-9);
        assert!(!clear);
        assert_relative_eq!(
            dist_point_segment([0.0, 0.0], [-15.0, 0.0], f),
            210.0 / (421.0f64).sqrt(),
            epsilon = 1e-9
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        let c = Circle {
            center_m: [0.0, 0.0],
            radius_m: -1.0,
        };
        assert!(matches!(
            insert_waypoint([0.0, 0.0], [1.0, 0.0], c, 0.2, None),
            Err(InsertError::NonPositiveRadius(_))
        ));
        let c = Circle {
            center_m: [f64::NAN, 0.0],
            radius_m: 1.0,
        };
        assert_eq!(
            insert_waypoint([0.0, 0.0], [1.0, 0.0], c, 0.2, None),
            Err(InsertError::NonFinite)
        );
    }
}
