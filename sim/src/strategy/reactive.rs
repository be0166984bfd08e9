//! Reactive LiDAR strategies (placeholder until `planner::reactive` lands; see the crate docs).

use super::{Command, Strategy, View};

/// Offset algorithm + Bezier pilot (not integrated yet: keeps the stack).
#[derive(Debug, Clone, Default)]
pub struct Offset;

/// Sector avoider (not integrated yet: keeps the stack).
#[derive(Debug, Clone, Default)]
pub struct Sectors;

impl Strategy for Offset {
    fn period_s(&self) -> f64 {
        0.1
    }
    fn decide(&mut self, _view: &View<'_>) -> Command {
        Command::Keep
    }
}

impl Strategy for Sectors {
    fn period_s(&self) -> f64 {
        0.1
    }
    fn decide(&mut self, _view: &View<'_>) -> Command {
        Command::Keep
    }
}
