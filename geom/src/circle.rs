//!
//! Seed 004's insertion finds where a leg enters and leaves a buffered cylinder
//! ([`line_circle_params`]); the simulated LiDAR finds a beam's first return
//! ([`ray_circle`]).

use crate::vector::{Point, dot, sub};

/// Line parameters `t0 <= t1` where the infinite line `a + t (b - a)` meets the circle
/// (`c`, radius `r` metres), or `None` when it misses or only touches it (tangent counts as
/// a miss) or `a == b`.
pub fn line_circle_params(a: Point, b: Point, c: Point, r: f64) -> Option<(f64, f64)> {
    let d = sub(b, a);
    let f = sub(a, c);
    let qa = dot(d, d);
    if qa <= 0.0 {
        return None;
    }
    let qb = 2.0 * dot(f, d);
    let qc = dot(f, f) - r * r;
    let disc = qb * qb - 4.0 * qa * qc;
    if disc <= 0.0 {
        return None;
    }
    let s = disc.sqrt();
    Some(((-qb - s) / (2.0 * qa), (-qb + s) / (2.0 * qa)))
}

/// Smallest distance `t >= 0` (metres) with `|origin + t * dir - center| = r`, for a unit
/// `dir`; `None` if the ray misses. A ray starting inside the circle answers `Some(0.0)`.
pub fn ray_circle(origin: Point, dir: Point, center: Point, r: f64) -> Option<f64> {
    let oc = sub(origin, center);
    let c = dot(oc, oc) - r * r;
    if c <= 0.0 {
        return Some(0.0);
    }
    let b = dot(oc, dir);
    if b >= 0.0 {
        return None;
    }
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    Some(-b - disc.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn line_circle_params_of_a_horizontal_chord() {
        // Line y = 5 through circle centre (50, 0) r = 13: x = 50 +- 12 -> t = 0.38, 0.62
        // on a -> b = (0, 5) -> (100, 5).
        let (t0, t1) = line_circle_params([0.0, 5.0], [100.0, 5.0], [50.0, 0.0], 13.0).unwrap();
        assert_relative_eq!(t0, 0.38, epsilon = 1e-12);
        assert_relative_eq!(t1, 0.62, epsilon = 1e-12);
        // Tangent: y = 13 touches only; reported as a miss.
        assert!(line_circle_params([0.0, 13.0], [100.0, 13.0], [50.0, 0.0], 13.0).is_none());
    }

    #[test]
    fn a_ray_from_the_origin_hits_a_circle_ten_metres_east_at_its_near_side() {
        // Circle at (10, 0) radius 2: near side at x = 8.
        let t = ray_circle([0.0, 0.0], [1.0, 0.0], [10.0, 0.0], 2.0).unwrap();
        assert_relative_eq!(t, 8.0, epsilon = 1e-12);
        assert!(ray_circle([0.0, 0.0], [-1.0, 0.0], [10.0, 0.0], 2.0).is_none());
        assert!(ray_circle([0.0, 0.0], [0.0, 1.0], [10.0, 0.0], 2.0).is_none());
        // From inside: the return is immediate.
        assert_eq!(
            ray_circle([10.5, 0.0], [1.0, 0.0], [10.0, 0.0], 2.0),
            Some(0.0)
        );
    }
}
