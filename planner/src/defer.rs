//! Putting off a mission waypoint that cannot be reached.
//!
//! A waypoint can lie where a moving obstacle stays: on the tour of a sphere that sweeps
//! it every few seconds, or under a slow one circling over it. The planner waits for it
//! (the delay credit, the overdue far limit and the hold circles of
//! [`crate::PlanParams::hold_overdue`]), and before this rule it waited for good: on
//! Webster Field with mixed spheres the aircraft circled such a waypoint from 81 s until
//! the scenario's time limit at 890 s and captured 4 of 14 waypoints (18 m/s, seed 1284;
//! the oracle, told the spheres' true future, did no better).
//!
//! Once the next fixed item has been the target longer than
//! [`crate::PlanParams::defer_after_s`], [`crate::replan`] moves it, with the avoid
//! items before it, to the end of the stack and flies the rest of the mission first
//! ([`with_deferred`]). The judges count a waypoint within 100 ft at any time, so the
//! waypoints after it still count, and the put-off one is tried again at the end, when
//! the obstacle may be elsewhere.
//!
//! Contract:
//! - Only a mission waypoint is put off, and only when another mission waypoint follows
//!   it in the stack: the last waypoint left is waited for as before (there is nothing to
//!   fly instead). Two stuck waypoints take turns at the end of the stack, each after its
//!   own wait.
//! - The put-off item keeps its mission index; the items after it keep their order.
//! - Pure: the same stack, index and waiting time give the same answer.

use crate::stack::{ItemKind, StackItem, next_fixed};

/// A mission waypoint put off to the end of the stack ([`with_deferred`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deferred {
    /// Its index in the stack as given (`current_index` or after).
    pub stack_index: usize,
    /// Its index in the mission's waypoints.
    pub mission_index: usize,
    /// How long it had been the target, seconds.
    pub pending_s: f64,
}

/// `stack` with its next fixed item (from `current_index` on) put off: that item and the
/// avoid items before it taken out, the item appended after the last one. `None` (nothing
/// changes) when the next fixed item is not a mission waypoint, when no mission waypoint
/// follows it, or when `pending_s` is not longer than `after_s` (`after_s` 0 or less, or
/// not finite: never).
pub fn with_deferred(
    stack: &[StackItem],
    current_index: usize,
    pending_s: f64,
    after_s: f64,
) -> Option<(Vec<StackItem>, Deferred)> {
    if !(after_s > 0.0 && after_s.is_finite() && pending_s > after_s) {
        return None;
    }
    let j = next_fixed(stack, current_index)?;
    let item = stack[j];
    let mission_index = item
        .mission_index
        .filter(|_| item.kind == ItemKind::Mission)?;
    if !stack[j + 1..].iter().any(|i| i.kind == ItemKind::Mission) {
        return None;
    }
    let mut out = Vec::with_capacity(stack.len() - (j - current_index));
    out.extend_from_slice(&stack[..current_index]);
    out.extend_from_slice(&stack[j + 1..]);
    out.push(item);
    Some((
        out,
        Deferred {
            stack_index: j,
            mission_index,
            pending_s,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(i: usize) -> StackItem {
        StackItem::mission(i, [100.0 * i as f64, 0.0], 100.0)
    }

    fn a(x: f64) -> StackItem {
        StackItem::avoid([x, 50.0], 100.0)
    }

    #[test]
    fn a_waypoint_pending_too_long_goes_to_the_end_with_its_avoid_items_dropped() {
        // Flying toward an avoid item before waypoint 1; waypoints 2 and 3 follow.
        let s = [m(0), a(50.0), m(1), a(150.0), m(2), m(3)];
        let (out, d) = with_deferred(&s, 1, 241.0, 240.0).expect("put off");
        assert_eq!(out, vec![m(0), a(150.0), m(2), m(3), m(1)]);
        assert_eq!(
            d,
            Deferred {
                stack_index: 2,
                mission_index: 1,
                pending_s: 241.0
            }
        );
        // The item before the current index is kept as it was.
        assert_eq!(out[0], s[0]);
        // Flying straight toward it: the same, nothing before it to drop.
        let (out, d) = with_deferred(&s, 2, 300.0, 240.0).expect("put off");
        assert_eq!(out, vec![m(0), a(50.0), a(150.0), m(2), m(3), m(1)]);
        assert_eq!(d.stack_index, 2);
    }

    #[test]
    fn nothing_is_put_off_before_its_time_or_when_off() {
        let s = [m(0), m(1), m(2)];
        assert_eq!(
            with_deferred(&s, 1, 240.0, 240.0),
            None,
            "not longer than the limit"
        );
        assert_eq!(with_deferred(&s, 1, 100.0, 240.0), None);
        assert_eq!(with_deferred(&s, 1, 1e6, 0.0), None, "0 is off");
        assert_eq!(with_deferred(&s, 1, 1e6, f64::INFINITY), None);
        assert_eq!(with_deferred(&s, 1, f64::NAN, 240.0), None);
    }

    #[test]
    fn the_last_waypoint_left_is_waited_for() {
        // Only avoid or search items after it: there is nothing to fly instead.
        let s = [m(0), m(1), a(150.0), StackItem::search([200.0, 0.0], 100.0)];
        assert_eq!(with_deferred(&s, 1, 1e3, 240.0), None);
        assert_eq!(with_deferred(&[m(0), m(1)], 1, 1e3, 240.0), None);
        // Nothing fixed left at all.
        assert_eq!(with_deferred(&[m(0), a(1.0)], 1, 1e3, 240.0), None);
    }

    #[test]
    fn only_a_mission_waypoint_is_put_off() {
        let s = [m(0), StackItem::search([50.0, 0.0], 100.0), m(1)];
        assert_eq!(with_deferred(&s, 1, 1e3, 240.0), None);
    }

    #[test]
    fn two_stuck_waypoints_take_turns_at_the_end() {
        let s = [m(0), m(1), m(2)];
        let (once, _) = with_deferred(&s, 1, 300.0, 240.0).unwrap();
        assert_eq!(once, vec![m(0), m(2), m(1)]);
        let (twice, d) = with_deferred(&once, 1, 300.0, 240.0).unwrap();
        assert_eq!(twice, vec![m(0), m(1), m(2)]);
        assert_eq!(d.mission_index, 2);
    }
}
