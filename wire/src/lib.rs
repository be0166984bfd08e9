//! jink's wire formats, parsed at the edge into domain types. No HTTP, no database, no
//! async: the server, the CLIs, the tests and the benches all read missions, observations
//! and telemetry through this crate, never a second parser.
//!
//! - [`mission`]: the native mission types, their validation and defaults;
//! - [`interop`]: the judges' interop-server formats (2017/2018 JSON, 2019+ protobuf-JSON),
//!   detection and conversion into native types (feet and knots into metres and m/s);
//! - [`domain`]: JSON text or value -> detected format -> parsed -> validated mission, and
//!   its conversion into the planner's ENU domain types (`planner::Mission`);
//! - [`telemetry`]: moving-obstacle observations and aircraft telemetry (native and interop)
//!   into validated [`telemetry::Observation`]s and [`telemetry::AircraftSample`]s;
//! - [`coords`]: the one latitude/longitude validator;
//! - [`ids`]: typed ids (`MissionId`, `PlanId`, `ObstacleId`);
//! - [`time`]: wire timestamps (RFC 3339 or Unix seconds);
//! - [`geodesy`]: WGS84 <-> local East-North-Up metres;
//! - [`error`]: field errors with JSON pointers into the document as the client sent it.
//!
//! With the `openapi` feature the wire types derive `utoipa::ToSchema`.

pub mod coords;
pub mod domain;
pub mod error;
pub mod geodesy;
pub mod ids;
pub mod interop;
pub mod mission;
pub mod telemetry;
pub mod time;

pub use error::{FieldError, WireError, from_value};

/// A committed interop fixture (`tests/fixtures/interop/` at the repository root), as text.
#[cfg(test)]
pub(crate) fn fixture_text(name: &str) -> String {
    let path = format!(
        "{}/../tests/fixtures/interop/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}
