//! Path planning for fixed-wing UAVs on SUAS-style missions.
//!
//! Mission geometry is in the local ENU frame in metres. `reactive` holds the onboard
//! LiDAR avoiders (seeds 000, 001, 003).

#![warn(missing_docs)]

pub mod bisection;
pub mod cost;
pub mod detour;
pub mod export;
pub mod geometry;
pub mod insertion;
pub mod ladder;
pub mod mission;
pub mod plan;
pub mod prepass;
pub mod reactive;
pub mod replan;
pub mod simplify;
pub mod stack;
pub mod tangent;
pub mod termination;
pub mod turn;
pub mod verify;

pub use insertion::{Circle, InsertOutcome, insert_waypoint};
pub use mission::{Aircraft, Cylinder, FlyZone, Mission, Waypoint};
pub use plan::{
    AircraftState, Plan, PlanOutcome, PlanParams, PlanRequest, Strategy, plan, plan_until,
};
pub use replan::{
    Dynamic, DynamicSeen, LiveMap, Replan, ReplanConfig, Replanned, SeenObstacle, live_map, replan,
};
pub use stack::{ItemKind, StackDiff, StackItem, diff};
pub use termination::Termination;
pub use verify::{Conflict, Verification, VerifyParams, verify_route};
