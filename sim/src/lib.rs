//! Closed-loop simulation of missions against moving obstacles, scored as the judges did.

#![warn(missing_docs)]

pub mod behaviour;
pub mod geometry;
pub mod mission;
pub mod scenario;
pub mod spline;
pub mod aircraft;
pub mod lidar;
pub mod scoring;
pub mod telemetry;
