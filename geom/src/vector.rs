//!
//! Written with vectors, never slopes, so that vertical and horizontal legs are the same
//! case (seed 004's insertion steps rely on this).

/// A point or vector in the local ENU plane, `[east_m, north_m]`.
pub type Point = [f64; 2];

/// `a + b`, metres.
#[inline]
pub fn add(a: Point, b: Point) -> Point {
    [a[0] + b[0], a[1] + b[1]]
}

/// `a - b`, metres.
#[inline]
pub fn sub(a: Point, b: Point) -> Point {
    [a[0] - b[0], a[1] - b[1]]
}

/// `k * a` (`k` dimensionless).
#[inline]
pub fn scale(a: Point, k: f64) -> Point {
    [a[0] * k, a[1] * k]
}

/// Dot product, square metres.
#[inline]
pub fn dot(a: Point, b: Point) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// z component of the 3-D cross product, square metres (positive when `b` is
/// counter-clockwise of `a`).
#[inline]
pub fn cross(a: Point, b: Point) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Euclidean length, metres.
///
/// `sqrt(x^2 + y^2)`, not `hypot`: libm's `hypot` guards against overflow with a slow
/// path that cost a fifth of a replan (the planner reads distances millions of times a
/// second), and local ENU coordinates (at most a few hundred kilometres) are nowhere near
/// overflowing a square.
#[inline]
pub fn norm(a: Point) -> f64 {
    (a[0] * a[0] + a[1] * a[1]).sqrt()
}

/// Distance between two points, metres.
#[inline]
pub fn dist(a: Point, b: Point) -> f64 {
    norm(sub(a, b))
}

/// `a + (b - a) * f`: the point at fraction `f` of the way from `a` to `b`.
#[inline]
pub fn lerp(a: Point, b: Point, f: f64) -> Point {
    [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f]
}

/// `a` rotated +90 degrees (counter-clockwise): the left normal of a direction.
#[inline]
pub fn perp(a: Point) -> Point {
    [-a[1], a[0]]
}

/// Unit vector of `a`, or `None` for a vector shorter than 1e-12 m.
#[inline]
pub fn unit(a: Point) -> Option<Point> {
    let n = norm(a);
    (n > 1e-12).then(|| scale(a, 1.0 / n))
}

/// Unit vector of `a`, or the zero vector for a (near) zero `a` (see [`unit()`]).
#[inline]
pub fn unit_or_zero(a: Point) -> Point {
    unit(a).unwrap_or([0.0, 0.0])
}

/// Turn angle in `[0, pi]` radians at vertex `b` of the path `a -> b -> c` (0 = straight
/// on; 0 when either leg is shorter than 1e-12 m).
pub fn turn_angle_rad(a: Point, b: Point, c: Point) -> f64 {
    let u = sub(b, a);
    let v = sub(c, b);
    let (nu, nv) = (norm(u), norm(v));
    if nu <= 1e-12 || nv <= 1e-12 {
        return 0.0;
    }
    (dot(u, v) / (nu * nv)).clamp(-1.0, 1.0).acos()
}

/// Length of a polyline, metres (0 for fewer than two points).
pub fn polyline_length(points: &[Point]) -> f64 {
    points.windows(2).map(|w| dist(w[0], w[1])).sum()
}
