//! QGroundControl `.plan` JSON export (file format "Plan", version 1).
//!
//! Layout, as QGroundControl reads it: `fileType: "Plan"`, `version: 1`,
//! `groundStation: "jink"`; `mission` with `cruiseSpeed`, `firmwareType`, `hoverSpeed`,
//! `items[]` of `SimpleItem`s (`command` 16 `MAV_CMD_NAV_WAYPOINT`, `frame` 0 global /
//! metres MSL, `params` `[0, 0, 0, null, lat, lon, alt]`, `doJumpId` from 1, `autoContinue`
//! true, `AltitudeMode` 2 = AMSL, `Altitude`), `plannedHomePosition` `[lat, lon, alt]`,
//! `vehicleType` 1 (fixed wing), `version` 2; `geoFence` version 2 with the fly zone as
//! inclusion polygons `[[lat, lon], ...]` (version 1) and no circles; `rallyPoints`
//! version 2 with no points.
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

/// The `.plan` JSON (pretty-printed) for `home`, `items` and the fly-zone polygons.
pub fn qgc_plan(
    home: &GeoItem,
    items: &[GeoItem],
    fly_zones: &[Vec<GeoPoint>],
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
    let v = json!({
        "fileType": "Plan",
        "geoFence": { "circles": [], "polygons": polygons, "version": 2 },
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
