//! QGC WPL 110 text export, the waypoint file format of QGroundControl, Mission Planner
//! and pymavlink's `mavwp`.
//!
//! Header `QGC WPL 110`, then one tab-separated line per item with 12 fields:
//! `index, current, frame, command, p1, p2, p3, p4, lat, lon, alt, autocontinue`.
//! Index 0 is the home position (current = 1, as ground stations write it); mission items
//! follow from index 1 as `MAV_CMD_NAV_WAYPOINT` (16) in frame 0 (global, altitude metres
//! MSL), all parameters 0, autocontinue 1. Latitude and longitude carry 8 decimals
//! (about 1 mm), altitude 2.
//!
//! # Example
//! ```
//! use planner::export::{qgc_wpl, GeoItem};
//! use planner::ItemKind;
//! let home = GeoItem { lat_deg: 38.1446, lon_deg: -76.4280, alt_msl_m: 10.0, kind: ItemKind::Mission };
//! let text = qgc_wpl(&home, &[]);
//! assert!(text.starts_with("QGC WPL 110\n0\t1\t0\t16\t"));
//! ```

use std::fmt::Write;

use super::{GeoItem, MAV_CMD_NAV_WAYPOINT, MAV_FRAME_GLOBAL};

/// The WPL 110 text of `home` (index 0) followed by `items` (indices 1..).
pub fn qgc_wpl(home: &GeoItem, items: &[GeoItem]) -> String {
    let mut s = String::from("QGC WPL 110\n");
    for (i, it) in std::iter::once(home).chain(items).enumerate() {
        let current = u8::from(i == 0);
        let _ = writeln!(
            s,
            "{i}\t{current}\t{MAV_FRAME_GLOBAL}\t{MAV_CMD_NAV_WAYPOINT}\t0\t0\t0\t0\t{:.8}\t{:.8}\t{:.2}\t1",
            it.lat_deg, it.lon_deg, it.alt_msl_m
        );
    }
    s
}
