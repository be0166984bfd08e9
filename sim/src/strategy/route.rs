//! Rebuilding the stack's tail from the aircraft's position, leg by leg, with a pluggable
//! leg router (the common shape of every ground-station strategy here).
//!
//! Items before the current index stay in place; previously inserted avoid items after it are
//! dropped; each remaining mission waypoint is joined from the previous point by the
//! router's intermediate points (flagged [`ItemKind::Avoid`], at the next waypoint's altitude).

use crate::geometry::P2;
use crate::mission::{ItemKind, Stack, StackItem, item_point};

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

/// The remaining route as points with altitudes, starting at `from`.
pub fn route_points(stack: &Stack, from_m: [f64; 3]) -> Vec<[f64; 3]> {
    std::iter::once(from_m)
        .chain(stack.remaining().iter().map(item_point))
        .collect()
}
