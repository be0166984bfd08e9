//! The judges' interoperability-server formats, as they were served, into jink's native
//! types: 2017/2018 JSON (`/api/missions`, `/api/obstacles`, form-encoded telemetry) and
//! 2019+ protobuf-JSON (lowerCamelCase, or snake_case as the server also accepted).
//!
//! The other direction, [`render_mission_2018`], [`render_mission_2019`],
//! [`render_obstacles_2018`], [`render_telemetry_2019`] and [`render_telemetry_2018_form`],
//! writes jink's values back in the judges' formats, for the interop-compatible surface
//! (`/api/missions`, `/api/obstacles`) and for forwarding telemetry to the judges' server.
//!
//! # Units
//! Interop data is in feet MSL and knots; everything parsed from this module is metres and
//! m/s, everything rendered by it feet and knots again. Unknown extra fields are ignored.

use serde::Deserialize;
use serde_json::Value;

use crate::error::{WireError, from_value};
use crate::mission::{
    FieldNames, FlyZone, Home, LatLon, Mission, MissionInput, MovingObstacleInfo, SourceFormat,
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

// ---- rendering: jink's values back in the judges' formats (feet, knots) ---------------

/// Metres to feet.
pub fn m_to_ft(v: f64) -> f64 {
    v / M_PER_FT
}

fn pos(lat: f64, lon: f64) -> Value {
    serde_json::json!({ "latitude": lat, "longitude": lon })
}

/// A mission as the 2019+ server's `GET /api/missions/{id}` served it (protobuf-JSON,
/// lowerCamelCase, feet MSL), with `id` as its interop id. The home is the lost-comms
/// position (what a 2019 mission's home was read from). What jink does not keep (ODLC
/// positions, air drop, map) is left out, as protobuf-JSON leaves out unset fields.
pub fn render_mission_2019(m: &Mission, id: i64) -> Value {
    let c = &m.content;
    serde_json::json!({
        "id": id,
        "lostCommsPos": pos(m.home.lat, m.home.lon),
        "flyZones": c.fly_zones.iter().map(|z| serde_json::json!({
            "altitudeMin": m_to_ft(z.alt_min_msl_m),
            "altitudeMax": m_to_ft(z.alt_max_msl_m),
            "boundaryPoints": z.boundary.iter().map(|p| pos(p.lat, p.lon)).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "waypoints": c.waypoints.iter().map(|w| serde_json::json!({
            "latitude": w.lat, "longitude": w.lon, "altitude": m_to_ft(w.alt_msl_m),
        })).collect::<Vec<_>>(),
        "searchGridPoints": c.search_grid.iter().map(|p| pos(p.lat, p.lon)).collect::<Vec<_>>(),
        "stationaryObstacles": c.stationary_obstacles.iter().map(|o| serde_json::json!({
            "latitude": o.lat, "longitude": o.lon,
            "radius": m_to_ft(o.radius_m), "height": m_to_ft(o.top_msl_m),
        })).collect::<Vec<_>>(),
    })
}

/// Points with 1-based `order` fields, as 2017/2018 lists carried them.
fn ordered(points: impl Iterator<Item = (f64, f64, Option<f64>)>) -> Vec<Value> {
    points
        .enumerate()
        .map(|(i, (lat, lon, alt_m))| {
            let mut v = serde_json::json!({ "latitude": lat, "longitude": lon, "order": i + 1 });
            if let Some(a) = alt_m {
                v["altitude_msl"] = Value::from(m_to_ft(a));
            }
            v
        })
        .collect()
}

/// A mission as the 2017/2018 server's `GET /api/missions/{id}` served it (feet MSL,
/// `order` fields), with `id` as its interop id, `active: true`, and the cylinders and
/// moving-obstacle announcements the 2018 mission list carried (`stationary_obstacles`,
/// `moving_obstacles` with `sphere_radius` in feet and `speed_avg` in knots).
pub fn render_mission_2018(m: &Mission, id: i64) -> Value {
    let c = &m.content;
    serde_json::json!({
        "id": id,
        "active": true,
        "home_pos": pos(m.home.lat, m.home.lon),
        "fly_zones": c.fly_zones.iter().map(|z| serde_json::json!({
            "altitude_msl_min": m_to_ft(z.alt_min_msl_m),
            "altitude_msl_max": m_to_ft(z.alt_max_msl_m),
            "boundary_pts": ordered(z.boundary.iter().map(|p| (p.lat, p.lon, None))),
        })).collect::<Vec<_>>(),
        "mission_waypoints": ordered(c.waypoints.iter().map(|w| (w.lat, w.lon, Some(w.alt_msl_m)))),
        "search_grid_points": ordered(c.search_grid.iter().map(|p| (p.lat, p.lon, None))),
        "stationary_obstacles": c.stationary_obstacles.iter().map(|o| serde_json::json!({
            "latitude": o.lat, "longitude": o.lon,
            "cylinder_radius": m_to_ft(o.radius_m), "cylinder_height": m_to_ft(o.top_msl_m),
        })).collect::<Vec<_>>(),
        "moving_obstacles": c.moving_obstacles.iter().map(|o| {
            let mut v = serde_json::json!({ "sphere_radius": m_to_ft(o.radius_m) });
            if let Some(s) = o.speed_avg_mps {
                v["speed_avg"] = Value::from(s / MPS_PER_KT);
            }
            v
        }).collect::<Vec<_>>(),
    })
}

/// A moving obstacle's position for [`render_obstacles_2018`] (metres, as jink keeps it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovingPosition {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Centre altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// A 2017/2018 `GET /api/obstacles` answer: `moving` in the order given (their index is
/// their id, as the judges' list was), then `stationary` (the mission's cylinders), feet.
pub fn render_obstacles_2018(
    moving: &[MovingPosition],
    stationary: &[StationaryObstacle],
) -> Value {
    serde_json::json!({
        "moving_obstacles": moving.iter().map(|o| serde_json::json!({
            "latitude": o.lat, "longitude": o.lon,
            "altitude_msl": m_to_ft(o.alt_msl_m), "sphere_radius": m_to_ft(o.radius_m),
        })).collect::<Vec<_>>(),
        "stationary_obstacles": stationary.iter().map(|o| serde_json::json!({
            "latitude": o.lat, "longitude": o.lon,
            "cylinder_radius": m_to_ft(o.radius_m), "cylinder_height": m_to_ft(o.top_msl_m),
        })).collect::<Vec<_>>(),
    })
}

/// Aircraft telemetry as a 2019+ `POST /api/telemetry` body: `latitude`, `longitude`,
/// `altitude` (feet MSL), `heading` (degrees). The sample's time is not sent (the judges'
/// server stamps telemetry on receipt).
pub fn render_telemetry_2019(s: &crate::telemetry::AircraftSample) -> Value {
    serde_json::json!({
        "latitude": s.lat_deg,
        "longitude": s.lon_deg,
        "altitude": m_to_ft(s.alt_msl_m),
        "heading": s.heading_deg,
    })
}

/// Aircraft telemetry as a 2017/2018 form-encoded `POST /api/telemetry` body: `latitude`,
/// `longitude`, `altitude_msl` (feet), `uas_heading` (degrees).
pub fn render_telemetry_2018_form(s: &crate::telemetry::AircraftSample) -> String {
    let fields = [
        ("latitude", s.lat_deg),
        ("longitude", s.lon_deg),
        ("altitude_msl", m_to_ft(s.alt_msl_m)),
        ("uas_heading", s.heading_deg),
    ];
    serde_urlencoded::to_string(fields).unwrap_or_default()
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

    fn read(v: Value) -> Mission {
        crate::domain::read_mission_text(&v.to_string(), "m").unwrap()
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * a.abs().max(1.0)
    }

    /// Every number of `got` equals the one at the same place in `want` (to 1e-9), for
    /// every key of `want` (keys of `got` that `want` lacks are ignored).
    fn assert_subset(want: &Value, got: &Value, at: &str) {
        match (want, got) {
            (Value::Object(w), Value::Object(g)) => {
                for (k, wv) in w {
                    let gv = g
                        .get(k)
                        .unwrap_or_else(|| panic!("{at}/{k} missing in {got}"));
                    assert_subset(wv, gv, &format!("{at}/{k}"));
                }
            }
            (Value::Array(w), Value::Array(g)) => {
                assert_eq!(w.len(), g.len(), "{at}: lengths differ");
                for (i, (wv, gv)) in w.iter().zip(g).enumerate() {
                    assert_subset(wv, gv, &format!("{at}/{i}"));
                }
            }
            (Value::Number(w), Value::Number(g)) => {
                let (w, g) = (w.as_f64().unwrap(), g.as_f64().unwrap());
                assert!(close(w, g), "{at}: {g} != {w}");
            }
            (w, g) => assert_eq!(w, g, "{at}"),
        }
    }

    #[test]
    fn a_2019_mission_renders_back_to_the_judges_document_in_feet() {
        // The fixture as the judges sent it, without what jink does not keep.
        let mut want = fixture("mission_2019.json");
        for k in ["offAxisOdlcPos", "airDropPos", "emergentLastKnownPos"] {
            want.as_object_mut().unwrap().remove(k);
        }
        let m = read(fixture("mission_2019.json"));
        let got = render_mission_2019(&m, 1);
        assert_subset(&want, &got, "");
        // ... and what it renders reads back as the same mission (feet and back: to 1e-9).
        let back = serde_json::to_value(read(got).content).unwrap();
        assert_subset(&serde_json::to_value(&m.content).unwrap(), &back, "");
    }

    #[test]
    fn webster_field_round_trips_through_the_2019_rendering() {
        let m = read(fixture("mission_2021_webster_field.json"));
        let got = render_mission_2019(&m, 7);
        assert_eq!(got["id"], 7);
        let back = read(got);
        assert_eq!(back.home, m.home);
        assert_eq!(back.content.waypoints.len(), 14);
        for (a, b) in back.content.waypoints.iter().zip(&m.content.waypoints) {
            assert!(close(a.alt_msl_m, b.alt_msl_m) && a.lat == b.lat && a.lon == b.lon);
        }
    }

    #[test]
    fn a_2018_mission_renders_back_with_its_orders_and_feet() {
        let mut want = fixture("mission_2018.json");
        for k in [
            "air_drop_pos",
            "off_axis_odlc_pos",
            "emergent_last_known_pos",
        ] {
            want.as_object_mut().unwrap().remove(k);
        }
        // jink keeps no altitude for search-grid points.
        for p in want["search_grid_points"].as_array_mut().unwrap() {
            p.as_object_mut().unwrap().remove("altitude_msl");
        }
        let m = read(fixture("mission_2018.json"));
        let got = render_mission_2018(&m, 1);
        assert_subset(&want, &got, "");
        let back = serde_json::to_value(read(got).content).unwrap();
        assert_subset(&serde_json::to_value(&m.content).unwrap(), &back, "");
    }

    #[test]
    fn a_2018_missions_obstacles_render_in_feet_and_knots() {
        // The 2018 superuser list carried cylinders and moving-obstacle announcements.
        let mut doc = fixture("mission_2018.json");
        doc["stationary_obstacles"] = serde_json::json!([
            {"latitude": 38.14, "longitude": -76.43, "cylinder_radius": 150.0, "cylinder_height": 300.0},
            {"latitude": 38.145, "longitude": -76.428, "cylinder_radius": 75.5, "cylinder_height": 212.25}
        ]);
        doc["moving_obstacles"] = serde_json::json!([
            {"sphere_radius": 50.0, "speed_avg": 30.0},
            {"sphere_radius": 35.0, "speed_avg": 12.5}
        ]);
        let m = read(doc.clone());
        assert!(close(
            m.content.stationary_obstacles[0].radius_m,
            150.0 * 0.3048
        ));
        let got = render_mission_2018(&m, 3);
        assert_eq!(got["id"], 3);
        assert_subset(
            &doc["stationary_obstacles"],
            &got["stationary_obstacles"],
            "/stationary_obstacles",
        );
        assert_subset(
            &doc["moving_obstacles"],
            &got["moving_obstacles"],
            "/moving_obstacles",
        );
    }

    #[test]
    fn an_obstacle_snapshot_renders_back_to_the_judges_snapshot() {
        let want = fixture("obstacles_2018.json");
        let moving: Vec<MovingPosition> =
            crate::telemetry::parse_observations(want.clone(), None, 0.0)
                .unwrap()
                .iter()
                .map(|o| MovingPosition {
                    lat: o.lat_deg,
                    lon: o.lon_deg,
                    alt_msl_m: o.alt_msl_m,
                    radius_m: o.radius_m,
                })
                .collect();
        let stationary: Vec<StationaryObstacle> = want["stationary_obstacles"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
            .map(|(i, c)| {
                cylinder_ft(
                    i,
                    c["latitude"].as_f64().unwrap(),
                    c["longitude"].as_f64().unwrap(),
                    c["cylinder_radius"].as_f64().unwrap(),
                    c["cylinder_height"].as_f64().unwrap(),
                )
            })
            .collect();
        let got = render_obstacles_2018(&moving, &stationary);
        assert_subset(&want, &got, "");
    }

    #[test]
    fn telemetry_renders_in_feet_for_both_generations() {
        let want = fixture("telemetry_2019.json");
        let s = crate::telemetry::parse_telemetry_json(want.clone(), 5.0)
            .unwrap()
            .remove(0);
        assert_subset(&want, &render_telemetry_2019(&s), "");
        let form = render_telemetry_2018_form(&s);
        let back = crate::telemetry::parse_telemetry_form(form.as_bytes(), 5.0).unwrap();
        assert_eq!(back.lat_deg, s.lat_deg);
        assert!(close(back.alt_msl_m, s.alt_msl_m));
        assert!(close(back.alt_msl_m, 50.0 * 0.3048));
        assert!(form.contains("uas_heading=90"), "{form}");
    }
}
