//! Stack exports for ground stations: QGC WPL 110 text ([`wpl`]) and QGroundControl
//! `.plan` JSON ([`qgc_plan`]) (DESIGN.md "Planner", "Output").
//!
//! Exports take geodetic items: the planner works in ENU metres and the server converts
//! to WGS84 before exporting (the planner crate knows no geodesy).
//!
//! # Units
//! Degrees WGS84 and metres MSL (MAVLink frame 0, `MAV_FRAME_GLOBAL`).

pub mod qgc_plan;
pub mod wpl;

pub use qgc_plan::{PlanFileOptions, qgc_plan};
pub use wpl::qgc_wpl;

use crate::stack::ItemKind;

/// `MAV_CMD_NAV_WAYPOINT`.
pub const MAV_CMD_NAV_WAYPOINT: u16 = 16;
/// `MAV_FRAME_GLOBAL`: altitude in metres above mean sea level.
pub const MAV_FRAME_GLOBAL: u8 = 0;

/// A geodetic point.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GeoPoint {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
}

/// A geodetic stack item.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GeoItem {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude, metres MSL.
    pub alt_msl_m: f64,
    /// What the item is for.
    pub kind: ItemKind,
}
