//! Mission geometry in ENU metres: fly zones, stationary cylinders, mission waypoints and
//! the aircraft's performance (DESIGN.md "Planner", "Frames, units, time").
//!
//! A cylinder matters to a leg only when the leg's altitude is at or below the cylinder's
//! top; a leg between two altitudes is taken at the lower one (conservative: the aircraft
//! holds a constant altitude on a leg, but which one depends on the autopilot).
//!
//! # Units
//! Positions `[east_m, north_m]` in the mission's ENU frame, altitudes metres MSL, speeds
//! m/s, turn radius metres.

use crate::geometry::{Point, Polygon, dist, dist_point_segment};

/// One fly-zone polygon with its altitude band. Non-convex polygons are fine.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FlyZone {
    /// Boundary vertices, ENU metres, open or closed ring.
    pub boundary_m: Vec<Point>,
    /// Lowest allowed altitude, metres MSL (informational: the planner never changes
    /// altitude).
    pub alt_min_m: f64,
    /// Highest allowed altitude, metres MSL (informational).
    pub alt_max_m: f64,
}

/// A stationary obstacle: an infinite-downward cylinder with a top.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Cylinder {
    /// Centre, ENU metres.
    pub center_m: Point,
    /// Radius, metres.
    pub radius_m: f64,
    /// Top, metres MSL. The cylinder matters for legs at or below it.
    pub top_m: f64,
}

impl Cylinder {
    /// Whether a leg flown at `alt_m` must avoid this cylinder.
    #[inline]
    pub fn matters_at(&self, alt_m: f64) -> bool {
        alt_m <= self.top_m
    }
}

/// A mission waypoint. Mission waypoints are never moved by the planner.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Waypoint {
    /// Position, ENU metres.
    pub p_m: Point,
    /// Altitude, metres MSL.
    pub alt_m: f64,
}

/// The mission as the planner sees it.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Mission {
    /// Fly zones; a point is inside when it is inside any of them. Empty = unbounded.
    pub fly_zones: Vec<FlyZone>,
    /// Stationary obstacles.
    pub cylinders: Vec<Cylinder>,
    /// Mission waypoints in flight order.
    pub waypoints: Vec<Waypoint>,
}

/// Aircraft performance: constant speed and a minimum turn radius.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Aircraft {
    /// Cruise speed, m/s.
    pub speed_mps: f64,
    /// Minimum turn radius, metres.
    pub turn_radius_m: f64,
}

impl Aircraft {
    /// The speed a route is timed with: the aircraft's measured ground speed
    /// (`reported_mps`) when it is a positive number, else the cruise speed.
    pub fn route_speed_mps(&self, reported_mps: f64) -> f64 {
        if reported_mps > 0.0 && reported_mps.is_finite() {
            reported_mps
        } else {
            self.speed_mps
        }
    }
}

impl Default for Aircraft {
    /// 20 m/s (~39 kt) and a 40 m turn radius: a typical SUAS fixed wing.
    fn default() -> Self {
        Self {
            speed_mps: 20.0,
            turn_radius_m: 40.0,
        }
    }
}

/// The fly zones prepared for fast queries.
#[derive(Debug, Clone, Default)]
pub struct Zones {
    polygons: Vec<Polygon>,
}

impl Zones {
    /// Prepares the fly zones of a mission.
    pub fn new(zones: &[FlyZone]) -> Self {
        Self {
            polygons: zones.iter().map(|z| Polygon::new(&z.boundary_m)).collect(),
        }
    }

    /// Prepares a single boundary (e.g. the optional fly zone of an insertion request).
    pub fn single(boundary_m: &[Point]) -> Self {
        Self {
            polygons: vec![Polygon::new(boundary_m)],
        }
    }

    /// True when there is no fly zone (everything is allowed).
    pub fn is_unbounded(&self) -> bool {
        self.polygons.is_empty()
    }

    /// Whether `p` is inside some fly zone (always true when unbounded).
    pub fn contains(&self, p: Point) -> bool {
        self.polygons.is_empty() || self.polygons.iter().any(|z| z.contains(p))
    }

    /// Whether the whole segment lies inside one fly zone (always true when unbounded).
    pub fn contains_segment(&self, a: Point, b: Point) -> bool {
        self.polygons.is_empty() || self.polygons.iter().any(|z| z.contains_segment(a, b))
    }

    /// The prepared polygons.
    pub fn polygons(&self) -> &[Polygon] {
        &self.polygons
    }
}

/// Index of the first cylinder (at `alt_m`) whose radius grown by `buffer_m(radius)`
/// the segment enters, ordered by where along the segment it is met, or `None`.
pub fn first_blocking_cylinder(
    cylinders: &[Cylinder],
    a: Point,
    b: Point,
    alt_m: f64,
    buffer_fraction: f64,
) -> Option<usize> {
    let mut best: Option<(f64, usize)> = None;
    let l = dist(a, b);
    for (i, c) in cylinders.iter().enumerate() {
        if !c.matters_at(alt_m) {
            continue;
        }
        let rb = c.radius_m * (1.0 + buffer_fraction);
        if dist_point_segment(c.center_m, a, b) < rb - 1e-9 {
            let along = crate::geometry::closest_t_on_segment(c.center_m, a, b) * l;
            if best.is_none_or(|(d, _)| along < d) {
                best = Some((along, i));
            }
        }
    }
    best.map(|(_, i)| i)
}

/// Whether segment `a -> b` at `alt_m` stays out of every cylinder grown by
/// `buffer_fraction` of its radius.
pub fn segment_clear(
    cylinders: &[Cylinder],
    a: Point,
    b: Point,
    alt_m: f64,
    buffer_fraction: f64,
) -> bool {
    first_blocking_cylinder(cylinders, a, b, alt_m, buffer_fraction).is_none()
}

/// Index of a cylinder (at `alt_m`) containing `p`, if any.
pub fn cylinder_containing(cylinders: &[Cylinder], p: Point, alt_m: f64) -> Option<usize> {
    cylinders
        .iter()
        .position(|c| c.matters_at(alt_m) && dist(c.center_m, p) < c.radius_m)
}
