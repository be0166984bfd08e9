//! The autopilot's waypoint stack and the diff between two revisions of it (seed 002,
//! "System integration / Pixhawk stack"; DESIGN.md "The stack and its indices").
//!
//! The Pixhawk flies a stack of items in order. Changing it mid-flight by appending a new
//! path would leave the old one in place and the aircraft would fly both (the "double
//! path" zigzag). Instead the ground station deletes every changed item and writes the new
//! ones: [`diff`] gives the first changed index, how many items to delete from there to the
//! end, and the items to write from there on. MAVLink's mission protocol can overwrite a
//! range in place only when the count is unchanged, so the diff is a tail rewrite: items
//! before `first_changed` are untouched, and items before the aircraft's current index are
//! never changed by a plan (they keep their indices).
//!
//! # Example
//! ```
//! use planner::stack::{diff, ItemKind, StackItem};
//! let m = |i: usize, x: f64| StackItem::mission(i, [x, 0.0], 50.0);
//! let old = vec![m(0, 0.0), m(1, 100.0), m(2, 200.0)];
//! let mut new = old.clone();
//! new.insert(2, StackItem::avoid([150.0, 30.0], 50.0));
//! let d = diff(&old, &new);
//! assert_eq!(d.first_changed, Some(2));
//! assert_eq!(d.remove, 1);
//! assert_eq!(d.insert.len(), 2);
//! assert_eq!(d.apply(&old), new);
//! ```

use crate::geometry::Point;

/// What an item is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum ItemKind {
    /// A mission waypoint (never moved).
    Mission,
    /// A waypoint the planner inserted to avoid an obstacle.
    Avoid,
    /// A search-area (ladder) waypoint; treated as fixed like a mission waypoint.
    Search,
}

/// One waypoint in the stack.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StackItem {
    /// Position, ENU metres.
    pub p_m: Point,
    /// Altitude, metres MSL.
    pub alt_m: f64,
    /// What the item is for.
    pub kind: ItemKind,
    /// Index into `Mission::waypoints` for mission items.
    pub mission_index: Option<usize>,
}

impl StackItem {
    /// A mission waypoint item.
    pub fn mission(mission_index: usize, p_m: Point, alt_m: f64) -> Self {
        Self {
            p_m,
            alt_m,
            kind: ItemKind::Mission,
            mission_index: Some(mission_index),
        }
    }
    /// An inserted avoidance item.
    pub fn avoid(p_m: Point, alt_m: f64) -> Self {
        Self {
            p_m,
            alt_m,
            kind: ItemKind::Avoid,
            mission_index: None,
        }
    }
    /// A search-pattern item.
    pub fn search(p_m: Point, alt_m: f64) -> Self {
        Self {
            p_m,
            alt_m,
            kind: ItemKind::Search,
            mission_index: None,
        }
    }
    /// Whether the planner must keep this item where it is.
    pub fn is_fixed(&self) -> bool {
        self.kind != ItemKind::Avoid
    }

    /// The altitude a route is checked at after this item, `low_m` being the one it was
    /// checked at before it (each leg is checked at the lower of this and the leg's end):
    /// a fixed item's own altitude (the route is taken to reach it), the lower of `low_m`
    /// and an avoid item's (an aircraft climbing through a detour toward the next fixed item
    /// may still be as low as where it began).
    pub fn low_alt_after(&self, low_m: f64) -> f64 {
        if self.is_fixed() {
            self.alt_m
        } else {
            low_m.min(self.alt_m)
        }
    }
}

/// A tail rewrite turning one stack into another.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StackDiff {
    /// First index where the stacks differ; `None` when they are equal.
    pub first_changed: Option<usize>,
    /// Number of old items to delete, from `first_changed` to the old end.
    pub remove: usize,
    /// Items to write from `first_changed` on (the new tail).
    pub insert: Vec<StackItem>,
}

impl StackDiff {
    /// Whether nothing changes.
    pub fn is_empty(&self) -> bool {
        self.first_changed.is_none()
    }

    /// Applies the diff to `old`.
    pub fn apply(&self, old: &[StackItem]) -> Vec<StackItem> {
        match self.first_changed {
            None => old.to_vec(),
            Some(i) => {
                let mut v = old[..i.min(old.len())].to_vec();
                v.extend_from_slice(&self.insert);
                v
            }
        }
    }
}

/// The tail rewrite from `old` to `new` (exact comparison of items).
pub fn diff(old: &[StackItem], new: &[StackItem]) -> StackDiff {
    let common = old.iter().zip(new).take_while(|(a, b)| a == b).count();
    if common == old.len() && common == new.len() {
        return StackDiff::default();
    }
    StackDiff {
        first_changed: Some(common),
        remove: old.len() - common,
        insert: new[common..].to_vec(),
    }
}

/// Index of the first fixed item (mission or search waypoint) of `items` from `from` on;
/// `None` when only avoid items (or nothing) are left.
pub fn next_fixed(items: &[StackItem], from: usize) -> Option<usize> {
    let k = items.get(from..)?.iter().position(StackItem::is_fixed)?;
    Some(from + k)
}

/// The stack of a mission's own waypoints (no revision yet).
pub fn mission_stack(mission: &crate::mission::Mission) -> Vec<StackItem> {
    mission
        .waypoints
        .iter()
        .enumerate()
        .map(|(i, w)| StackItem::mission(i, w.p_m, w.alt_m))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_next_fixed_item_skips_avoid_items_and_ends_with_the_stack() {
        let s = [
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::avoid([1.0, 0.0], 100.0),
            StackItem::avoid([2.0, 0.0], 100.0),
            StackItem::search([3.0, 0.0], 100.0),
            StackItem::avoid([4.0, 0.0], 100.0),
        ];
        assert_eq!(next_fixed(&s, 0), Some(0));
        assert_eq!(next_fixed(&s, 1), Some(3));
        assert_eq!(next_fixed(&s, 3), Some(3));
        assert_eq!(next_fixed(&s, 4), None);
        assert_eq!(next_fixed(&s, 5), None);
        assert_eq!(next_fixed(&s, 9), None);
    }

    #[test]
    fn a_detour_is_checked_at_its_lowest_altitude_since_the_last_fixed_item() {
        let climb = [
            StackItem::avoid([0.0, 100.0], 120.0),
            StackItem::avoid([0.0, 200.0], 120.0),
            StackItem::mission(0, [0.0, 300.0], 120.0),
            StackItem::avoid([0.0, 400.0], 90.0),
        ];
        // From 60 m: 60 through the detour, the waypoint's own after it, then the lower.
        let mut low = 60.0;
        let seen: Vec<f64> = climb
            .iter()
            .map(|it| {
                low = it.low_alt_after(low);
                low
            })
            .collect();
        assert_eq!(seen, vec![60.0, 60.0, 120.0, 90.0]);
    }

    #[test]
    fn equal_stacks_have_an_empty_diff() {
        let s = vec![StackItem::mission(0, [0.0, 0.0], 10.0)];
        assert!(diff(&s, &s).is_empty());
    }

    #[test]
    fn replacing_an_avoid_item_rewrites_from_it() {
        // [M0, A, M1] -> [M0, A', A'', M1]: first change at 1, delete 2, write 3.
        let old = vec![
            StackItem::mission(0, [0.0, 0.0], 10.0),
            StackItem::avoid([50.0, 20.0], 10.0),
            StackItem::mission(1, [100.0, 0.0], 10.0),
        ];
        let new = vec![
            old[0],
            StackItem::avoid([30.0, 25.0], 10.0),
            StackItem::avoid([70.0, 25.0], 10.0),
            old[2],
        ];
        let d = diff(&old, &new);
        assert_eq!((d.first_changed, d.remove, d.insert.len()), (Some(1), 2, 3));
        assert_eq!(d.apply(&old), new);
    }
}
