//! The waypoint-insertion strategy: the planner's static pre-pass (seed 004 insertion around
//! every blocking cylinder, buffer 20% of the radius), run once at the first call; cylinders
//! never move, so later calls keep the stack.

use super::{Command, Strategy, View};
use crate::mission::Stack;

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
}
