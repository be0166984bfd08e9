//! The judges' interoperability-server formats, as they were served, into jink's native
//! types: 2017/2018 JSON (`/api/missions`, `/api/obstacles`, form-encoded telemetry) and
//! 2019+ protobuf-JSON (lowerCamelCase, or snake_case as the server also accepted).
//!
//! # Units
//! Interop data is in feet MSL and knots; everything leaving this module is metres and m/s.
//! Unknown extra fields are ignored.

use serde::Deserialize;
use serde_json::Value;

use crate::error::{WireError, from_value};
use crate::mission::{
    FieldNames, FlyZone, Home, LatLon, MissionInput, MovingObstacleInfo, SourceFormat,
    StationaryObstacle, Waypoint,
};

/// Metres per international foot.
pub const M_PER_FT: f64 = 0.3048;
/// Metres per second per knot.
pub const MPS_PER_KT: f64 = 0.514444;

/// Feet to metres.
pub fn ft(v: f64) -> f64 {
    v * M_PER_FT
}

/// Guesses the format of a mission document (an object, or a list of objects).
pub fn detect_mission_format(v: &Value) -> SourceFormat {
    let obj = match v {
        Value::Array(items) => match items.first() {
            Some(first) => return detect_mission_format(first),
            None => return SourceFormat::Native,
        },
        Value::Object(o) => o,
        _ => return SourceFormat::Native,
    };
    let has = |k: &str| obj.contains_key(k);
    if has("flyZones")
        || has("stationaryObstacles")
        || has("searchGridPoints")
        || has("lostCommsPos")
    {
        return SourceFormat::Interop2019;
    }
    if has("mission_waypoints") || has("home_pos") || has("search_grid_points") && !has("waypoints")
    {
        return SourceFormat::Interop2018;
    }
    let zone_has = |k: &str| {
        obj.get("fly_zones")
            .and_then(Value::as_array)
            .and_then(|z| z.first())
            .and_then(Value::as_object)
            .is_some_and(|z| z.contains_key(k))
    };
    if zone_has("boundary_pts") || zone_has("altitude_msl_min") {
        return SourceFormat::Interop2018;
    }
    if zone_has("boundary_points") || zone_has("altitude_min") {
        return SourceFormat::Interop2019;
    }
    SourceFormat::Native
}

/// Parses a mission upload: one mission object, or a list of them (the 2018
/// `GET /api/missions` answer).
///
/// # Errors
/// A 400 naming the field that does not parse.
pub fn parse_missions(
    v: Value,
    format: SourceFormat,
) -> Result<Vec<(MissionInput, FieldNames)>, WireError> {
    match v {
        Value::Array(items) => {
            if items.is_empty() {
                return Err(WireError::field("", "the list of missions is empty"));
            }
            let mut out = Vec::with_capacity(items.len());
            for (i, item) in items.into_iter().enumerate() {
                let (m, mut names) = parse_one(item, format).map_err(|e| prefix_error(e, i))?;
                names.prefix = format!("/{i}{}", names.prefix);
                out.push((m, names));
            }
            Ok(out)
        }
        Value::Object(_) => Ok(vec![parse_one(v, format)?]),
        _ => Err(WireError::BadRequest {
            detail: "a mission must be a JSON object (or a list of them)".into(),
            pointer: Some(String::new()),
        }),
    }
}

fn prefix_error(e: WireError, i: usize) -> WireError {
    match e {
        WireError::BadRequest { detail, pointer } => WireError::BadRequest {
            detail: format!("/{i}{detail}"),
            pointer: pointer.map(|p| format!("/{i}{p}")),
        },
        other => other,
    }
}

fn parse_one(v: Value, format: SourceFormat) -> Result<(MissionInput, FieldNames), WireError> {
    match format {
        SourceFormat::Native => {
            let m: MissionInput = from_value(v)?;
            let names = FieldNames::native();
            Ok((m, names))
        }
        SourceFormat::Interop2018 => from_value::<Mission2018>(v).map(Mission2018::into_native),
        SourceFormat::Interop2019 => from_value::<Mission2019>(v).map(Mission2019::into_native),
    }
}

// ---- both interop generations: the judges' values (feet) as native ones ----------------

fn lat_lon(lat: f64, lon: f64) -> LatLon {
    LatLon { lat, lon }
}

/// A home without altitude (the interop documents give none).
fn home(lat: f64, lon: f64) -> Home {
    Home {
        lat,
        lon,
        alt_msl_m: None,
    }
}

/// A waypoint at `alt_ft` feet MSL; a missing altitude becomes NaN, which validation names.
fn waypoint_ft(lat: f64, lon: f64, alt_ft: Option<f64>) -> Waypoint {
    Waypoint {
        lat,
        lon,
        alt_msl_m: ft(alt_ft.unwrap_or(f64::NAN)),
    }
}

/// The `i`th stationary cylinder (its id is its index in the list), radius and top in feet.
fn cylinder_ft(i: usize, lat: f64, lon: f64, radius_ft: f64, top_ft: f64) -> StationaryObstacle {
    StationaryObstacle {
        id: i.to_string().into(),
        lat,
        lon,
        radius_m: ft(radius_ft),
        top_msl_m: ft(top_ft),
    }
}

// ---- 2017/2018 -------------------------------------------------------------------------

#[derive(Deserialize)]
struct Pos2018 {
    latitude: f64,
    longitude: f64,
}

#[derive(Deserialize)]
struct OrderedPos2018 {
    latitude: f64,
    longitude: f64,
    #[serde(default)]
    altitude_msl: Option<f64>,
    #[serde(default)]
    order: Option<i64>,
}

#[derive(Deserialize)]
struct FlyZone2018 {
    boundary_pts: Vec<OrderedPos2018>,
    altitude_msl_min: f64,
    altitude_msl_max: f64,
}

#[derive(Deserialize)]
struct Cylinder2018 {
    latitude: f64,
    longitude: f64,
    cylinder_radius: f64,
    cylinder_height: f64,
}

#[derive(Deserialize)]
struct Moving2018 {
    sphere_radius: f64,
    #[serde(default)]
    speed_avg: Option<f64>,
}

#[derive(Deserialize)]
struct Mission2018 {
    #[serde(default)]
    id: Option<i64>,
    #[serde(default)]
    fly_zones: Vec<FlyZone2018>,
    #[serde(default)]
    home_pos: Option<Pos2018>,
    #[serde(default)]
    mission_waypoints: Vec<OrderedPos2018>,
    #[serde(default)]
    search_grid_points: Vec<OrderedPos2018>,
    #[serde(default)]
    stationary_obstacles: Vec<Cylinder2018>,
    #[serde(default)]
    moving_obstacles: Vec<Moving2018>,
}

/// Sorts by `order` (stable; missing orders keep document order) and returns the
/// document index of each sorted item.
fn sort_by_order(items: &[OrderedPos2018]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..items.len()).collect();
    idx.sort_by_key(|&i| items[i].order.unwrap_or(i as i64));
    idx
}

impl Mission2018 {
    fn into_native(self) -> (MissionInput, FieldNames) {
        let zone_src: Vec<Vec<usize>> = self
            .fly_zones
            .iter()
            .map(|z| sort_by_order(&z.boundary_pts))
            .collect();
        let wp_src = sort_by_order(&self.mission_waypoints);
        let grid_src = sort_by_order(&self.search_grid_points);
        let fly_zones = self
            .fly_zones
            .iter()
            .zip(&zone_src)
            .map(|(z, src)| FlyZone {
                boundary: src
                    .iter()
                    .map(|&i| lat_lon(z.boundary_pts[i].latitude, z.boundary_pts[i].longitude))
                    .collect(),
                alt_min_msl_m: ft(z.altitude_msl_min),
                alt_max_msl_m: ft(z.altitude_msl_max),
            })
            .collect();
        let waypoints = wp_src
            .iter()
            .map(|&i| {
                let w = &self.mission_waypoints[i];
                waypoint_ft(w.latitude, w.longitude, w.altitude_msl)
            })
            .collect();
        let m = MissionInput {
            name: None,
            home: self.home_pos.map(|h| home(h.latitude, h.longitude)),
            fly_zones,
            waypoints,
            search_grid: grid_src
                .iter()
                .map(|&i| {
                    let p = &self.search_grid_points[i];
                    lat_lon(p.latitude, p.longitude)
                })
                .collect(),
            stationary_obstacles: self
                .stationary_obstacles
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    cylinder_ft(
                        i,
                        c.latitude,
                        c.longitude,
                        c.cylinder_radius,
                        c.cylinder_height,
                    )
                })
                .collect(),
            moving_obstacles: self
                .moving_obstacles
                .iter()
                .enumerate()
                .map(|(i, o)| MovingObstacleInfo {
                    id: i.to_string().into(),
                    radius_m: ft(o.sphere_radius),
                    speed_avg_mps: o.speed_avg.map(|kt| kt * MPS_PER_KT),
                })
                .collect(),
            interop_id: self.id,
        };
        let names = FieldNames {
            fly_zones: "fly_zones",
            boundary: "boundary_pts",
            alt_min: "altitude_msl_min",
            alt_max: "altitude_msl_max",
            waypoints: "mission_waypoints",
            wp_alt: "altitude_msl",
            search_grid: "search_grid_points",
            stationary: "stationary_obstacles",
            radius: "cylinder_radius",
            top: "cylinder_height",
            home: "home_pos",
            lat: "latitude",
            lon: "longitude",
            fly_zone_points_src: zone_src,
            waypoint_src: wp_src,
            prefix: String::new(),
        };
        (m, names)
    }
}

// ---- 2019+ protobuf-JSON ---------------------------------------------------------------

#[derive(Deserialize)]
struct Pos2019 {
    latitude: f64,
    longitude: f64,
    #[serde(default)]
    altitude: Option<f64>,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct FlyZone2019 {
    #[serde(alias = "boundary_points")]
    boundary_points: Vec<Pos2019>,
    #[serde(alias = "altitude_min")]
    altitude_min: f64,
    #[serde(alias = "altitude_max")]
    altitude_max: f64,
}

#[derive(Deserialize)]
struct Cylinder2019 {
    latitude: f64,
    longitude: f64,
    radius: f64,
    height: f64,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Mission2019 {
    #[serde(default)]
    id: Option<i64>,
    #[serde(default, alias = "fly_zones")]
    fly_zones: Vec<FlyZone2019>,
    #[serde(default)]
    waypoints: Vec<Pos2019>,
    #[serde(default, alias = "search_grid_points")]
    search_grid_points: Vec<Pos2019>,
    #[serde(default, alias = "stationary_obstacles")]
    stationary_obstacles: Vec<Cylinder2019>,
    #[serde(default, alias = "lost_comms_pos")]
    lost_comms_pos: Option<Pos2019>,
}

impl Mission2019 {
    fn into_native(self) -> (MissionInput, FieldNames) {
        // Which spelling did the client use? Point errors at that one.
        let m = MissionInput {
            name: None,
            // The 2019+ missions carry no home; the lost-comms position is where the
            // aircraft returns to, the nearest thing to a home. Else the first vertex.
            home: self
                .lost_comms_pos
                .as_ref()
                .map(|p| home(p.latitude, p.longitude)),
            fly_zones: self
                .fly_zones
                .iter()
                .map(|z| FlyZone {
                    boundary: z
                        .boundary_points
                        .iter()
                        .map(|p| lat_lon(p.latitude, p.longitude))
                        .collect(),
                    alt_min_msl_m: ft(z.altitude_min),
                    alt_max_msl_m: ft(z.altitude_max),
                })
                .collect(),
            waypoints: self
                .waypoints
                .iter()
                .map(|w| waypoint_ft(w.latitude, w.longitude, w.altitude))
                .collect(),
            search_grid: self
                .search_grid_points
                .iter()
                .map(|p| lat_lon(p.latitude, p.longitude))
                .collect(),
            stationary_obstacles: self
                .stationary_obstacles
                .iter()
                .enumerate()
                .map(|(i, c)| cylinder_ft(i, c.latitude, c.longitude, c.radius, c.height))
                .collect(),
            moving_obstacles: vec![],
            interop_id: self.id,
        };
        let names = FieldNames {
            fly_zones: "flyZones",
            boundary: "boundaryPoints",
            alt_min: "altitudeMin",
            alt_max: "altitudeMax",
            waypoints: "waypoints",
            wp_alt: "altitude",
            search_grid: "searchGridPoints",
            stationary: "stationaryObstacles",
            radius: "radius",
            top: "height",
            home: "lostCommsPos",
            lat: "latitude",
            lon: "longitude",
            fly_zone_points_src: Vec::new(),
            waypoint_src: Vec::new(),
            prefix: String::new(),
        };
        (m, names)
    }
}

/// Rewrites camelCase field names to snake_case for a client that sent snake_case 2019
/// keys, so error pointers match their document.
pub fn snake_names(mut n: FieldNames) -> FieldNames {
    n.fly_zones = "fly_zones";
    n.boundary = "boundary_points";
    n.alt_min = "altitude_min";
    n.alt_max = "altitude_max";
    n.search_grid = "search_grid_points";
    n.stationary = "stationary_obstacles";
    n.home = "lost_comms_pos";
    n
}

/// True when a 2019 document uses snake_case keys.
pub fn uses_snake_case(v: &Value) -> bool {
    let obj = match v {
        Value::Array(a) => a.first().and_then(Value::as_object),
        Value::Object(o) => Some(o),
        _ => None,
    };
    obj.is_some_and(|o| o.contains_key("fly_zones") || o.contains_key("stationary_obstacles"))
}

// ---- telemetry and obstacle snapshots --------------------------------------------------

/// An interop 2017/2018 `GET /api/obstacles` snapshot.
#[derive(Debug, Deserialize)]
pub struct ObstacleSnapshot2018 {
    /// Moving obstacles; each one's id is its index in this list.
    #[serde(default)]
    pub moving_obstacles: Vec<MovingSnapshot2018>,
    /// Stationary obstacles (already known from the mission; counted, not stored).
    #[serde(default)]
    pub stationary_obstacles: Vec<serde_json::Value>,
    /// When the snapshot was taken (RFC 3339 or Unix seconds); else `?time=`, else receipt.
    #[serde(default)]
    pub time: Option<crate::time::WireTime>,
}

/// One moving obstacle in a 2018 snapshot.
#[derive(Debug, Deserialize)]
pub struct MovingSnapshot2018 {
    /// Latitude, degrees.
    pub latitude: f64,
    /// Longitude, degrees.
    pub longitude: f64,
    /// Altitude, feet MSL.
    pub altitude_msl: f64,
    /// Sphere radius, feet.
    pub sphere_radius: f64,
}

/// Interop 2017/2018 aircraft telemetry (form-encoded).
#[derive(Debug, Deserialize)]
pub struct Telemetry2018 {
    /// Latitude, degrees.
    pub latitude: f64,
    /// Longitude, degrees.
    pub longitude: f64,
    /// Altitude, feet MSL.
    pub altitude_msl: f64,
    /// Heading, degrees true, [0, 360).
    pub uas_heading: f64,
}

/// Interop 2019+ aircraft telemetry (protobuf-JSON).
#[derive(Debug, Deserialize)]
pub struct Telemetry2019 {
    /// Latitude, degrees.
    pub latitude: f64,
    /// Longitude, degrees.
    pub longitude: f64,
    /// Altitude, feet MSL.
    pub altitude: f64,
    /// Heading, degrees true.
    pub heading: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> Value {
        serde_json::from_str(&crate::fixture_text(name)).unwrap()
    }

    #[test]
    fn each_fixture_is_detected_as_its_format() {
        for (name, format) in [
            ("mission_2018.json", SourceFormat::Interop2018),
            ("missions_list_2018_fixture.json", SourceFormat::Interop2018),
            ("mission_2019.json", SourceFormat::Interop2019),
            ("mission_2021_webster_field.json", SourceFormat::Interop2019),
        ] {
            assert_eq!(detect_mission_format(&fixture(name)), format, "{name}");
        }
    }

    #[test]
    fn feet_become_metres() {
        let v = fixture("mission_2019.json");
        let (m, _) = parse_missions(v, SourceFormat::Interop2019)
            .unwrap()
            .remove(0);
        assert!((m.waypoints[0].alt_msl_m - 60.96).abs() < 1e-9);
        assert!((m.stationary_obstacles[0].top_msl_m - 60.96).abs() < 1e-9);
        assert!((m.stationary_obstacles[0].radius_m - 45.72).abs() < 1e-9);
        assert!((m.fly_zones[0].alt_max_msl_m - 228.6).abs() < 1e-9);
    }

    #[test]
    fn snake_case_2019_keys_parse_like_camel_case() {
        let snake = serde_json::json!({
            "fly_zones": [{"altitude_min": 100.0, "altitude_max": 750.0, "boundary_points": [
                {"latitude": 38.0, "longitude": -76.0}, {"latitude": 38.01, "longitude": -76.0},
                {"latitude": 38.01, "longitude": -75.99}]}],
            "waypoints": [{"latitude": 38.005, "longitude": -75.999, "altitude": 200.0}],
            "stationary_obstacles": [{"latitude": 38.0, "longitude": -76.0, "radius": 50.0, "height": 300.0}]
        });
        assert_eq!(detect_mission_format(&snake), SourceFormat::Interop2019);
        let (m, _) = parse_missions(snake, SourceFormat::Interop2019)
            .unwrap()
            .remove(0);
        assert_eq!(m.fly_zones[0].boundary.len(), 3);
        assert!((m.stationary_obstacles[0].top_msl_m - 91.44).abs() < 1e-9);
    }

    #[test]
    fn order_fields_sort_2018_points() {
        let v = serde_json::json!({
            "fly_zones": [{"altitude_msl_min": 100.0, "altitude_msl_max": 750.0, "boundary_pts": [
                {"latitude": 3.0, "longitude": 0.0, "order": 3},
                {"latitude": 1.0, "longitude": 0.0, "order": 1},
                {"latitude": 2.0, "longitude": 0.0, "order": 2}]}],
            "mission_waypoints": []
        });
        let (m, names) = parse_missions(v, SourceFormat::Interop2018)
            .unwrap()
            .remove(0);
        let lats: Vec<f64> = m.fly_zones[0].boundary.iter().map(|p| p.lat).collect();
        assert_eq!(lats, vec![1.0, 2.0, 3.0]);
        assert_eq!(names.fly_zone_points_src[0], vec![1, 2, 0]);
    }
}
