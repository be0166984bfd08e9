//! QGroundControl `.plan` JSON export (file format "Plan", version 1).
//!
//! Layout, as QGroundControl reads it: `fileType: "Plan"`, `version: 1`,
//! `groundStation: "jink"`; `mission` with `cruiseSpeed`, `firmwareType`, `hoverSpeed`,
//! `items[]` of `SimpleItem`s (`command` 16 `MAV_CMD_NAV_WAYPOINT`, `frame` 0 global /
//! metres MSL, `params` `[0, 0, 0, null, lat, lon, alt]`, `doJumpId` from 1, `autoContinue`
//! true, `AltitudeMode` 2 = AMSL, `Altitude`), `plannedHomePosition` `[lat, lon, alt]`,
//! `vehicleType` 1 (fixed wing), `version` 2; `geoFence` version 2 with the fly zone as
//! inclusion polygons `[[lat, lon], ...]` (version 1) and the stationary obstacles as
//! exclusion circles (`{"circle": {"center": [lat, lon], "radius": metres}, "inclusion":
//! false, "version": 1}`, [`qgc_plan_with_fence`]); `rallyPoints` version 2 with no points.
//!
//! # Example
//! ```
//! use planner::export::{qgc_plan, GeoItem, PlanFileOptions};
//! use planner::ItemKind;
//! let home = GeoItem { lat_deg: 38.0, lon_deg: -76.0, alt_msl_m: 5.0, kind: ItemKind::Mission };
//! let json = qgc_plan(&home, &[home], &[], &PlanFileOptions::default());
//! let v: serde_json::Value = serde_json::from_str(&json).unwrap();
//! assert_eq!(v["mission"]["items"][0]["command"], 16);
//! ```

use serde_json::{Value, json};

use super::{GeoItem, GeoPoint, MAV_CMD_NAV_WAYPOINT, MAV_FRAME_GLOBAL};

/// Mission-level fields of the `.plan` file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanFileOptions {
    /// Cruise speed, m/s. Default 20.
    pub cruise_speed_mps: f64,
    /// Hover speed, m/s (unused by fixed wings). Default 5.
    pub hover_speed_mps: f64,
    /// `MAV_AUTOPILOT` of the vehicle. Default 3 (ArduPilot); 12 is PX4.
    pub firmware_type: u8,
}

impl Default for PlanFileOptions {
    fn default() -> Self {
        Self {
            cruise_speed_mps: 20.0,
            hover_speed_mps: 5.0,
            firmware_type: 3,
        }
    }
}

/// Rounds to `d` decimals so the file is stable and readable.
fn round(v: f64, d: i32) -> f64 {
    let k = 10f64.powi(d);
    (v * k).round() / k
}

/// A circle the aircraft must stay out of (a stationary obstacle), as a geofence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExclusionCircle {
    /// Centre.
    pub center: GeoPoint,
    /// Radius, metres.
    pub radius_m: f64,
}

/// The `.plan` JSON (pretty-printed) for `home`, `items` and the fly-zone polygons, with
/// no exclusion circles.
pub fn qgc_plan(
    home: &GeoItem,
    items: &[GeoItem],
    fly_zones: &[Vec<GeoPoint>],
    options: &PlanFileOptions,
) -> String {
    qgc_plan_with_fence(home, items, fly_zones, &[], options)
}

/// The `.plan` JSON (pretty-printed) for `home`, `items`, the fly-zone polygons (inclusion
/// fences) and `exclusion_circles` (exclusion fences, e.g. the mission's cylinders).
pub fn qgc_plan_with_fence(
    home: &GeoItem,
    items: &[GeoItem],
    fly_zones: &[Vec<GeoPoint>],
    exclusion_circles: &[ExclusionCircle],
    options: &PlanFileOptions,
) -> String {
    let items: Vec<Value> = items
        .iter()
        .enumerate()
        .map(|(i, it)| {
            let (lat, lon, alt) = (
                round(it.lat_deg, 8),
                round(it.lon_deg, 8),
                round(it.alt_msl_m, 2),
            );
            json!({
                "AMSLAltAboveTerrain": null,
                "Altitude": alt,
                "AltitudeMode": 2,
                "autoContinue": true,
                "command": MAV_CMD_NAV_WAYPOINT,
                "doJumpId": i + 1,
                "frame": MAV_FRAME_GLOBAL,
                "params": [0, 0, 0, null, lat, lon, alt],
                "type": "SimpleItem"
            })
        })
        .collect();
    let polygons: Vec<Value> = fly_zones
        .iter()
        .map(|z| {
            let pts: Vec<Value> = z
                .iter()
                .map(|p| json!([round(p.lat_deg, 8), round(p.lon_deg, 8)]))
                .collect();
            json!({ "inclusion": true, "polygon": pts, "version": 1 })
        })
        .collect();
    let circles: Vec<Value> = exclusion_circles
        .iter()
        .map(|c| {
            json!({
                "circle": {
                    "center": [round(c.center.lat_deg, 8), round(c.center.lon_deg, 8)],
                    "radius": round(c.radius_m, 2)
                },
                "inclusion": false,
                "version": 1
            })
        })
        .collect();
    let v = json!({
        "fileType": "Plan",
        "geoFence": { "circles": circles, "polygons": polygons, "version": 2 },
        "groundStation": "jink",
        "mission": {
            "cruiseSpeed": options.cruise_speed_mps,
            "firmwareType": options.firmware_type,
            "hoverSpeed": options.hover_speed_mps,
            "items": items,
            "plannedHomePosition": [round(home.lat_deg, 8), round(home.lon_deg, 8), round(home.alt_msl_m, 2)],
            "vehicleType": 1,
            "version": 2
        },
        "rallyPoints": { "points": [], "version": 2 },
        "version": 1
    });
    let mut s = serde_json::to_string_pretty(&v).unwrap_or_default();
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ItemKind;

    fn item(lat_deg: f64, lon_deg: f64, alt_msl_m: f64) -> GeoItem {
        GeoItem {
            lat_deg,
            lon_deg,
            alt_msl_m,
            kind: ItemKind::Mission,
        }
    }

    /// The golden file `tests/data/fence_circles.plan`: two waypoints, one inclusion
    /// polygon, two exclusion circles (Webster Field's first two cylinders, 150 ft and
    /// 300 ft). Regenerate with `JINK_BLESS=1 cargo test -p planner --lib qgc_plan`.
    #[test]
    fn cylinders_are_exclusion_circles_as_in_the_golden_file() {
        let home = item(38.14469, -76.428, 5.0);
        let items = [
            item(38.14469, -76.428, 60.96),
            item(38.14619, -76.42371, 91.44),
        ];
        let zone = vec![
            GeoPoint {
                lat_deg: 38.142,
                lon_deg: -76.434,
            },
            GeoPoint {
                lat_deg: 38.151,
                lon_deg: -76.434,
            },
            GeoPoint {
                lat_deg: 38.151,
                lon_deg: -76.418,
            },
            GeoPoint {
                lat_deg: 38.142,
                lon_deg: -76.418,
            },
        ];
        let circles = [
            ExclusionCircle {
                center: GeoPoint {
                    lat_deg: 38.146689,
                    lon_deg: -76.426475,
                },
                radius_m: 45.72,
            },
            ExclusionCircle {
                center: GeoPoint {
                    lat_deg: 38.142914,
                    lon_deg: -76.430297,
                },
                radius_m: 91.44,
            },
        ];
        let text = qgc_plan_with_fence(
            &home,
            &items,
            &[zone],
            &circles,
            &PlanFileOptions::default(),
        );
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/fence_circles.plan");
        if std::env::var("JINK_BLESS").is_ok_and(|v| v == "1") {
            std::fs::write(path, &text).unwrap();
        }
        let golden = std::fs::read_to_string(path).unwrap();
        assert_eq!(
            text, golden,
            "regenerate with JINK_BLESS=1 if the change is intended"
        );
        // What QGroundControl reads: an exclusion circle with its centre and radius.
        let v: Value = serde_json::from_str(&text).unwrap();
        let c = &v["geoFence"]["circles"][1];
        assert_eq!(c["inclusion"], false);
        assert_eq!(c["version"], 1);
        assert_eq!(c["circle"]["center"], json!([38.142914, -76.430297]));
        assert_eq!(c["circle"]["radius"], 91.44);
        assert_eq!(v["geoFence"]["polygons"][0]["inclusion"], true);
    }

    #[test]
    fn without_circles_the_fence_has_none() {
        let home = item(38.0, -76.0, 5.0);
        let v: Value =
            serde_json::from_str(&qgc_plan(&home, &[home], &[], &PlanFileOptions::default()))
                .unwrap();
        assert_eq!(v["geoFence"]["circles"], json!([]));
    }
}
