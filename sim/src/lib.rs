//! Closed-loop simulation of missions against moving obstacles, scored as the judges did
//! (DESIGN.md "Simulator and evaluation").
//!
//! - [`scenario`]: seeded scenarios within the rules (fly zone, waypoints, up to 10
//!   cylinders, up to 10 moving spheres), or moving spheres for a real mission;
//! - [`behaviour`], [`spline`]: obstacle behaviours (straight with rare turns, random,
//!   biased, patterned/memory turning, the judges' periodic spline tours) and ground truth;
//! - [`telemetry`]: obstacle telemetry at a rate, with Gaussian noise and dropouts;
//! - [`aircraft`]: constant speed, bank-limited turns, L1 path following, waypoint switching;
//! - [`lidar`]: a 2-D LiDAR at the aircraft's altitude (cylinders and sphere sections);
//! - [`strategy`]: the [`strategy::Strategy`] plug-in trait and the strategies (none,
//!   insertion, tangent graph, constant velocity, Monte Carlo bisection with a forced or
//!   automatic stage, reactive offset + pilot, reactive sectors); [`tangent_graph`] is the
//!   clean-room static baseline;
//! - [`run`]: one closed-loop run; [`suite`]: many, in parallel on all cores;
//! - [`scoring`]: the judges' scoring (0.1 s interpolation over gaps up to 5 s, hits,
//!   `(fraction not hit)^3`, 100 ft waypoints) plus clearance and boundary metrics;
//! - [`report`], [`svg`], [`prediction`]: Markdown/JSON reports, SVG plots, and the
//!   prediction report (NLL and 95% coverage per stage and behaviour);
//! - [`compare`]: two builds' reports paired by seed (`jink compare`).
//!
//! # Example
//! ```
//! use sim::run::{RunConfig, run};
//! use sim::scenario::{Family, ScenarioParams, generate};
//! use sim::strategy::StrategyKind;
//!
//! let scenario = generate(Family::Static, 3, &ScenarioParams::default());
//! let result = run(&scenario, StrategyKind::Tangent, &RunConfig::default());
//! assert!(result.metrics.completed);
//! assert_eq!(result.metrics.sphere_score, 1.0); // no spheres in the static family
//! ```

#![warn(missing_docs)]

pub mod aircraft;
pub mod behaviour;
pub mod compare;
pub mod cpu;
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
