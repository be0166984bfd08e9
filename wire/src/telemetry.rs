//! Moving-obstacle observations and aircraft telemetry: the native wire types, the interop
//! forms they are accepted in, and their parsing at the edge into the validated domain
//! values [`Observation`] and [`AircraftSample`].
//!
//! Accepted:
//! - observations: a native batch `{"observations": [ObservationIn]}`, or an interop
//!   2017/2018 `/api/obstacles` snapshot (feet; a moving obstacle's id is its index in the
//!   list) stamped with its `time`, else the caller's `?time=`, else the receipt time;
//! - aircraft telemetry: a native [`AircraftTelemetry`] or a list of them, interop 2019
//!   JSON `{latitude, longitude, altitude (ft), heading}`, or interop 2018 form-encoded
//!   `latitude, longitude, altitude_msl (ft), uas_heading`.
//!
//! # Units
//! Degrees for latitude/longitude and headings (true, clockwise from north), metres MSL for
//! altitudes, metres for radii, m/s for speeds, Unix seconds for times.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::error::{FieldError, WireError, from_value};
use crate::interop::{ObstacleSnapshot2018, Telemetry2018, Telemetry2019, ft};
use crate::time::WireTime;

/// A moving-obstacle observation, validated: position in range, radius positive, altitude
/// finite, id not blank.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// The obstacle's id within the mission.
    pub obstacle_id: String,
    /// Observation time, Unix seconds.
    pub t_s: f64,
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude of the sphere's centre, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// An aircraft telemetry sample, validated: position in range, altitude finite, heading in
/// [0, 360) (360 is read as 0), speed non-negative when given.
#[derive(Debug, Clone, PartialEq)]
pub struct AircraftSample {
    /// Sample time, Unix seconds.
    pub t_s: f64,
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Heading, degrees true (0 = north, clockwise), in [0, 360).
    pub heading_deg: f64,
    /// Ground speed, m/s, when reported.
    pub speed_mps: Option<f64>,
}

/// One native moving-obstacle observation.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ObservationIn {
    /// The obstacle's id within the mission (not blank).
    #[cfg_attr(feature = "openapi", schema(min_length = 1, pattern = r"\S"))]
    pub obstacle_id: String,
    /// When it was observed (RFC 3339 or Unix seconds); receipt time when absent.
    #[serde(default)]
    pub t: Option<WireTime>,
    /// Latitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -90.0, maximum = 90.0))]
    pub lat: f64,
    /// Longitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -180.0, maximum = 180.0))]
    pub lon: f64,
    /// Altitude of the sphere's centre, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres (> 0).
    #[cfg_attr(feature = "openapi", schema(exclusive_minimum = 0.0))]
    pub radius_m: f64,
}

/// A native batch of observations.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ObservationBatch {
    /// The observations, in any order.
    pub observations: Vec<ObservationIn>,
}

/// A stored observation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ObservationOut {
    /// The obstacle's id.
    pub obstacle_id: String,
    /// Observation time, Unix seconds.
    pub t: f64,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

impl From<&Observation> for ObservationOut {
    fn from(o: &Observation) -> Self {
        Self {
            obstacle_id: o.obstacle_id.clone(),
            t: o.t_s,
            lat: o.lat_deg,
            lon: o.lon_deg,
            alt_msl_m: o.alt_msl_m,
            radius_m: o.radius_m,
        }
    }
}

impl From<&ObservationOut> for Observation {
    fn from(o: &ObservationOut) -> Self {
        Self {
            obstacle_id: o.obstacle_id.clone(),
            t_s: o.t,
            lat_deg: o.lat,
            lon_deg: o.lon,
            alt_msl_m: o.alt_msl_m,
            radius_m: o.radius_m,
        }
    }
}

/// One native aircraft telemetry sample.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AircraftTelemetry {
    /// Sample time (RFC 3339 or Unix seconds); receipt time when absent.
    #[serde(default)]
    pub t: Option<WireTime>,
    /// Latitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -90.0, maximum = 90.0))]
    pub lat: f64,
    /// Longitude, degrees.
    #[cfg_attr(feature = "openapi", schema(minimum = -180.0, maximum = 180.0))]
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Heading, degrees true, [0, 360].
    #[cfg_attr(feature = "openapi", schema(minimum = 0.0, maximum = 360.0))]
    pub heading_deg: f64,
    /// Ground speed, m/s, in [0, 200] ([`MAX_SPEED_MPS`]).
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(minimum = 0.0, maximum = 200.0))]
    pub speed_mps: Option<f64>,
}

/// A stored aircraft telemetry sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AircraftTelemetryOut {
    /// Sample time, Unix seconds.
    pub t: f64,
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// Heading, degrees true.
    pub heading_deg: f64,
    /// Ground speed, m/s, when reported.
    pub speed_mps: Option<f64>,
}

impl From<&AircraftSample> for AircraftTelemetryOut {
    fn from(s: &AircraftSample) -> Self {
        Self {
            t: s.t_s,
            lat: s.lat_deg,
            lon: s.lon_deg,
            alt_msl_m: s.alt_msl_m,
            heading_deg: s.heading_deg,
            speed_mps: s.speed_mps,
        }
    }
}

/// The client's names of one position's fields, for the pointers of field errors.
struct Keys<'a> {
    lat: &'a str,
    lon: &'a str,
    alt: &'a str,
}

/// Checks the fields every observation and sample has; one error per bad field.
fn check_common(
    errs: &mut Vec<FieldError>,
    at: &str,
    keys: &Keys<'_>,
    (lat, lon, alt): (f64, f64, f64),
) {
    crate::coords::check_lat_lon(
        errs,
        &format!("{at}/{}", keys.lat),
        &format!("{at}/{}", keys.lon),
        lat,
        lon,
    );
    if !alt.is_finite() {
        errs.push(FieldError::new(
            format!("{at}/{}", keys.alt),
            "altitude must be finite",
        ));
    }
}

fn check_radius(errs: &mut Vec<FieldError>, pointer: String, radius: f64) {
    if !(radius.is_finite() && radius > 0.0) {
        errs.push(FieldError::new(
            pointer,
            format!("the radius must be positive, got {radius}"),
        ));
    }
}

fn done<T>(errs: Vec<FieldError>, value: T) -> Result<T, WireError> {
    if errs.is_empty() {
        Ok(value)
    } else {
        Err(WireError::Validation(errs))
    }
}

/// Whether a JSON observation document is an interop 2017/2018 snapshot (else native).
pub fn is_obstacle_snapshot_2018(value: &Value) -> bool {
    value.get("moving_obstacles").is_some() || value.get("stationary_obstacles").is_some()
}

/// Parses and validates a posted observation document: a native batch or an interop
/// 2017/2018 snapshot (stamped with its `time`, else `time_s`, else `received_s`; a native
/// observation without `t` is stamped `received_s`). Stationary obstacles of a snapshot
/// are part of the mission and are not returned.
///
/// # Errors
/// [`WireError::BadRequest`] naming a field of the wrong type; [`WireError::Validation`]
/// listing every invalid field.
pub fn parse_observations(
    value: Value,
    time_s: Option<f64>,
    received_s: f64,
) -> Result<Vec<Observation>, WireError> {
    let mut errs = Vec::new();
    if is_obstacle_snapshot_2018(&value) {
        let snap: ObstacleSnapshot2018 = from_value(value)?;
        let t_s = snap.time.map(|t| t.0).or(time_s).unwrap_or(received_s);
        let keys = Keys {
            lat: "latitude",
            lon: "longitude",
            alt: "altitude_msl",
        };
        let rows = snap
            .moving_obstacles
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let at = format!("/moving_obstacles/{i}");
                check_common(
                    &mut errs,
                    &at,
                    &keys,
                    (o.latitude, o.longitude, o.altitude_msl),
                );
                check_radius(&mut errs, format!("{at}/sphere_radius"), o.sphere_radius);
                Observation {
                    obstacle_id: i.to_string(),
                    t_s,
                    lat_deg: o.latitude,
                    lon_deg: o.longitude,
                    alt_msl_m: ft(o.altitude_msl),
                    radius_m: ft(o.sphere_radius),
                }
            })
            .collect();
        return done(errs, rows);
    }
    let batch: ObservationBatch = from_value(value)?;
    let keys = Keys {
        lat: "lat",
        lon: "lon",
        alt: "alt_msl_m",
    };
    let rows = batch
        .observations
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let at = format!("/observations/{i}");
            if o.obstacle_id.trim().is_empty() {
                errs.push(FieldError::new(
                    format!("{at}/obstacle_id"),
                    "the obstacle id must not be empty",
                ));
            }
            check_common(&mut errs, &at, &keys, (o.lat, o.lon, o.alt_msl_m));
            check_radius(&mut errs, format!("{at}/radius_m"), o.radius_m);
            Observation {
                obstacle_id: o.obstacle_id.clone(),
                t_s: o.t.map_or(received_s, |t| t.0),
                lat_deg: o.lat,
                lon_deg: o.lon,
                alt_msl_m: o.alt_msl_m,
                radius_m: o.radius_m,
            }
        })
        .collect();
    done(errs, rows)
}

/// Validates one sample given as (time, lat, lon, alt m, heading, speed), the fields named
/// `keys` (lat, lon, alt, heading, speed) under `at`.
fn sample(
    errs: &mut Vec<FieldError>,
    at: &str,
    keys: [&str; 5],
    s: &AircraftTelemetry,
    received_s: f64,
) -> AircraftSample {
    check_common(
        errs,
        at,
        &Keys {
            lat: keys[0],
            lon: keys[1],
            alt: keys[2],
        },
        (s.lat, s.lon, s.alt_msl_m),
    );
    if !(s.heading_deg.is_finite() && (0.0..=360.0).contains(&s.heading_deg)) {
        errs.push(FieldError::new(
            format!("{at}/{}", keys[3]),
            format!("heading {} is not in [0, 360]", s.heading_deg),
        ));
    }
    if let Some(v) = s.speed_mps
        && !(v.is_finite() && (0.0..=MAX_SPEED_MPS).contains(&v))
    {
        errs.push(FieldError::new(
            format!("{at}/{}", keys[4]),
            format!("speed {v} is not in [0, {MAX_SPEED_MPS}] m/s"),
        ));
    }
    AircraftSample {
        t_s: s.t.map_or(received_s, |t| t.0),
        lat_deg: s.lat,
        lon_deg: s.lon,
        alt_msl_m: s.alt_msl_m,
        heading_deg: s.heading_deg % 360.0,
        speed_mps: s.speed_mps,
    }
}

/// Validates an interop sample `(lat, lon, altitude in feet, heading)`, its fields named
/// `keys` (the judges' names of those four); it carries no time (stamped `received_s`) and
/// no speed.
fn interop_sample(
    errs: &mut Vec<FieldError>,
    [lat_key, lon_key, alt_key, heading_key]: [&str; 4],
    (lat, lon, alt_ft, heading_deg): (f64, f64, f64, f64),
    received_s: f64,
) -> AircraftSample {
    let s = AircraftTelemetry {
        t: None,
        lat,
        lon,
        alt_msl_m: ft(alt_ft),
        heading_deg,
        speed_mps: None,
    };
    let keys = [lat_key, lon_key, alt_key, heading_key, "-"];
    sample(errs, "", keys, &s, received_s)
}

/// The highest aircraft speed jink accepts, m/s (about 390 kt: far above any fixed-wing
/// UAV; a plan's forward flight is simulated in steps of time that shrink with speed, so
/// an absurd speed would make it endless).
pub const MAX_SPEED_MPS: f64 = 200.0;

const NATIVE_KEYS: [&str; 5] = ["lat", "lon", "alt_msl_m", "heading_deg", "speed_mps"];

/// Parses and validates posted JSON aircraft telemetry: interop 2019 (detected by its
/// `latitude` key; feet, stamped `received_s`), a list of native samples, or one native
/// sample (a sample without `t` is stamped `received_s`).
///
/// # Errors
/// [`WireError::BadRequest`] naming a field of the wrong type; [`WireError::Validation`]
/// listing every invalid field.
pub fn parse_telemetry_json(
    value: Value,
    received_s: f64,
) -> Result<Vec<AircraftSample>, WireError> {
    let mut errs = Vec::new();
    let rows = if value.get("latitude").is_some() {
        let t: Telemetry2019 = from_value(value)?;
        let keys = ["latitude", "longitude", "altitude", "heading"];
        let fields = (t.latitude, t.longitude, t.altitude, t.heading);
        vec![interop_sample(&mut errs, keys, fields, received_s)]
    } else if value.is_array() {
        let samples: Vec<AircraftTelemetry> = from_value(value)?;
        samples
            .iter()
            .enumerate()
            .map(|(i, s)| sample(&mut errs, &format!("/{i}"), NATIVE_KEYS, s, received_s))
            .collect()
    } else {
        let s: AircraftTelemetry = from_value(value)?;
        vec![sample(&mut errs, "", NATIVE_KEYS, &s, received_s)]
    };
    done(errs, rows)
}

/// Parses and validates interop 2017/2018 form-encoded aircraft telemetry (feet), stamped
/// `received_s`.
///
/// # Errors
/// [`WireError::BadRequest`] when the form does not parse; [`WireError::Validation`]
/// listing every invalid field.
pub fn parse_telemetry_form(body: &[u8], received_s: f64) -> Result<AircraftSample, WireError> {
    let t: Telemetry2018 = serde_urlencoded::from_bytes(body).map_err(|e| WireError::BadRequest {
        detail: format!("invalid interop 2018 telemetry form: {e} (expected latitude, longitude, altitude_msl, uas_heading)"),
        pointer: None,
    })?;
    let mut errs = Vec::new();
    let keys = ["latitude", "longitude", "altitude_msl", "uas_heading"];
    let fields = (t.latitude, t.longitude, t.altitude_msl, t.uas_heading);
    let row = interop_sample(&mut errs, keys, fields, received_s);
    done(errs, row)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn pointers(e: WireError) -> Vec<String> {
        match e {
            WireError::Validation(errs) => errs.into_iter().map(|e| e.pointer).collect(),
            other => panic!("not a validation error: {other:?}"),
        }
    }

    #[test]
    fn a_native_batch_is_stamped_and_each_bad_field_named() {
        let v = json!({"observations": [
            {"obstacle_id": "a", "t": 10.0, "lat": 38.0, "lon": -76.0, "alt_msl_m": 80.0, "radius_m": 15.0},
            {"obstacle_id": "b", "lat": 38.0, "lon": -76.0, "alt_msl_m": 80.0, "radius_m": 15.0},
        ]});
        let rows = parse_observations(v, Some(99.0), 50.0).unwrap();
        assert_eq!(rows[0].t_s, 10.0);
        assert_eq!(rows[1].t_s, 50.0, "a native observation ignores ?time=");
        let bad = json!({"observations": [
            {"obstacle_id": " ", "lat": 91.0, "lon": -76.0, "alt_msl_m": 80.0, "radius_m": 0.0},
        ]});
        assert_eq!(
            pointers(parse_observations(bad, None, 0.0).unwrap_err()),
            [
                "/observations/0/obstacle_id",
                "/observations/0/lat",
                "/observations/0/radius_m"
            ]
        );
    }

    #[test]
    fn an_interop_snapshot_is_in_feet_with_index_ids_and_its_own_time_first() {
        let v = json!({"time": 20.0, "moving_obstacles": [
            {"latitude": 38.0, "longitude": -76.0, "altitude_msl": 100.0, "sphere_radius": 50.0},
            {"latitude": 38.1, "longitude": -76.1, "altitude_msl": 200.0, "sphere_radius": 60.0},
        ], "stationary_obstacles": []});
        let rows = parse_observations(v, Some(99.0), 50.0).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].obstacle_id, "1");
        assert_eq!(rows[0].t_s, 20.0);
        assert!((rows[0].alt_msl_m - 30.48).abs() < 1e-9);
        assert!((rows[0].radius_m - 15.24).abs() < 1e-9);
        let untimed = json!({"moving_obstacles": [
            {"latitude": 38.0, "longitude": 200.0, "altitude_msl": 100.0, "sphere_radius": -1.0}]});
        assert_eq!(
            pointers(parse_observations(untimed, Some(99.0), 50.0).unwrap_err()),
            [
                "/moving_obstacles/0/longitude",
                "/moving_obstacles/0/sphere_radius"
            ]
        );
    }

    #[test]
    fn telemetry_in_three_forms() {
        let native = json!([{"t": 5.0, "lat": 38.0, "lon": -76.0, "alt_msl_m": 90.0, "heading_deg": 360.0, "speed_mps": 20.0},
                            {"lat": 38.0, "lon": -76.0, "alt_msl_m": 90.0, "heading_deg": 10.0}]);
        let rows = parse_telemetry_json(native, 7.0).unwrap();
        assert_eq!((rows[0].t_s, rows[0].heading_deg), (5.0, 0.0));
        assert_eq!((rows[1].t_s, rows[1].speed_mps), (7.0, None));
        let i2019 =
            json!({"latitude": 38.0, "longitude": -76.0, "altitude": 100.0, "heading": 400.0});
        assert_eq!(
            pointers(parse_telemetry_json(i2019, 0.0).unwrap_err()),
            ["/heading"]
        );
        let form = parse_telemetry_form(
            b"latitude=38.1&longitude=-76.4&altitude_msl=100&uas_heading=45",
            3.0,
        )
        .unwrap();
        assert!((form.alt_msl_m - 30.48).abs() < 1e-9);
        assert_eq!(form.t_s, 3.0);
        assert!(matches!(
            parse_telemetry_form(b"latitude=x", 0.0),
            Err(WireError::BadRequest { .. })
        ));
    }
}
