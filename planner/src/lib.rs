//! Path planning for fixed-wing UAVs on SUAS-style missions.
//!
//! Mission geometry is in the local ENU frame in metres. `reactive` holds the onboard
//! LiDAR avoiders (seeds 000, 001, 003).

#![warn(missing_docs)]

/// Builder setters for a parameters struct: each `name(field: Type);` line, under its doc
/// comment, becomes `pub fn name(mut self, field: Type) -> Self` that sets `self.field`.
/// Used inside an `impl` block by the planner's and the simulator's parameter types.
///
/// ```
/// #[derive(Default)]
/// pub struct Params { spacing_m: f64 }
/// impl Params {
///     planner::setters! {
///         /// Sets the spacing, metres.
///         spacing_m(spacing_m: f64);
///     }
/// }
/// assert_eq!(Params::default().spacing_m(60.0).spacing_m, 60.0);
/// ```
#[macro_export]
macro_rules! setters {
    ($($(#[$doc:meta])* $name:ident($field:ident: $ty:ty);)*) => {
        $(
            $(#[$doc])*
            pub fn $name(mut self, $field: $ty) -> Self {
                self.$field = $field;
                self
            }
        )*
    };
}

pub mod bisection;
pub mod cost;
pub mod defer;
pub mod detour;
pub mod export;
pub mod geometry;
pub mod insertion;
pub mod ladder;
pub mod lane;
pub mod mission;
pub mod plan;
pub mod prepass;
pub mod reactive;
pub mod replan;
pub mod revisit;
pub mod shown_turn;
pub mod simplify;
pub mod stack;
pub mod tangent;
pub mod termination;
pub mod turn;
pub mod verify;

pub use defer::{Deferred, with_deferred};
pub use insertion::{Circle, InsertOutcome, insert_waypoint};
pub use mission::{Aircraft, Cylinder, FlyZone, Mission, Waypoint};
pub use plan::{
    AircraftState, DEFAULT_HORIZON_S, Plan, PlanOutcome, PlanParams, PlanRequest, Strategy, plan,
    plan_until,
};
pub use replan::{
    Dynamic, DynamicSeen, LiveMap, Replan, ReplanConfig, Replanned, SeenObstacle, live_map, replan,
};
pub use revisit::{
    Captured, Missed, Pass, TrackPoint, Watch, captured_on_the_way, judge_pass, missed_waypoint,
};
pub use stack::{ItemKind, StackDiff, StackItem, diff, next_fixed};
pub use termination::Termination;
pub use verify::{Conflict, Rival, Verification, VerifyParams, verify_route, verify_route_to_beat};
