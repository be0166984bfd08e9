//!
//! Used for clearance (a cylinder's distance to a leg), threat filtering (an obstacle's
//! distance to the intended path) and the fly-zone predicates.

use crate::vector::{Point, cross, dist, dot, lerp, sub};

/// Parameter in `[0, 1]` of the point of segment `a -> b` closest to `p` (0 when `a == b`).
#[inline]
pub fn closest_t_on_segment(p: Point, a: Point, b: Point) -> f64 {
    let d = sub(b, a);
    let l2 = dot(d, d);
    if l2 <= 0.0 {
        return 0.0;
    }
    (dot(sub(p, a), d) / l2).clamp(0.0, 1.0)
}

/// Distance from `p` to segment `a -> b`, metres.
#[inline]
pub fn dist_point_segment(p: Point, a: Point, b: Point) -> f64 {
    dist(p, lerp(a, b, closest_t_on_segment(p, a, b)))
}

/// Whether segments `p1 -> p2` and `q1 -> q2` share a point: a proper crossing or a touch
/// (an end on the other segment, or a collinear overlap). Exact signs, no tolerance.
#[inline]
pub fn segments_intersect(p1: Point, p2: Point, q1: Point, q2: Point) -> bool {
    let d1 = cross(sub(q2, q1), sub(p1, q1));
    let d2 = cross(sub(q2, q1), sub(p2, q1));
    let d3 = cross(sub(p2, p1), sub(q1, p1));
    let d4 = cross(sub(p2, p1), sub(q2, p1));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |a: Point, b: Point, p: Point, d: f64| {
        d == 0.0
            && p[0] >= a[0].min(b[0])
            && p[0] <= a[0].max(b[0])
            && p[1] >= a[1].min(b[1])
            && p[1] <= a[1].max(b[1])
    };
    on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn distance_to_a_vertical_segment_uses_the_perpendicular_foot() {
        // Segment x = 0, y in [0, 10]; p = (3, 4): foot (0, 4), distance 3.
        assert_relative_eq!(dist_point_segment([3.0, 4.0], [0.0, 0.0], [0.0, 10.0]), 3.0);
        // Beyond the end: p = (3, 14) -> nearest (0, 10), distance 5 (3-4-5 triangle).
        assert_relative_eq!(
            dist_point_segment([3.0, 14.0], [0.0, 0.0], [0.0, 10.0]),
            5.0
        );
    }

    #[test]
    fn a_degenerate_segment_is_its_point() {
        assert_eq!(
            closest_t_on_segment([3.0, 4.0], [0.0, 0.0], [0.0, 0.0]),
            0.0
        );
        assert_relative_eq!(dist_point_segment([3.0, 4.0], [0.0, 0.0], [0.0, 0.0]), 5.0);
    }

    #[test]
    fn crossing_touching_overlapping_and_apart() {
        let (a, b) = ([0.0, 0.0], [10.0, 0.0]);
        assert!(segments_intersect(a, b, [5.0, -1.0], [5.0, 1.0]));
        // An end of one on the other.
        assert!(segments_intersect(a, b, [5.0, 0.0], [5.0, 1.0]));
        // Collinear overlap, and collinear but apart.
        assert!(segments_intersect(a, b, [8.0, 0.0], [12.0, 0.0]));
        assert!(!segments_intersect(a, b, [11.0, 0.0], [12.0, 0.0]));
        // Parallel.
        assert!(!segments_intersect(a, b, [0.0, 1.0], [10.0, 1.0]));
    }
}
