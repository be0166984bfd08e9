//! Closed-loop simulation of missions against moving obstacles, scored as the judges did.

#![warn(missing_docs)]

pub mod aircraft;
pub mod behaviour;
pub mod geometry;
pub mod lidar;
pub mod mission;
pub mod prediction;
pub mod report;
pub mod run;
pub mod scenario;
pub mod scoring;
pub mod spline;
pub mod strategy;
pub mod suite;
pub mod svg;
pub mod tangent_graph;
pub mod telemetry;
