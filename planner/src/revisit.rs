//! Flying a missed waypoint again.
//!
//! The judges count a mission waypoint when the aircraft comes within 100 ft
//! ([`crate::verify::JUDGE_CAPTURE_M`], three dimensions) of it at any time. An autopilot
//! goes on to the next item when it is within its acceptance radius *or* crosses the
//! item's finish line (the line through it across the leg), so an aircraft pushed off its
//! leg (an avoidance, a turn it flew wide, a plan that changed its leg late) can pass a
//! waypoint too wide and the autopilot moves on. [`missed_waypoint`] tells, from the
//! aircraft's recent track, that this has just happened; [`crate::Replan::revisit`] then
//! plans the same item again before the rest, so the autopilot turns back for it.
//!
//! Contract:
//! - Only the item just passed and only a mission waypoint (not an avoid or search item)
//!   is a candidate: `stack[current_index - 1]`, when it was the item pursued at the last
//!   plan (the next fixed item from that plan's current index). The item before the
//!   current one stays there for as long as the planner rewrites the items after it, so
//!   without this an aircraft detouring near a waypoint it captured a minute ago would fly
//!   it again.
//! - At most [`MAX_PASSES`] passes per waypoint: an item with a revisit already planned
//!   (its mission index later in the stack) is not flown again, and neither is one whose
//!   mission index appears [`MAX_PASSES`] times up to it (the first pass and its
//!   revisits). A revisit planned right beside the waypoint can itself go wide: the
//!   aircraft loops back round a turn radius and crosses the finish line tens of metres
//!   off (Webster Field, spline seed 55 with a 15-minute lead-in: 62 m, then 53 m).
//! - Only on evidence: the track must reach back to when the item became the target
//!   (within [`TRACK_GAP_S`]), and the closest approach is taken over the track and the
//!   straight line ahead of its newest point along its newest segment (an aircraft still
//!   closing in may yet capture it).
//! - Pure: the same stack, index and track give the same answer.
//!
//! # Units
//! ENU metres, metres MSL, seconds.

use crate::geometry::Point;
use crate::stack::{ItemKind, StackItem};
use crate::verify::JUDGE_CAPTURE_M;

/// The track may start this long after the item became the target, seconds (a sample
/// period and then some).
pub const TRACK_GAP_S: f64 = 2.0;

/// Passes at a mission waypoint, the first included: a waypoint passed wide is flown
/// again at most `MAX_PASSES - 1` times.
pub const MAX_PASSES: usize = 3;

/// One sample of the aircraft's own track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPoint {
    /// Time, seconds.
    pub t_s: f64,
    /// Position, ENU metres.
    pub p_m: Point,
    /// Altitude, metres MSL.
    pub alt_m: f64,
}

/// A mission waypoint the autopilot has just gone past without capturing it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Missed {
    /// Its index in the stack (`current_index - 1`).
    pub stack_index: usize,
    /// Its index in the mission's waypoints.
    pub mission_index: usize,
    /// The track's closest approach to it, metres (three dimensions; more than
    /// [`JUDGE_CAPTURE_M`]).
    pub closest_m: f64,
}

/// The mission waypoint just passed (`stack[current_index - 1]`) when it was the item
/// pursued at the last plan (`pursued`: its stack index and since when it has been the
/// target, seconds on the track's clock) and `track` (time order, oldest first, from then
/// on) shows the aircraft went by it farther than the judges' capture distance (see the
/// module docs for every condition).
pub fn missed_waypoint(
    stack: &[StackItem],
    current_index: usize,
    pursued: (usize, f64),
    track: &[TrackPoint],
) -> Option<Missed> {
    let k = current_index.checked_sub(1)?;
    let item = stack.get(k)?;
    let mission_index = item.mission_index?;
    let same =
        |i: &StackItem| i.kind == ItemKind::Mission && i.mission_index == Some(mission_index);
    let planned_again = stack[k + 1..].iter().any(same);
    let passes = stack[..=k].iter().filter(|i| same(i)).count();
    if item.kind != ItemKind::Mission || pursued.0 != k || planned_again || passes >= MAX_PASSES {
        return None;
    }
    let [first, .., before, last] = track else {
        return None;
    };
    if first.t_s > pursued.1 + TRACK_GAP_S {
        return None;
    }
    // Flown, and ahead along the newest heading: an aircraft still closing in may yet come
    // within the capture distance.
    let closest_m = track
        .windows(2)
        .map(|w| distance_m(&w[0], &w[1], item, 1.0))
        .fold(distance_m(before, last, item, f64::INFINITY), f64::min);
    (closest_m.is_finite() && closest_m > JUDGE_CAPTURE_M).then_some(Missed {
        stack_index: k,
        mission_index,
        closest_m,
    })
}

/// `stack` with the item at `current_index - 1` flown again: a copy of it at
/// `current_index`, the rest after it. `None` when there is no such item.
pub fn with_revisit(stack: &[StackItem], current_index: usize) -> Option<Vec<StackItem>> {
    let again = *stack.get(current_index.checked_sub(1)?)?;
    let mut out = Vec::with_capacity(stack.len() + 1);
    out.extend_from_slice(&stack[..current_index]);
    out.push(again);
    out.extend_from_slice(stack.get(current_index..).unwrap_or(&[]));
    Some(out)
}

/// Distance from `item` to the points `a + u (b - a)`, `u` in `[0, u_max]` (1: the segment,
/// infinity: the ray from `a` through `b`), three dimensions.
fn distance_m(a: &TrackPoint, b: &TrackPoint, item: &StackItem, u_max: f64) -> f64 {
    let ab = [b.p_m[0] - a.p_m[0], b.p_m[1] - a.p_m[1], b.alt_m - a.alt_m];
    let aw = [
        item.p_m[0] - a.p_m[0],
        item.p_m[1] - a.p_m[1],
        item.alt_m - a.alt_m,
    ];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    let u = if len2 > 0.0 {
        ((aw[0] * ab[0] + aw[1] * ab[1] + aw[2] * ab[2]) / len2).clamp(0.0, u_max)
    } else {
        0.0
    };
    let d = [aw[0] - u * ab[0], aw[1] - u * ab[1], aw[2] - u * ab[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight pass along y = `offset`, x from -200 to `x_end`, at 100 m, 20 m/s,
    /// sampled at 5 Hz.
    fn pass(offset: f64, x_end: f64) -> Vec<TrackPoint> {
        let mut v = Vec::new();
        let mut x = -200.0;
        let mut t = 0.0;
        while x <= x_end + 1e-9 {
            v.push(TrackPoint {
                t_s: t,
                p_m: [x, offset],
                alt_m: 100.0,
            });
            x += 4.0;
            t += 0.2;
        }
        v
    }

    fn stack() -> Vec<StackItem> {
        vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::mission(1, [1000.0, 0.0], 100.0),
        ]
    }

    #[test]
    fn a_pass_wider_than_100_ft_is_missed_and_one_within_is_not() {
        let s = stack();
        let wide = missed_waypoint(&s, 1, (0, 0.0), &pass(35.0, 60.0)).expect("35 m is a miss");
        assert_eq!((wide.stack_index, wide.mission_index), (0, 0));
        assert!((wide.closest_m - 35.0).abs() < 1e-9);
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &pass(30.0, 60.0)), None);
    }

    #[test]
    fn the_altitude_counts_in_the_distance() {
        // 20 m off sideways, 25 m above: 32.0 m in three dimensions, a miss.
        let s = stack();
        let mut t = pass(20.0, 60.0);
        for p in &mut t {
            p.alt_m = 125.0;
        }
        let m = missed_waypoint(&s, 1, (0, 0.0), &t).expect("32 m in 3-D is a miss");
        assert!((m.closest_m - 20f64.hypot(25.0)).abs() < 1e-9);
    }

    #[test]
    fn no_evidence_no_revisit() {
        let s = stack();
        // The track starts 4 s after the item became the target (the pass may be before).
        let late: Vec<TrackPoint> = pass(35.0, 200.0)
            .into_iter()
            .filter(|p| p.t_s >= 4.0)
            .collect();
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &late), None);
        // Targeted 2.5 s in: the track starts within a sample gap of that, so it counts.
        assert!(missed_waypoint(&s, 1, (0, 2.5), &late).is_some());
        // Still closing in 35 m off the line: a miss ahead; 25 m off: it may yet capture.
        let ahead = missed_waypoint(&s, 1, (0, 0.0), &pass(35.0, -40.0)).expect("a miss ahead");
        assert!((ahead.closest_m - 35.0).abs() < 1e-9);
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &pass(25.0, -40.0)), None);
        // A track that came within 100 ft before turning away: captured.
        let mut near_then_far = pass(20.0, 0.0);
        near_then_far.extend(pass(20.0, 0.0).iter().map(|p| TrackPoint {
            t_s: p.t_s + 100.0,
            p_m: [-p.p_m[0], 300.0],
            alt_m: 100.0,
        }));
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &near_then_far), None);
        // No track, or one point.
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &[]), None);
        assert_eq!(
            missed_waypoint(&s, 1, (0, 0.0), &pass(35.0, 60.0)[..1]),
            None
        );
    }

    #[test]
    fn only_a_mission_waypoint_just_passed_and_at_most_three_times() {
        let track = pass(35.0, 60.0);
        // Nothing passed yet.
        assert_eq!(missed_waypoint(&stack(), 0, (0, 0.0), &track), None);
        // An avoid item just passed.
        let avoid = vec![
            StackItem::avoid([0.0, 0.0], 100.0),
            StackItem::mission(1, [1000.0, 0.0], 100.0),
        ];
        assert_eq!(missed_waypoint(&avoid, 1, (0, 0.0), &track), None);
        // Not the item pursued at the last plan: passed before it.
        assert_eq!(missed_waypoint(&stack(), 1, (1, 0.0), &track), None);
        // A revisit already planned (mission index 0 later in the stack): not again.
        let again = with_revisit(&stack(), 1).expect("an item to revisit");
        assert_eq!(again.len(), 3);
        assert_eq!(again[1], again[0]);
        assert_eq!(again[2], stack()[1]);
        assert_eq!(missed_waypoint(&again, 1, (0, 0.0), &track), None);
        // The revisit passed wide too: flown a third time, and no more.
        let second = missed_waypoint(&again, 2, (1, 0.0), &track).expect("a second revisit");
        assert_eq!((second.stack_index, second.mission_index), (1, 0));
        let thrice = with_revisit(&again, 2).expect("a third pass");
        assert_eq!(thrice.len(), 4);
        assert_eq!(missed_waypoint(&thrice, 3, (2, 0.0), &track), None);
        assert_eq!(MAX_PASSES, 3);
        // The index past the end names no item after it, and a revisit of the last item
        // appends it.
        assert!(missed_waypoint(&stack(), 3, (2, 0.0), &track).is_none());
        let last = with_revisit(&stack(), 2).expect("the last item");
        assert_eq!(last.len(), 3);
        assert_eq!(last[2], stack()[1]);
        assert_eq!(with_revisit(&stack(), 0), None);
    }
}
