//! Plane geometry helpers in ENU metres: vectors, polygons, segments, circles and rays.
//!
//! Small free functions used by every other module of the simulator. Points are
//! `[east_m, north_m]`.

/// A point or vector in the ENU plane, metres (the planner's `Point`).
pub type P2 = planner::geometry::Point;

// The vector algebra is the planner's own: one definition for both crates.
pub use planner::geometry::{add, cross, dist, dot, norm, scale, segments_intersect, sub};

/// Unit vector of `a` (zero stays zero).
#[inline]
pub fn unit(a: P2) -> P2 {
    let n = norm(a);
    if n > 0.0 {
        scale(a, 1.0 / n)
    } else {
        [0.0, 0.0]
    }
}

/// `a` rotated by +90 degrees (to the left).
#[inline]
pub fn perp_left(a: P2) -> P2 {
    [-a[1], a[0]]
}

/// The first two coordinates of a 3-D point.
#[inline]
pub fn xy(p: [f64; 3]) -> P2 {
    [p[0], p[1]]
}

/// Wraps an angle to `(-pi, pi]`.
pub fn wrap_pi(a_rad: f64) -> f64 {
    let mut a = a_rad % std::f64::consts::TAU;
    if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    } else if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    }
    a
}

/// Whether `p` lies inside the polygon (even-odd rule; the ring need not be closed).
pub fn point_in_polygon(p: P2, poly: &[P2]) -> bool {
    let n = poly.len();
    if n < 3 {
        return false;
    }
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Whether the whole segment `a-b` lies inside the polygon (both ends inside, no edge crossed).
pub fn segment_inside_polygon(a: P2, b: P2, poly: &[P2]) -> bool {
    if !point_in_polygon(a, poly) || !point_in_polygon(b, poly) {
        return false;
    }
    let n = poly.len();
    (0..n).all(|i| !segments_intersect(a, b, poly[i], poly[(i + 1) % n]))
}

/// Distance from `p` to the segment `a-b`.
pub fn point_segment_distance(p: P2, a: P2, b: P2) -> f64 {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    if l2 == 0.0 {
        return dist(p, a);
    }
    let t = (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0);
    dist(p, add(a, scale(ab, t)))
}

/// Distance from `p` to the polygon's boundary.
pub fn distance_to_polygon_boundary(p: P2, poly: &[P2]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| point_segment_distance(p, poly[i], poly[(i + 1) % n]))
        .fold(f64::INFINITY, f64::min)
}

/// Smallest `t >= 0` with `|origin + t * dir - center| = r`, for a unit `dir`; `None` if the
/// ray misses. A ray starting inside the circle answers `Some(0.0)`.
pub fn ray_circle(origin: P2, dir: P2, center: P2, r: f64) -> Option<f64> {
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

/// Length of a polyline.
pub fn polyline_length(pts: &[P2]) -> f64 {
    pts.windows(2).map(|w| dist(w[0], w[1])).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_from_the_origin_hits_a_circle_ten_metres_east_at_its_near_side() {
        // Circle at (10, 0) radius 2: near side at x = 8.
        let t = ray_circle([0.0, 0.0], [1.0, 0.0], [10.0, 0.0], 2.0).unwrap();
        assert!((t - 8.0).abs() < 1e-12);
        assert!(ray_circle([0.0, 0.0], [-1.0, 0.0], [10.0, 0.0], 2.0).is_none());
        assert!(ray_circle([0.0, 0.0], [0.0, 1.0], [10.0, 0.0], 2.0).is_none());
    }

    #[test]
    fn polygon_membership_and_segment_containment_follow_the_edges() {
        // An L-shaped polygon: the segment between the two arms leaves it.
        let l = [
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 2.0],
            [2.0, 2.0],
            [2.0, 10.0],
            [0.0, 10.0],
        ];
        assert!(point_in_polygon([1.0, 1.0], &l));
        assert!(!point_in_polygon([5.0, 5.0], &l));
        assert!(segment_inside_polygon([1.0, 1.0], [9.0, 1.0], &l));
        assert!(!segment_inside_polygon([9.0, 1.0], [1.0, 9.0], &l));
    }
}
