//! Parse at the edge: a mission document (JSON text or value, any supported format) is
//! detected, parsed, validated and defaulted here, once, and converted into the planner's
//! domain types. The server's upload handler, `jink plan`, `jink simulate --mission` and
//! the tests and benches all come through these functions.
//!
//! # Frame
//! A mission's local ENU frame has its origin at its home (interop 2019+: the lost-comms
//! position; else the first fly-zone vertex) at 0 m MSL; see [`crate::geodesy`].

use serde_json::Value;

use crate::error::{FieldError, WireError};
use crate::geodesy::LocalFrame;
use crate::interop::{detect_mission_format, parse_missions, snake_names, uses_snake_case};
use crate::mission::{Home, Mission, MissionInput, SourceFormat, validate};

/// Validated missions of one upload, in document order.
#[derive(Debug, Clone)]
pub struct ReadMissions {
    /// The format they came in (detected unless given).
    pub format: SourceFormat,
    /// Each mission's content and home (defaulted when the document had none).
    pub missions: Vec<(MissionInput, Home)>,
}

/// Reads one mission document (an object, or a list of them as the 2018 `GET
/// /api/missions` served it): the format is `format` or detected, every mission is
/// validated.
///
/// # Errors
/// [`WireError::BadRequest`] when the document does not parse, [`WireError::Validation`]
/// listing every invalid field of every mission, each pointer in the client's own names.
pub fn read_missions(
    value: Value,
    format: Option<SourceFormat>,
) -> Result<ReadMissions, WireError> {
    let format = format.unwrap_or_else(|| detect_mission_format(&value));
    let snake = format == SourceFormat::Interop2019 && uses_snake_case(&value);
    let mut missions = Vec::new();
    let mut errors: Vec<FieldError> = Vec::new();
    for (input, names) in parse_missions(value, format)? {
        let names = if snake { snake_names(names) } else { names };
        match validate(input, &names) {
            Ok(ok) => missions.push(ok),
            Err(e) => errors.extend(e),
        }
    }
    if errors.is_empty() {
        Ok(ReadMissions { format, missions })
    } else {
        Err(WireError::Validation(errors))
    }
}

/// Reads the first mission of a JSON text (a file), format detected, validated, as a
/// [`Mission`] with the given id and no creation time.
///
/// # Errors
/// A message naming the problem: not JSON, not a mission, or the invalid fields.
pub fn read_mission_text(text: &str, id: &str) -> Result<Mission, String> {
    let value: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    let read = read_missions(value, None).map_err(|e| match e {
        WireError::Validation(errs) => errs
            .iter()
            .map(|e| format!("{}: {}", e.pointer, e.detail))
            .collect::<Vec<_>>()
            .join("; "),
        other => other.to_string(),
    })?;
    let (content, home) = read.missions.into_iter().next().ok_or("no mission")?;
    Ok(Mission {
        id: id.into(),
        source_format: read.format,
        created_at: String::new(),
        home,
        content,
    })
}

impl Mission {
    /// The mission in the planner's ENU terms (metres in the mission's frame, altitudes
    /// metres MSL).
    pub fn to_planner(&self) -> planner::Mission {
        self.content.to_planner(&self.frame())
    }

    /// Where a simulated flight of the mission takes off, in the planner's ENU terms: the
    /// home position (the frame's origin) at the first waypoint's altitude; `None` for a
    /// mission without waypoints. `jink simulate --mission` and the simulator's tests
    /// start here.
    pub fn home_start(&self) -> Option<[f64; 3]> {
        let alt = self.content.waypoints.first()?.alt_msl_m;
        let [e, n] = self.frame().to_enu(self.home.lat, self.home.lon);
        Some([e, n, alt])
    }
}

impl MissionInput {
    /// The mission content in the planner's ENU terms, in `frame`.
    pub fn to_planner(&self, frame: &LocalFrame) -> planner::Mission {
        planner::Mission {
            fly_zones: self
                .fly_zones
                .iter()
                .map(|z| planner::FlyZone {
                    boundary_m: z
                        .boundary
                        .iter()
                        .map(|p| frame.to_enu(p.lat, p.lon))
                        .collect(),
                    alt_min_m: z.alt_min_msl_m,
                    alt_max_m: z.alt_max_msl_m,
                })
                .collect(),
            cylinders: self
                .stationary_obstacles
                .iter()
                .map(|c| planner::Cylinder {
                    center_m: frame.to_enu(c.lat, c.lon),
                    radius_m: c.radius_m,
                    top_m: c.top_msl_m,
                })
                .collect(),
            waypoints: self
                .waypoints
                .iter()
                .map(|w| planner::Waypoint {
                    p_m: frame.to_enu(w.lat, w.lon),
                    alt_m: w.alt_msl_m,
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> String {
        let path = format!(
            "{}/../tests/fixtures/interop/{name}",
            env!("CARGO_MANIFEST_DIR")
        );
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
    }

    #[test]
    fn webster_field_converts_in_metres_about_the_lost_comms_position() {
        let m = read_mission_text(&fixture("mission_2021_webster_field.json"), "w").unwrap();
        assert_eq!(m.source_format, SourceFormat::Interop2019);
        let pm = m.to_planner();
        assert_eq!(
            (pm.fly_zones.len(), pm.waypoints.len(), pm.cylinders.len()),
            (1, 14, 6)
        );
        assert_eq!(pm.fly_zones[0].boundary_m.len(), 12);
        // 100-750 ft band, exactly converted.
        assert!((pm.fly_zones[0].alt_min_m - 30.48).abs() < 1e-9);
        assert!((pm.fly_zones[0].alt_max_m - 228.6).abs() < 1e-9);
        // The home (lost-comms position) is the frame's origin, and a simulated flight
        // takes off there at the first waypoint's altitude.
        let [e, n] = m.frame().to_enu(m.home.lat, m.home.lon);
        assert!(e.abs() < 1e-9 && n.abs() < 1e-9);
        let [se, sn, salt] = m.home_start().expect("waypoints");
        assert!(se.abs() < 1e-9 && sn.abs() < 1e-9, "{se} {sn}");
        assert_eq!(salt, pm.waypoints[0].alt_m);
        let mut none = m.clone();
        none.content.waypoints.clear();
        assert_eq!(none.home_start(), None);
        // Every converted waypoint maps back to its latitude/longitude.
        for (w, pw) in m.content.waypoints.iter().zip(&pm.waypoints) {
            let (lat, lon) = m.frame().to_geodetic(pw.p_m);
            assert!((lat - w.lat).abs() < 1e-8 && (lon - w.lon).abs() < 1e-8);
        }
    }

    #[test]
    fn a_2018_list_reads_every_mission_and_an_invalid_one_names_its_field() {
        let v: Value = serde_json::from_str(&fixture("missions_list_2018_fixture.json")).unwrap();
        let n = v.as_array().map_or(1, Vec::len);
        let read = read_missions(v.clone(), None).unwrap();
        assert_eq!(read.format, SourceFormat::Interop2018);
        assert_eq!(read.missions.len(), n);

        let mut bad = v;
        bad[0]["mission_waypoints"][0]["latitude"] = serde_json::json!(95.0);
        match read_missions(bad, None) {
            Err(WireError::Validation(errs)) => {
                assert!(
                    errs.iter()
                        .any(|e| e.pointer == "/0/mission_waypoints/0/latitude"),
                    "{errs:?}"
                );
            }
            other => panic!("{other:?}"),
        }
        assert!(
            read_mission_text("{", "x")
                .unwrap_err()
                .starts_with("not JSON")
        );
    }
}
