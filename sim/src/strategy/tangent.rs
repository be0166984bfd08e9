//! The tangent-graph strategy: at the first call, every leg is routed around the cylinders
//! that matter at its altitude on [`crate::tangent_graph`]; cylinders never move, so later
//! calls keep the stack.

use super::route::rebuild_tail;
use super::{Command, Strategy, View};
use crate::geometry::xy;
use crate::tangent_graph::{TangentGraphParams, inflated_circles, shortest_path};

/// Static shortest paths around cylinders.
#[derive(Debug, Clone, Default)]
pub struct Tangent {
    /// Graph parameters.
    pub params: TangentGraphParams,
    done: bool,
}

impl Strategy for Tangent {
    fn period_s(&self) -> f64 {
        1.0
    }
    fn decide(&mut self, view: &View<'_>) -> Command {
        if self.done {
            return Command::Keep;
        }
        self.done = true;
        let p = self.params;
        let m = view.mission;
        Command::Replace(rebuild_tail(
            view.stack,
            xy(view.own.p_m),
            |a, b, alt, _| {
                let circles = inflated_circles(&m.cylinders, alt, &p);
                shortest_path(a, b, &circles, crate::mission::fly_zone(m), &p).unwrap_or_default()
            },
        ))
    }
}
