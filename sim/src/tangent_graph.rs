//! The tangent-graph shortest path around cylinders lives in the planner
//! ([`planner::tangent`]); the simulator's `tangent` strategy and the reactive strategies'
//! cylinder routing use it from there.

pub use planner::tangent::*;
