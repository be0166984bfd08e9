//! Plane geometry in ENU metres for the simulator: the workspace's one implementation in the
//! `geom` crate, re-exported here (with the simulator's historical names) so that
//! `sim::geometry::*` paths keep working, plus the one helper only the simulator needs.
//!
//! Points are `[east_m, north_m]`. Polygon predicates follow `geom`'s closed boundary rule:
//! a point on the fly-zone boundary is inside.

pub use geom::*;

/// A point or vector in the ENU plane, metres (the planner's `Point`).
pub type P2 = geom::Point;

/// Unit vector of `a`; a (near) zero vector stays zero (the simulator's `unit`; `geom::unit`
/// answers an `Option` instead).
pub use geom::unit_or_zero as unit;

/// `a` rotated by +90 degrees (to the left); the simulator's name for `geom::perp`.
pub use geom::perp as perp_left;

/// Distance from `p` to the segment `a-b`; the simulator's name for `geom::dist_point_segment`.
pub use geom::dist_point_segment as point_segment_distance;

/// The first two coordinates of a 3-D point.
#[inline]
pub fn xy(p: [f64; 3]) -> P2 {
    [p[0], p[1]]
}
