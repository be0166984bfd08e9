//! The tangent-graph strategy: at the first call, every leg is routed around the cylinders
//! that matter at its altitude on [`crate::tangent_graph`] ([`super::route::tangent_stack`]);
//! cylinders never move, so later calls keep the stack ([`super::FirstThen`]). The reactive
//! strategies ([`super::reactive`]) fly on the same route.

use super::route::tangent_stack;
use super::{Command, View};
use crate::tangent_graph::TangentGraphParams;

/// The stack with every leg on its static shortest path around the cylinders (default
/// graph parameters).
pub fn tangent_command(view: &View<'_>) -> Command {
    Command::Replace(tangent_stack(view, &TangentGraphParams::default()))
}
