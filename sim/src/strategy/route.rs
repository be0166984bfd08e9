//! Rebuilding the stack's tail from the aircraft's position, leg by leg, with a pluggable
//! leg router (the common shape of every ground-station strategy here).
//!
//! Items before the current index stay in place; previously inserted avoid items after it are
//! dropped; each remaining mission waypoint is joined from the previous point by the
//! router's intermediate points (flagged [`ItemKind::Avoid`], at the next waypoint's altitude).

use super::View;
use crate::geometry::{P2, xy};
use crate::mission::{ItemKind, Mission, Stack, StackItem, item_point};
use crate::tangent_graph::{TangentGraphParams, inflated_circles, shortest_path};

/// Builds the new stack: `route(from, to, alt_m, leg)` returns intermediate points for the leg
/// (`leg` = 0 for the leg from the aircraft, 1.. after).
pub fn rebuild_tail(
    stack: &Stack,
    from_m: P2,
    mut route: impl FnMut(P2, P2, f64, usize) -> Vec<P2>,
) -> Stack {
    let mut items: Vec<StackItem> = stack.items[..stack.current.min(stack.items.len())].to_vec();
    let mut prev = from_m;
    let mut leg = 0;
    for it in stack.remaining() {
        if it.kind == ItemKind::Avoid {
            continue;
        }
        for q in route(prev, it.p_m, it.alt_m, leg) {
            items.push(StackItem::avoid(q, it.alt_m));
        }
        items.push(*it);
        prev = it.p_m;
        leg += 1;
    }
    Stack {
        items,
        current: stack.current,
    }
}

/// The stack rebuilt from the aircraft with every leg routed around the cylinders that
/// matter at its altitude on the tangent graph ([`crate::tangent_graph`]); a leg with no
/// route is left straight.
pub fn tangent_stack(view: &View<'_>, g: &TangentGraphParams) -> Stack {
    rebuild_tail(view.stack, xy(view.own.p_m), |a, b, alt, _| {
        tangent_route(view.mission, g, a, b, alt)
    })
}

/// The intermediate points of the tangent graph's shortest path from `a` to `b` at `alt_m`
/// around `m`'s cylinders inside its fly zone; none when there is no path.
pub fn tangent_route(m: &Mission, g: &TangentGraphParams, a: P2, b: P2, alt_m: f64) -> Vec<P2> {
    let circles = inflated_circles(&m.cylinders, alt_m, g);
    shortest_path(a, b, &circles, crate::mission::fly_zone(m), g).unwrap_or_default()
}

/// The remaining route as points with altitudes, starting at `from`.
pub fn route_points(stack: &Stack, from_m: [f64; 3]) -> Vec<[f64; 3]> {
    std::iter::once(from_m)
        .chain(stack.remaining().iter().map(item_point))
        .collect()
}
