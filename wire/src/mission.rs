//! Missions: the native wire form, the stored domain form, validation, and the local
//! ENU frame a mission defines.
//!
//! # Units
//! Degrees for latitude/longitude, metres MSL for altitudes, metres for radii, m/s for
//! speeds. The interop adapters (`crate::interop`) convert feet and knots on the way in.

use serde::{Deserialize, Serialize};

use crate::error::FieldError;
use crate::geodesy::LocalFrame;

/// A position on the earth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LatLon {
    /// Latitude, degrees, in [-90, 90].
    #[cfg_attr(feature = "openapi", schema(minimum = -90.0, maximum = 90.0))]
    pub lat: f64,
    /// Longitude, degrees, in [-180, 180].
    #[cfg_attr(feature = "openapi", schema(minimum = -180.0, maximum = 180.0))]
    pub lon: f64,
}

/// A position with an optional altitude (the home position).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Home {
    /// Latitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -90.0, maximum = 90.0))]
    pub lat: f64,
    /// Longitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -180.0, maximum = 180.0))]
    pub lon: f64,
    /// Ground altitude at home, metres MSL, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alt_msl_m: Option<f64>,
}

/// A fly zone: a polygon the aircraft must stay inside, with an altitude band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FlyZone {
    /// The boundary, in order, not closed (at least 3 points, not self-intersecting).
    pub boundary: Vec<LatLon>,
    /// Lowest allowed altitude, metres MSL.
    pub alt_min_msl_m: f64,
    /// Highest allowed altitude, metres MSL.
    pub alt_max_msl_m: f64,
}

/// A mission waypoint, flown in order.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Waypoint {
    /// Latitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -90.0, maximum = 90.0))]
    pub lat: f64,
    /// Longitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -180.0, maximum = 180.0))]
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
}

/// A stationary obstacle: a cylinder from the ground up to `top_msl_m`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StationaryObstacle {
    /// The obstacle's id (its index in the mission when not given).
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub id: crate::ids::ObstacleId,
    /// Centre latitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -90.0, maximum = 90.0))]
    pub lat: f64,
    /// Centre longitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -180.0, maximum = 180.0))]
    pub lon: f64,
    /// Radius, metres (> 0).
    pub radius_m: f64,
    /// Top of the cylinder, metres MSL (the interop `height`).
    pub top_msl_m: f64,
}

/// What the mission says of a moving obstacle before any telemetry (interop 2018 lists).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MovingObstacleInfo {
    /// The obstacle id telemetry will use (its index in the list).
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub id: crate::ids::ObstacleId,
    /// Sphere radius, metres.
    pub radius_m: f64,
    /// Average speed, m/s, when the judges published it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_avg_mps: Option<f64>,
}

/// The format a mission was uploaded in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum SourceFormat {
    /// jink's own JSON.
    #[serde(rename = "native")]
    Native,
    /// Interop server 2017/2018 JSON (feet, `order` fields).
    #[serde(rename = "interop-2018")]
    Interop2018,
    /// Interop server 2019+ protobuf-JSON (feet, camelCase or snake_case keys).
    #[serde(rename = "interop-2019")]
    Interop2019,
}

impl SourceFormat {
    /// The name used in `?format=` and in stored missions.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Native => "native",
            Self::Interop2018 => "interop-2018",
            Self::Interop2019 => "interop-2019",
        }
    }
}

/// A mission as uploaded in native form (also what the interop adapters produce).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MissionInput {
    /// A name for people.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Home / launch position; the local frame's origin. Defaults to the first fly-zone
    /// vertex.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub home: Option<Home>,
    /// Fly zones (at least one).
    pub fly_zones: Vec<FlyZone>,
    /// Mission waypoints in flight order.
    #[serde(default)]
    pub waypoints: Vec<Waypoint>,
    /// The search-area polygon.
    #[serde(default)]
    pub search_grid: Vec<LatLon>,
    /// Stationary cylinders.
    #[serde(default)]
    pub stationary_obstacles: Vec<StationaryObstacle>,
    /// Moving obstacles announced by the mission (optional; telemetry also creates them).
    #[serde(default)]
    pub moving_obstacles: Vec<MovingObstacleInfo>,
    /// The interop server's mission id, when the mission came from it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interop_id: Option<i64>,
}

/// A stored mission, as every GET returns it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Mission {
    /// The mission id.
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub id: crate::ids::MissionId,
    /// The upload format it came in.
    pub source_format: SourceFormat,
    /// When it was stored (RFC 3339).
    pub created_at: String,
    /// Home position; the local frame's origin (defaults to the first fly-zone vertex).
    pub home: Home,
    /// The mission content (its `home` is always moved to the field above).
    #[serde(flatten)]
    pub content: MissionInput,
}

impl Mission {
    /// The mission's local ENU frame.
    pub fn frame(&self) -> LocalFrame {
        LocalFrame::new(self.home.lat, self.home.lon)
    }
}

/// How the fields of the uploaded document are named, so that a validation error points
/// at the field as the client sent it.
#[derive(Debug, Clone)]
pub struct FieldNames {
    /// Key of the fly-zone list.
    pub fly_zones: &'static str,
    /// Key of a fly zone's boundary list.
    pub boundary: &'static str,
    /// Keys of a fly zone's altitude band.
    pub alt_min: &'static str,
    /// Key of the fly zone's maximum altitude.
    pub alt_max: &'static str,
    /// Key of the waypoint list.
    pub waypoints: &'static str,
    /// Key of a waypoint's altitude.
    pub wp_alt: &'static str,
    /// Key of the search grid.
    pub search_grid: &'static str,
    /// Key of the stationary-obstacle list.
    pub stationary: &'static str,
    /// Key of a cylinder's radius.
    pub radius: &'static str,
    /// Key of a cylinder's top.
    pub top: &'static str,
    /// Key of the home position.
    pub home: &'static str,
    /// Keys of latitude and longitude.
    pub lat: &'static str,
    /// Longitude key.
    pub lon: &'static str,
    /// Document index of each sorted item (interop 2018 sorts by `order`): `[list][i]`;
    /// an item not listed (all of them when empty) stands at its own index.
    pub fly_zone_points_src: Vec<Vec<usize>>,
    /// Document index of each waypoint (as `fly_zone_points_src`).
    pub waypoint_src: Vec<usize>,
    /// Prefix when the document is one item of a list (`/0`).
    pub prefix: String,
}

impl FieldNames {
    /// Native field names, items in document order.
    pub fn native() -> Self {
        Self {
            fly_zones: "fly_zones",
            boundary: "boundary",
            alt_min: "alt_min_msl_m",
            alt_max: "alt_max_msl_m",
            waypoints: "waypoints",
            wp_alt: "alt_msl_m",
            search_grid: "search_grid",
            stationary: "stationary_obstacles",
            radius: "radius_m",
            top: "top_msl_m",
            home: "home",
            lat: "lat",
            lon: "lon",
            fly_zone_points_src: Vec::new(),
            waypoint_src: Vec::new(),
            prefix: String::new(),
        }
    }

    fn fz(&self, i: usize) -> String {
        format!("{}/{}/{i}", self.prefix, self.fly_zones)
    }
    fn fz_pt(&self, i: usize, j: usize) -> String {
        let src = self
            .fly_zone_points_src
            .get(i)
            .and_then(|v| v.get(j))
            .copied()
            .unwrap_or(j);
        format!("{}/{}", self.fz(i), format_args!("{}/{src}", self.boundary))
    }
    fn wp(&self, i: usize) -> String {
        let src = self.waypoint_src.get(i).copied().unwrap_or(i);
        format!("{}/{}/{src}", self.prefix, self.waypoints)
    }
}

/// Distance, metres, within which a point just outside a fly-zone edge still counts as
/// inside: interop missions put waypoints exactly on boundary vertices, and the round trip
/// through ENU must not reject them.
pub const BOUNDARY_TOLERANCE_M: f64 = 0.5;
/// Altitude tolerance, metres, for the altitude band (feet-to-metre rounding).
pub const ALTITUDE_TOLERANCE_M: f64 = 1e-6;

fn check_lat_lon(errs: &mut Vec<FieldError>, at: &str, n: &FieldNames, lat: f64, lon: f64) {
    let (lat_ptr, lon_ptr) = (format!("{at}/{}", n.lat), format!("{at}/{}", n.lon));
    crate::coords::check_lat_lon(errs, &lat_ptr, &lon_ptr, lat, lon);
}

fn finite(errs: &mut Vec<FieldError>, at: String, what: &str, v: f64) -> bool {
    if v.is_finite() {
        true
    } else {
        errs.push(FieldError::new(
            at,
            format!("{what} must be a finite number"),
        ));
        false
    }
}

/// Validates a mission and fills in defaults (home, obstacle ids).
///
/// # Errors
/// Every invalid field, each with a JSON pointer in the client's own field names.
pub fn validate(
    mut m: MissionInput,
    n: &FieldNames,
) -> Result<(MissionInput, Home), Vec<FieldError>> {
    let mut errs = Vec::new();
    let p = &n.prefix;

    if m.fly_zones.is_empty() {
        errs.push(FieldError::new(
            format!("{p}/{}", n.fly_zones),
            "at least one fly zone is required",
        ));
    }
    for (i, z) in m.fly_zones.iter().enumerate() {
        for (j, pt) in z.boundary.iter().enumerate() {
            check_lat_lon(&mut errs, &n.fz_pt(i, j), n, pt.lat, pt.lon);
        }
        if z.boundary.len() < 3 {
            errs.push(FieldError::new(
                format!("{}/{}", n.fz(i), n.boundary),
                format!(
                    "a fly zone needs at least 3 boundary points, got {}",
                    z.boundary.len()
                ),
            ));
        }
        let ok_min = finite(
            &mut errs,
            format!("{}/{}", n.fz(i), n.alt_min),
            "altitude",
            z.alt_min_msl_m,
        );
        let ok_max = finite(
            &mut errs,
            format!("{}/{}", n.fz(i), n.alt_max),
            "altitude",
            z.alt_max_msl_m,
        );
        if ok_min && ok_max && z.alt_min_msl_m > z.alt_max_msl_m {
            errs.push(FieldError::new(
                format!("{}/{}", n.fz(i), n.alt_min),
                format!(
                    "minimum altitude {} m is above the maximum {} m",
                    z.alt_min_msl_m, z.alt_max_msl_m
                ),
            ));
        }
    }
    if let Some(h) = &m.home {
        check_lat_lon(&mut errs, &format!("{p}/{}", n.home), n, h.lat, h.lon);
    }
    for (i, w) in m.waypoints.iter().enumerate() {
        check_lat_lon(&mut errs, &n.wp(i), n, w.lat, w.lon);
        finite(
            &mut errs,
            format!("{}/{}", n.wp(i), n.wp_alt),
            "altitude",
            w.alt_msl_m,
        );
    }
    for (i, g) in m.search_grid.iter().enumerate() {
        check_lat_lon(
            &mut errs,
            &format!("{p}/{}/{i}", n.search_grid),
            n,
            g.lat,
            g.lon,
        );
    }
    for (i, c) in m.stationary_obstacles.iter().enumerate() {
        let at = format!("{p}/{}/{i}", n.stationary);
        check_lat_lon(&mut errs, &at, n, c.lat, c.lon);
        if !(c.radius_m.is_finite() && c.radius_m > 0.0) {
            errs.push(FieldError::new(
                format!("{at}/{}", n.radius),
                format!("a cylinder's radius must be positive, got {}", c.radius_m),
            ));
        }
        finite(
            &mut errs,
            format!("{at}/{}", n.top),
            "top altitude",
            c.top_msl_m,
        );
    }
    if !errs.is_empty() {
        return Err(errs);
    }

    // Geometry needs valid coordinates: checked above.
    let first = m.fly_zones[0].boundary[0];
    let home = m.home.unwrap_or(Home {
        lat: first.lat,
        lon: first.lon,
        alt_msl_m: None,
    });
    let frame = LocalFrame::new(home.lat, home.lon);
    let polys: Vec<geo::Polygon<f64>> = m
        .fly_zones
        .iter()
        .map(|z| {
            let ring: Vec<geo::Coord<f64>> = z
                .boundary
                .iter()
                .map(|pt| {
                    let [x, y] = frame.to_enu(pt.lat, pt.lon);
                    geo::Coord { x, y }
                })
                .collect();
            geo::Polygon::new(geo::LineString::new(ring), vec![])
        })
        .collect();
    for (i, poly) in polys.iter().enumerate() {
        use geo::algorithm::Validation;
        for problem in poly.validation_errors() {
            errs.push(FieldError::new(
                format!("{}/{}", n.fz(i), n.boundary),
                format!("the fly-zone boundary is not a simple polygon: {problem}"),
            ));
        }
    }
    if !errs.is_empty() {
        return Err(errs);
    }
    for (i, w) in m.waypoints.iter().enumerate() {
        let [x, y] = frame.to_enu(w.lat, w.lon);
        let pt = geo::Point::new(x, y);
        let inside: Vec<usize> = polys
            .iter()
            .enumerate()
            .filter(|(_, poly)| point_in_or_near(poly, pt))
            .map(|(k, _)| k)
            .collect();
        if inside.is_empty() {
            errs.push(FieldError::new(
                n.wp(i),
                "the waypoint is outside every fly zone",
            ));
            continue;
        }
        let in_band = inside.iter().any(|&k| {
            let z = &m.fly_zones[k];
            w.alt_msl_m >= z.alt_min_msl_m - ALTITUDE_TOLERANCE_M
                && w.alt_msl_m <= z.alt_max_msl_m + ALTITUDE_TOLERANCE_M
        });
        if !in_band {
            let z = &m.fly_zones[inside[0]];
            errs.push(FieldError::new(
                format!("{}/{}", n.wp(i), n.wp_alt),
                format!(
                    "altitude {} m MSL is outside the fly zone's band [{}, {}] m",
                    w.alt_msl_m, z.alt_min_msl_m, z.alt_max_msl_m
                ),
            ));
        }
    }
    if !errs.is_empty() {
        return Err(errs);
    }
    for (i, c) in m.stationary_obstacles.iter_mut().enumerate() {
        if c.id.is_empty() {
            c.id = i.to_string().into();
        }
    }
    // The resolved home lives in `Mission::home`; keep one copy.
    m.home = None;
    Ok((m, home))
}

fn point_in_or_near(poly: &geo::Polygon<f64>, pt: geo::Point<f64>) -> bool {
    use geo::{Distance, Euclidean, Intersects};
    poly.intersects(&pt) || Euclidean.distance(poly.exterior(), &pt) <= BOUNDARY_TOLERANCE_M
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> MissionInput {
        let b = |lat, lon| LatLon { lat, lon };
        MissionInput {
            name: None,
            home: None,
            fly_zones: vec![FlyZone {
                boundary: vec![
                    b(38.0, -76.0),
                    b(38.01, -76.0),
                    b(38.01, -75.99),
                    b(38.0, -75.99),
                ],
                alt_min_msl_m: 30.0,
                alt_max_msl_m: 200.0,
            }],
            waypoints: vec![Waypoint {
                lat: 38.005,
                lon: -75.995,
                alt_msl_m: 100.0,
            }],
            search_grid: vec![],
            stationary_obstacles: vec![],
            moving_obstacles: vec![],
            interop_id: None,
        }
    }

    fn errors(m: MissionInput) -> Vec<FieldError> {
        let n = FieldNames::native();
        validate(m, &n).unwrap_err()
    }

    #[test]
    fn a_valid_mission_gets_the_first_vertex_as_home() {
        let m = square();
        let n = FieldNames::native();
        let (_, home) = validate(m, &n).unwrap();
        assert_eq!((home.lat, home.lon), (38.0, -76.0));
    }

    #[test]
    fn a_bow_tie_fly_zone_is_rejected() {
        let mut m = square();
        m.fly_zones[0].boundary.swap(1, 2);
        let e = errors(m);
        assert_eq!(e[0].pointer, "/fly_zones/0/boundary");
        assert!(e[0].detail.contains("self-intersection"), "{}", e[0].detail);
    }

    #[test]
    fn a_waypoint_on_a_boundary_vertex_is_inside() {
        let mut m = square();
        m.waypoints[0] = Waypoint {
            lat: 38.01,
            lon: -75.99,
            alt_msl_m: 200.0,
        };
        let n = FieldNames::native();
        assert!(validate(m, &n).is_ok());
    }

    #[test]
    fn each_bad_field_is_named() {
        let mut m = square();
        m.waypoints.push(Waypoint {
            lat: 91.0,
            lon: 0.0,
            alt_msl_m: 100.0,
        });
        m.fly_zones[0].alt_min_msl_m = 300.0;
        let e = errors(m);
        let ptrs: Vec<_> = e.iter().map(|e| e.pointer.as_str()).collect();
        assert!(ptrs.contains(&"/waypoints/1/lat"), "{ptrs:?}");
        assert!(ptrs.contains(&"/fly_zones/0/alt_min_msl_m"), "{ptrs:?}");
    }
}
