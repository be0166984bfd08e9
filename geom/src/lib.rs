//! Plane geometry in local ENU metres, once for the whole workspace: vector algebra, angle
//! wrapping, point-segment distance, segment and circle intersection, and polygons (the fly
//! zone) with a closed boundary rule.
//!
//! `predictor`, `planner` and `sim` all use these; `planner::geometry` and `sim::geometry`
//! re-export them under their historical names.
//!
//! ```
//! use geom::{Polygon, dist_point_segment};
//!
//! // A leg from one fly-zone vertex to another along an edge is inside the zone.
//! let zone = Polygon::new(&[[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]]);
//! assert!(zone.contains_segment([0.0, 0.0], [100.0, 0.0]));
//! assert!(!zone.contains_segment([50.0, 50.0], [150.0, 50.0]));
//! assert_eq!(dist_point_segment([5.0, 3.0], [0.0, 0.0], [10.0, 0.0]), 3.0);
//! ```
//!
//! # Units
//! Points are `[east_m, north_m]`; angles are radians.

#![warn(missing_docs)]

/// Angle wrapping.
pub mod angle;
pub use angle::{arc_over_chord, wrap_pi};

/// Where a line or a ray meets a circle.
pub mod circle;
pub use circle::{line_circle_params, ray_circle};

/// Polygons with a closed boundary: the prepared [`Polygon`] and the same predicates on a
/// bare vertex ring.
pub mod polygon;
pub use polygon::{
    BOUNDARY_TOLERANCE_M, Polygon, distance_to_polygon_boundary, point_in_polygon,
    segment_inside_polygon,
};

/// Point-segment distance, closest parameter and segment intersection.
pub mod segment;
pub use segment::{closest_t_on_segment, dist_point_segment, segments_intersect};

/// Vector algebra on `[east_m, north_m]` arrays.
pub mod vector;
pub use vector::{
    Point, add, cross, dist, dot, lerp, norm, perp, polyline_length, scale, sub, turn_angle_rad,
    unit, unit_or_zero,
};
