//! The waypoint-insertion strategy: the planner's static pre-pass (seed 004 insertion around
//! every blocking cylinder, buffer 20% of the radius), run once at the first call; cylinders
//! never move, so later calls keep the stack.

use super::planner_adapter::{
    from_planner_stack, to_planner_aircraft, to_planner_mission, to_planner_stack, to_planner_state,
};
use super::{Command, Strategy, View};

/// Seed 004 insertion only.
#[derive(Debug, Clone, Default)]
pub struct Insertion {
    done: bool,
}

impl Strategy for Insertion {
    fn period_s(&self) -> f64 {
        1.0
    }
    fn decide(&mut self, view: &View<'_>) -> Command {
        if self.done {
            return Command::Keep;
        }
        self.done = true;
        let mission = to_planner_mission(view.mission);
        let stack = to_planner_stack(view.stack);
        let req = planner::PlanRequest {
            mission: &mission,
            aircraft: to_planner_aircraft(view.aircraft),
            stack: &stack,
            current_index: view.stack.current,
            state: to_planner_state(&view.own),
            params: planner::PlanParams::default().strategy(planner::Strategy::Insertion),
            seed: 0,
        };
        match planner::plan(&req, &predictor::NoRisk) {
            Ok(p) => Command::Replace(from_planner_stack(&p.items, p.current_index)),
            Err(_) => Command::Keep,
        }
    }
}
