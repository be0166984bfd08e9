//! Plane geometry in ENU metres: vector helpers, point-segment distance, segment-circle
//! intersection and a prepared polygon for fly-zone predicates.
//!
//! Supports DESIGN.md "Planner" and seed 004 (steps 1-4 of the insertion algorithm are
//! written with vectors here, never with slopes, so vertical and horizontal legs are the
//! same case).
//!
//! Polygon predicates use precomputed edges and a bounding box rather than the `geo`
//! crate: the planner asks "is this point / segment inside the fly zone" a few hundred
//! thousand times per plan, and a flat edge list with an even-odd test is a few ns per
//! edge without allocation. The tests cross-check [`Polygon::contains`] against `geo`.
//!
//! # Units
//! All coordinates are `[east_m, north_m]`.

/// A point or vector in the local ENU plane, `[east_m, north_m]`.
pub type Point = [f64; 2];

/// `a + b`.
#[inline]
pub fn add(a: Point, b: Point) -> Point {
    [a[0] + b[0], a[1] + b[1]]
}

/// `a - b`.
#[inline]
pub fn sub(a: Point, b: Point) -> Point {
    [a[0] - b[0], a[1] - b[1]]
}

/// `k * a`.
#[inline]
pub fn scale(a: Point, k: f64) -> Point {
    [a[0] * k, a[1] * k]
}

/// Dot product.
#[inline]
pub fn dot(a: Point, b: Point) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// z component of the 3-D cross product (positive when `b` is counter-clockwise of `a`).
#[inline]
pub fn cross(a: Point, b: Point) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Euclidean length.
#[inline]
pub fn norm(a: Point) -> f64 {
    a[0].hypot(a[1])
}

/// Distance between two points.
#[inline]
pub fn dist(a: Point, b: Point) -> f64 {
    norm(sub(a, b))
}

/// `a + (b - a) * f`.
#[inline]
pub fn lerp(a: Point, b: Point, f: f64) -> Point {
    [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f]
}

/// `a` rotated +90 degrees (counter-clockwise): the left normal of a direction.
#[inline]
pub fn perp(a: Point) -> Point {
    [-a[1], a[0]]
}

/// Unit vector of `a`, or `None` for a (near) zero vector.
#[inline]
pub fn unit(a: Point) -> Option<Point> {
    let n = norm(a);
    (n > 1e-12).then(|| scale(a, 1.0 / n))
}

/// Parameter in `[0, 1]` of the point of segment `a -> b` closest to `p`.
#[inline]
pub fn closest_t_on_segment(p: Point, a: Point, b: Point) -> f64 {
    let d = sub(b, a);
    let l2 = dot(d, d);
    if l2 <= 0.0 {
        return 0.0;
    }
    (dot(sub(p, a), d) / l2).clamp(0.0, 1.0)
}

/// Distance from `p` to segment `a -> b`.
#[inline]
pub fn dist_point_segment(p: Point, a: Point, b: Point) -> f64 {
    dist(p, lerp(a, b, closest_t_on_segment(p, a, b)))
}

/// Line parameters `t0 <= t1` where the infinite line `a + t (b - a)` meets the circle
/// `(c, r)`, or `None` when it misses or only touches it (tangent counts as a miss).
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

/// Proper or touching intersection of segments `p1 -> p2` and `q1 -> q2`.
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

/// A simple polygon (convex or not) prepared for fast point and segment queries.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    vertices: Vec<Point>,
    min: Point,
    max: Point,
}

impl Polygon {
    /// Prepares a polygon from its vertices (open ring; a closing vertex equal to the
    /// first is dropped). Fewer than three vertices make an empty polygon that contains
    /// nothing.
    pub fn new(vertices: &[Point]) -> Self {
        let mut v = vertices.to_vec();
        if v.len() > 1 && v.first() == v.last() {
            v.pop();
        }
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for p in &v {
            min = [min[0].min(p[0]), min[1].min(p[1])];
            max = [max[0].max(p[0]), max[1].max(p[1])];
        }
        Self {
            vertices: v,
            min,
            max,
        }
    }

    /// The vertices (open ring).
    pub fn vertices(&self) -> &[Point] {
        &self.vertices
    }

    /// Even-odd point-in-polygon test. Points exactly on the boundary may go either way.
    pub fn contains(&self, p: Point) -> bool {
        let n = self.vertices.len();
        if n < 3
            || p[0] < self.min[0]
            || p[0] > self.max[0]
            || p[1] < self.min[1]
            || p[1] > self.max[1]
        {
            return false;
        }
        let mut inside = false;
        let mut j = n - 1;
        for i in 0..n {
            let a = self.vertices[i];
            let b = self.vertices[j];
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

    /// Whether segment `a -> b` crosses or touches the boundary.
    pub fn segment_crosses_boundary(&self, a: Point, b: Point) -> bool {
        let n = self.vertices.len();
        if n < 3 {
            return false;
        }
        // Bounding-box reject: a segment wholly outside the box cannot touch an edge.
        if a[0].max(b[0]) < self.min[0]
            || a[0].min(b[0]) > self.max[0]
            || a[1].max(b[1]) < self.min[1]
            || a[1].min(b[1]) > self.max[1]
        {
            return false;
        }
        let mut j = n - 1;
        for i in 0..n {
            if segments_intersect(a, b, self.vertices[j], self.vertices[i]) {
                return true;
            }
            j = i;
        }
        false
    }

    /// Whether the whole segment `a -> b` lies inside (both ends inside, no boundary
    /// crossing: required for non-convex zones, where a chord can leave and re-enter).
    pub fn contains_segment(&self, a: Point, b: Point) -> bool {
        self.contains(a) && self.contains(b) && !self.segment_crosses_boundary(a, b)
    }

    /// Distance from `p` to the nearest boundary edge.
    pub fn boundary_distance(&self, p: Point) -> f64 {
        let n = self.vertices.len();
        let mut best = f64::INFINITY;
        let mut j = n.wrapping_sub(1);
        for i in 0..n {
            best = best.min(dist_point_segment(p, self.vertices[j], self.vertices[i]));
            j = i;
        }
        best
    }
}

/// Turn angle in `[0, pi]` at vertex `b` of the path `a -> b -> c` (0 = straight on).
pub fn turn_angle_rad(a: Point, b: Point, c: Point) -> f64 {
    let u = sub(b, a);
    let v = sub(c, b);
    let (nu, nv) = (norm(u), norm(v));
    if nu <= 1e-12 || nv <= 1e-12 {
        return 0.0;
    }
    (dot(u, v) / (nu * nv)).clamp(-1.0, 1.0).acos()
}

/// Length of a polyline.
pub fn polyline_length(points: &[Point]) -> f64 {
    points.windows(2).map(|w| dist(w[0], w[1])).sum()
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
    fn a_chord_of_a_u_shaped_zone_leaves_it() {
        // U shape: the notch x in (4, 6), y > 2 is outside.
        let u = Polygon::new(&[
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 10.0],
            [6.0, 10.0],
            [6.0, 2.0],
            [4.0, 2.0],
            [4.0, 10.0],
            [0.0, 10.0],
        ]);
        assert!(u.contains([2.0, 8.0]) && u.contains([8.0, 8.0]));
        assert!(!u.contains([5.0, 8.0]));
        assert!(!u.contains_segment([2.0, 8.0], [8.0, 8.0]));
        assert!(u.contains_segment([2.0, 1.0], [8.0, 1.0]));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// The even-odd test agrees with `geo` on a non-convex polygon (points within
        /// 1e-6 of an edge are skipped: the boundary may go either way).
        #[test]
        fn contains_agrees_with_geo(x in -2.0..12.0f64, y in -2.0..12.0f64) {
            use geo::Contains;
            let ring = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [6.0, 10.0], [6.0, 2.0], [4.0, 2.0], [4.0, 10.0], [0.0, 10.0], [3.0, 5.0]];
            let poly = Polygon::new(&ring);
            let g = geo::Polygon::new(geo::LineString::from(ring.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>()), vec![]);
            if poly.boundary_distance([x, y]) > 1e-6 {
                proptest::prop_assert_eq!(poly.contains([x, y]), g.contains(&geo::Point::new(x, y)));
            }
        }
    }
}
