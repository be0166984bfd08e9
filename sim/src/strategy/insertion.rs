//! The waypoint-insertion strategy: the planner's static pre-pass (seed 004 insertion around
//! every blocking cylinder, buffer 20% of the radius), run once at the first call; cylinders
//! never move, so later calls keep the stack ([`super::FirstThen`]).

use super::{Command, View};
use crate::mission::Stack;

/// Seed 004 insertion only: the stack revised by the planner's static pre-pass, or kept
/// on bad input.
pub fn insertion_stack(view: &View<'_>) -> Command {
    let req = planner::PlanRequest {
        mission: view.mission,
        aircraft: view.aircraft.planner_aircraft(),
        stack: &view.stack.items,
        current_index: view.stack.current,
        state: view.own.planner_state(),
        params: planner::PlanParams::default().strategy(planner::Strategy::Insertion),
        seed: 0,
    };
    match planner::plan(&req, &predictor::NoRisk) {
        Ok(p) => Command::Replace(Stack {
            items: p.items,
            current: p.current_index,
        }),
        Err(_) => Command::Keep,
    }
}
