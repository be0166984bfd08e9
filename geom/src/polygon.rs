//!
//! # Boundary rule (issue 10)
//! The polygon is a closed set: a point on the boundary (a vertex, or on an edge) is inside,
//! and a segment is inside when every point of it is inside or on the boundary. So a leg
//! between two fly-zone vertices, a leg touching a vertex, or a leg running along an edge
//! is inside; a leg that crosses to the outside anywhere, even between two boundary points
//! (a chord across the notch of a U-shaped zone), is not. "On the boundary" allows
//! [`BOUNDARY_TOLERANCE_M`] for rounding.
//!
//! # Speed
//! [`Polygon`] keeps a flat vertex list and a bounding box rather than using the `geo`
//! crate: the planner asks "is this point / segment inside the fly zone" a few hundred
//! thousand times per plan, and the even-odd test is a handful of arithmetic operations per
//! edge without allocation. The free functions answer the same questions on a bare vertex ring (open or
//! closed) without the bounding-box shortcut. The tests cross-check both against `geo`.

use crate::segment::{closest_t_on_segment, dist_point_segment};
use crate::vector::{Point, cross, dot, lerp, sub};

/// How far outside the boundary a point may be and still count as on it, metres. Covers
/// floating-point rounding of coordinates that are meant to coincide (a waypoint placed on a
/// fly-zone vertex, a leg along an edge); far below any flying accuracy.
pub const BOUNDARY_TOLERANCE_M: f64 = 1e-6;

/// The edges of a ring as `(start, end)` pairs, closing it (`ring[n-1] -> ring[0]`).
fn edges(ring: &[Point]) -> impl Iterator<Item = (Point, Point)> + '_ {
    let n = ring.len();
    (0..n).map(move |i| (ring[(i + n - 1) % n], ring[i]))
}

/// Even-odd ray-crossing parity: strictly inside or outside away from the boundary; points
/// on the boundary may go either way (the callers settle those with the distance).
fn even_odd(p: Point, ring: &[Point]) -> bool {
    let mut inside = false;
    for (b, a) in edges(ring) {
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Whether `p` is within [`BOUNDARY_TOLERANCE_M`] of segment `a -> b`, by squared distances
/// (no square root: this runs for every edge when a point is outside).
fn near_segment(p: Point, a: Point, b: Point) -> bool {
    let d = sub(p, lerp(a, b, closest_t_on_segment(p, a, b)));
    dot(d, d) <= BOUNDARY_TOLERANCE_M * BOUNDARY_TOLERANCE_M
}

/// Whether `p` is within [`BOUNDARY_TOLERANCE_M`] of some edge of `ring`.
fn near_boundary(p: Point, ring: &[Point]) -> bool {
    edges(ring).any(|(a, b)| near_segment(p, a, b))
}

/// Whether `p` is inside the polygon `ring` or on its boundary (fewer than three vertices
/// contain nothing).
pub fn point_in_polygon(p: Point, ring: &[Point]) -> bool {
    ring.len() >= 3 && (even_odd(p, ring) || near_boundary(p, ring))
}

/// Distance from `p` to the nearest edge of the polygon `ring`, metres (infinite for an
/// empty ring).
pub fn distance_to_polygon_boundary(p: Point, ring: &[Point]) -> f64 {
    edges(ring)
        .map(|(a, b)| dist_point_segment(p, a, b))
        .fold(f64::INFINITY, f64::min)
}

/// Whether every point of segment `a -> b` is inside the polygon `ring` or on its boundary
/// (the boundary rule in the module docs).
pub fn segment_inside_polygon(a: Point, b: Point, ring: &[Point]) -> bool {
    point_in_polygon(a, ring)
        && point_in_polygon(b, ring)
        && segment_stays_in(a, b, ring, |p| point_in_polygon(p, ring))
}

/// How a segment meets a ring's edges.
enum Contact {
    /// No edge is within the tolerance of the segment: it does not meet the boundary.
    Apart,
    /// Some edge crosses it properly: the segment passes from one side to the other.
    Crosses,
    /// Some edge or vertex comes within the tolerance of the segment or its line, without a
    /// proper crossing: touches, overlaps and near misses, settled piece by piece.
    Touches,
}

/// Classifies how segment `a -> b` meets the edges of `ring` (see [`Contact`]).
fn contact(a: Point, b: Point, ring: &[Point]) -> Contact {
    let tol = BOUNDARY_TOLERANCE_M;
    let s = sub(b, a);
    let ls2 = dot(s, s);
    let mut touches = false;
    for (q1, q2) in edges(ring) {
        if a[0].max(b[0]) < q1[0].min(q2[0]) - tol
            || a[0].min(b[0]) > q1[0].max(q2[0]) + tol
            || a[1].max(b[1]) < q1[1].min(q2[1]) - tol
            || a[1].min(b[1]) > q1[1].max(q2[1]) + tol
        {
            continue;
        }
        let e = sub(q2, q1);
        let le2 = dot(e, e);
        if le2 == 0.0 || ls2 == 0.0 {
            touches = true;
            continue;
        }
        // a, b against the edge's line and q1, q2 against the segment's: each cross
        // product is a signed distance times the line's length, so "within the tolerance of
        // the line" is cross^2 <= tol^2 * length^2 (no square root in this hot loop).
        let da = cross(e, sub(a, q1));
        let db = cross(e, sub(b, q1));
        let d1 = cross(s, sub(q1, a));
        let d2 = cross(s, sub(q2, a));
        let near = |d: f64, l2: f64| d * d <= tol * tol * l2;
        if near(da, le2) || near(db, le2) || near(d1, ls2) || near(d2, ls2) {
            touches = true;
        } else if (da > 0.0) != (db > 0.0) && (d1 > 0.0) != (d2 > 0.0) {
            return Contact::Crosses;
        }
    }
    if touches {
        Contact::Touches
    } else {
        Contact::Apart
    }
}

/// Given both ends inside (closed), whether the segment stays inside: it fails on a proper
/// crossing. With only touches and near misses, the segment is cut wherever it meets an
/// edge's line within the edge and at every vertex within the tolerance of it; between two
/// cuts it meets no edge, so each piece is wholly inside, wholly outside or along an edge,
/// and its midpoint decides.
fn segment_stays_in(a: Point, b: Point, ring: &[Point], contains: impl Fn(Point) -> bool) -> bool {
    match contact(a, b, ring) {
        Contact::Apart => true,
        Contact::Crosses => false,
        Contact::Touches => {
            let s = sub(b, a);
            let crossings = edges(ring).filter_map(|(q1, q2)| {
                let e = sub(q2, q1);
                let denom = cross(s, e);
                if denom == 0.0 {
                    return None;
                }
                let aq = sub(q1, a);
                let (t, u) = (cross(aq, e) / denom, cross(aq, s) / denom);
                ((0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u)).then_some(t)
            });
            let vertices = ring
                .iter()
                .filter(|q| near_segment(**q, a, b))
                .map(|q| closest_t_on_segment(*q, a, b));
            let mut cuts: Vec<f64> = crossings.chain(vertices).chain([0.0, 1.0]).collect();
            cuts.sort_by(f64::total_cmp);
            cuts.windows(2)
                .filter(|w| w[1] > w[0])
                .all(|w| contains(lerp(a, b, 0.5 * (w[0] + w[1]))))
        }
    }
}

/// A simple polygon (convex or not) prepared for fast point and segment queries, with the
/// closed boundary rule of the module docs.
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

    /// Whether `p` is inside or on the boundary.
    pub fn contains(&self, p: Point) -> bool {
        let tol = BOUNDARY_TOLERANCE_M;
        if self.vertices.len() < 3
            || p[0] < self.min[0] - tol
            || p[0] > self.max[0] + tol
            || p[1] < self.min[1] - tol
            || p[1] > self.max[1] + tol
        {
            return false;
        }
        even_odd(p, &self.vertices) || near_boundary(p, &self.vertices)
    }

    /// Whether every point of segment `a -> b` is inside or on the boundary: a leg touching
    /// a vertex or running along an edge is inside; one that leaves anywhere is not
    /// (required for non-convex zones, where a chord can leave and re-enter).
    pub fn contains_segment(&self, a: Point, b: Point) -> bool {
        self.contains(a)
            && self.contains(b)
            && segment_stays_in(a, b, &self.vertices, |p| self.contains(p))
    }

    /// Distance from `p` to the nearest boundary edge, metres.
    pub fn boundary_distance(&self, p: Point) -> f64 {
        distance_to_polygon_boundary(p, &self.vertices)
    }
}
