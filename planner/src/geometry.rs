//! Plane geometry in ENU metres for the planner: the workspace's one implementation in the
//! `geom` crate, re-exported here so that `planner::geometry::*` paths keep working.
//!
//! Supports DESIGN.md "Planner" and seed 004. The fly-zone predicates follow `geom`'s
//! closed boundary rule (issue 10): a leg touching a fly-zone vertex or running along an
//! edge is inside; a leg that crosses to the outside is not.
//!
//! # Units
//! All coordinates are `[east_m, north_m]`.

pub use geom::*;
