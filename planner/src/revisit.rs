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
//!   flight ahead of its newest point (an aircraft still closing in may yet capture it):
//!   [`ANTICIPATE_S`] seconds turning at the turn radius from its newest heading toward the
//!   item it now flies to, as the autopilot does once it has switched (with no turn radius,
//!   the straight line ahead along its newest segment). The straight line alone took an
//!   aircraft that switched 38 m short, heading past the waypoint as it turned away for
//!   the next one, for a capture 26 m off; it went by 31.4 m off (Webster Field, spline
//!   seed 193).
//! - The flight ahead is a forecast made before the plan, which may change the item the
//!   autopilot flies to. A pass only it would capture is watched ([`judge_pass`],
//!   [`Watch`]): judged again at the next plans with the newer track, while the item
//!   stays the one before the current index, the flight ahead counting until
//!   [`ANTICIPATE_S`] after the first verdict's newest sample and the track alone after.
//! - Pure: the same stack, index, track (and watch) give the same answer.
//!
//! # Units
//! ENU metres, metres MSL, seconds.

use crate::geometry::Point;
use crate::stack::{ItemKind, StackItem, next_fixed};
use crate::verify::JUDGE_CAPTURE_M;

/// The track may start this long after the item became the target, seconds (a sample
/// period and then some).
pub const TRACK_GAP_S: f64 = 2.0;

/// How long the flight ahead of the newest sample is followed for the closest approach,
/// seconds ([`missed_waypoint`]).
pub const ANTICIPATE_S: f64 = 6.0;

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
/// module docs for every condition). `turn_radius_m` is the aircraft's (0: the flight
/// ahead is taken straight). A pass the flight ahead may yet capture is `None` here;
/// [`judge_pass`] watches it over the next plans.
pub fn missed_waypoint(
    stack: &[StackItem],
    current_index: usize,
    pursued: (usize, f64),
    track: &[TrackPoint],
    turn_radius_m: f64,
) -> Option<Missed> {
    match judge_pass(
        stack,
        current_index,
        Some(pursued),
        None,
        track,
        turn_radius_m,
    ) {
        Some(Pass::Missed(m)) => Some(m),
        _ => None,
    }
}

/// A mission waypoint the autopilot has gone past, which the track has not captured but
/// the flight ahead of it still may: judged again at the next plans until `until_s`, and
/// then on the track alone ([`judge_pass`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Watch {
    /// Its index in the stack (the item before the current one while it is watched).
    pub stack_index: usize,
    /// Since when it was the target, seconds on the track's clock.
    pub since_s: f64,
    /// Until when the flight ahead counts, seconds on the track's clock: the first verdict's
    /// newest sample plus [`ANTICIPATE_S`] (the flight ahead it read).
    pub until_s: f64,
}

/// What the track says of the mission waypoint the autopilot has just gone past.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pass {
    /// Passed wider than the judges' capture distance, along the track and the flight ahead
    /// (ahead only while the watch lasts): fly it again.
    Missed(Missed),
    /// Not captured along the track, but the flight ahead comes within the capture distance:
    /// judged again at the next plan, with this watch.
    Watch(Watch),
}

/// The verdict on the mission waypoint just passed (`stack[current_index - 1]`), judged the
/// way [`missed_waypoint`] judges it, for a caller that keeps `watch` between plans: the
/// waypoint under `watch`, when it is still the item before the current one, or else the
/// item `pursued` at the last plan. The flight ahead of the track's newest sample (the
/// autopilot's turn for the item it now flies to, [`ANTICIPATE_S`]) counts only until the
/// watch ends: a pass it alone would capture is watched, not missed, and the verdict
/// comes with the next track. It is a forecast made before the plan that may change the
/// item the autopilot flies to: on Webster Field (spline seed 124) the turn for an avoid
/// item 190 m north would have passed 18 m from waypoint 2, the plan then sent the
/// aircraft south-west, and the waypoint, gone past 40 m off, was never flown again.
/// `None`: nothing to judge (no such waypoint, see the module docs) or captured.
pub fn judge_pass(
    stack: &[StackItem],
    current_index: usize,
    pursued: Option<(usize, f64)>,
    watch: Option<Watch>,
    track: &[TrackPoint],
    turn_radius_m: f64,
) -> Option<Pass> {
    let k = current_index.checked_sub(1)?;
    let (since, until) = match watch.filter(|w| w.stack_index == k) {
        Some(w) => (w.since_s, Some(w.until_s)),
        None => (pursued.filter(|p| p.0 == k)?.1, None),
    };
    let item = stack.get(k)?;
    let mission_index = item.mission_index?;
    let same =
        |i: &StackItem| i.kind == ItemKind::Mission && i.mission_index == Some(mission_index);
    let planned_again = stack[k + 1..].iter().any(same);
    let passes = stack[..=k].iter().filter(|i| same(i)).count();
    if item.kind != ItemKind::Mission || planned_again || passes >= MAX_PASSES {
        return None;
    }
    let [first, .., before, last] = track else {
        return None;
    };
    if first.t_s > since + TRACK_GAP_S {
        return None;
    }
    let flown_m = track
        .windows(2)
        .map(|w| distance_m(&w[0], &w[1], item, 1.0))
        .fold(f64::INFINITY, f64::min);
    if !flown_m.is_finite() || flown_m <= JUDGE_CAPTURE_M {
        return None;
    }
    let until_s = until.unwrap_or(last.t_s + ANTICIPATE_S);
    // Ahead, while the watch lasts: an aircraft still closing in may yet come within the
    // capture distance.
    let next = stack.get(current_index).map(|i| i.p_m);
    let ahead = if last.t_s < until_s {
        ahead_m(before, last, item, next, turn_radius_m)
    } else {
        f64::INFINITY
    };
    if ahead <= JUDGE_CAPTURE_M {
        return Some(Pass::Watch(Watch {
            stack_index: k,
            since_s: since,
            until_s,
        }));
    }
    Some(Pass::Missed(Missed {
        stack_index: k,
        mission_index,
        closest_m: flown_m.min(ahead),
    }))
}

/// Within this distance of the aircraft's track (three dimensions) a mission waypoint
/// ahead counts as captured on the way ([`captured_on_the_way`]), metres: the judges'
/// 100 ft less 5.5 m for the telemetry's own error.
pub const ON_THE_WAY_M: f64 = 25.0;

/// For the item the autopilot flies toward, only the track of this many seconds before its
/// newest sample counts ([`captured_on_the_way`]), seconds: a pass within 25 m is followed
/// within a second or two by the autopilot's own switch (within its acceptance radius or
/// past the finish line), so older evidence with the item still flown toward is a circle
/// round it, and a server holds this much of the newest telemetry without reading more.
pub const FLOWN_TOWARD_S: f64 = 5.0;

/// A mission waypoint ahead that the aircraft has already captured, on its way to it or to
/// an avoid item before it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Captured {
    /// Its index in the stack (`current_index` or after).
    pub stack_index: usize,
    /// Its index in the mission's waypoints.
    pub mission_index: usize,
    /// The track's closest approach to it, metres (three dimensions; at most
    /// [`ON_THE_WAY_M`]).
    pub closest_m: f64,
}

/// The next fixed item of `stack` (from `current_index` on), when it is a mission waypoint
/// (the item the autopilot flies toward, or one behind avoid items), it was the item
/// pursued at the last plan (`pursued`: its stack index and since when it has been the
/// target, seconds on the track's clock), and `track` (time order, from then on) came
/// within [`ON_THE_WAY_M`] of it. The judges count it there, but the autopilot switches
/// only at the item it flies toward, within its acceptance radius or past the item's finish
/// line:
/// - behind an avoid item, without this the plan goes on routing the aircraft back to a
///   waypoint it already has (Webster Field, spline seed 218: waypoint 1 passed 11 m off on
///   the way to an avoid item at 7 s, then still pending, and detoured round, for 45 s until
///   a sphere was hit);
/// - flown toward, the plan turns for the next item up to 15 m sooner than the autopilot's
///   10 m would (Webster Field with spline spheres at 18 m/s, seeds 0-199: 6.8 s a run
///   shorter, median path ratio 1.208 -> 1.189, no hit either way; README, "The waypoint
///   flown toward, captured on the way").
///
/// Only evidence since it became the target counts (waypoints are captured in order), for
/// the item flown toward only that of the last [`FLOWN_TOWARD_S`], and the last item of a
/// stack is never skipped (the mission would be left with nothing to fly).
pub fn captured_on_the_way(
    stack: &[StackItem],
    current_index: usize,
    pursued: (usize, f64),
    track: &[TrackPoint],
) -> Option<Captured> {
    let j = next_fixed(stack, current_index)?;
    let item = stack[j];
    let mission_index = item.mission_index?;
    if item.kind != ItemKind::Mission || pursued.0 != j || j + 1 >= stack.len() {
        return None;
    }
    let since = match track.last() {
        Some(last) if j == current_index => pursued.1.max(last.t_s - FLOWN_TOWARD_S),
        _ => pursued.1,
    };
    let from = track.partition_point(|p| p.t_s < since);
    let closest_m = match &track[from..] {
        [] => return None,
        [only] => distance_m(only, only, &item, 0.0),
        since => since
            .windows(2)
            .map(|w| distance_m(&w[0], &w[1], &item, 1.0))
            .fold(f64::INFINITY, f64::min),
    };
    (closest_m <= ON_THE_WAY_M).then_some(Captured {
        stack_index: j,
        mission_index,
        closest_m,
    })
}

/// `stack` without the items from `current_index` through `captured` (the avoid items
/// before a waypoint captured on the way, and the waypoint): the item after it becomes the
/// one at `current_index`. `None` when `captured` is not such an index.
pub fn with_captured_skipped(
    stack: &[StackItem],
    current_index: usize,
    captured: usize,
) -> Option<Vec<StackItem>> {
    if captured < current_index || captured + 1 >= stack.len() {
        return None;
    }
    let mut out = Vec::with_capacity(stack.len() - (captured + 1 - current_index));
    out.extend_from_slice(&stack[..current_index]);
    out.extend_from_slice(&stack[captured + 1..]);
    Some(out)
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
/// The closest the flight ahead of `last` comes to `item` within [`ANTICIPATE_S`]: from
/// `last` at the speed and heading of `before -> last`, turning at `turn_radius_m` toward
/// `next` (the item the autopilot now flies to) and then straight at it, at `last`'s
/// altitude. Without a turn radius or a next item, the straight line ahead.
fn ahead_m(
    before: &TrackPoint,
    last: &TrackPoint,
    item: &StackItem,
    next: Option<Point>,
    turn_radius_m: f64,
) -> f64 {
    let (dx, dy) = (last.p_m[0] - before.p_m[0], last.p_m[1] - before.p_m[1]);
    let dt = last.t_s - before.t_s;
    let v = dx.hypot(dy) / dt;
    let Some(next) = next.filter(|_| turn_radius_m > 0.0 && dt > 0.0 && v > 0.0) else {
        return distance_m(before, last, item, f64::INFINITY);
    };
    let dz = item.alt_m - last.alt_m;
    let dist = |p: Point| (p[0] - item.p_m[0]).hypot(p[1] - item.p_m[1]).hypot(dz);
    const STEP_S: f64 = 0.1;
    let w_max = v / turn_radius_m * STEP_S;
    let mut th = dy.atan2(dx);
    let mut p = last.p_m;
    let mut best = dist(p);
    for _ in 0..(ANTICIPATE_S / STEP_S).round() as usize {
        let to = (next[1] - p[1]).atan2(next[0] - p[0]);
        let err = (to - th + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        th += err.clamp(-w_max, w_max);
        p = [p[0] + v * STEP_S * th.cos(), p[1] + v * STEP_S * th.sin()];
        best = best.min(dist(p));
    }
    best
}

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
        let wide =
            missed_waypoint(&s, 1, (0, 0.0), &pass(35.0, 60.0), 0.0).expect("35 m is a miss");
        assert_eq!((wide.stack_index, wide.mission_index), (0, 0));
        assert!((wide.closest_m - 35.0).abs() < 1e-9);
        assert_eq!(
            missed_waypoint(&s, 1, (0, 0.0), &pass(30.0, 60.0), 0.0),
            None
        );
    }

    #[test]
    fn the_altitude_counts_in_the_distance() {
        // 20 m off sideways, 25 m above: 32.0 m in three dimensions, a miss.
        let s = stack();
        let mut t = pass(20.0, 60.0);
        for p in &mut t {
            p.alt_m = 125.0;
        }
        let m = missed_waypoint(&s, 1, (0, 0.0), &t, 0.0).expect("32 m in 3-D is a miss");
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
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &late, 0.0), None);
        // Targeted 2.5 s in: the track starts within a sample gap of that, so it counts.
        assert!(missed_waypoint(&s, 1, (0, 2.5), &late, 0.0).is_some());
        // Still closing in 35 m off the line: a miss ahead; 25 m off: it may yet capture.
        let ahead =
            missed_waypoint(&s, 1, (0, 0.0), &pass(35.0, -40.0), 0.0).expect("a miss ahead");
        assert!((ahead.closest_m - 35.0).abs() < 1e-9);
        assert_eq!(
            missed_waypoint(&s, 1, (0, 0.0), &pass(25.0, -40.0), 0.0),
            None
        );
        // A track that came within 100 ft before turning away: captured.
        let mut near_then_far = pass(20.0, 0.0);
        near_then_far.extend(pass(20.0, 0.0).iter().map(|p| TrackPoint {
            t_s: p.t_s + 100.0,
            p_m: [-p.p_m[0], 300.0],
            alt_m: 100.0,
        }));
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &near_then_far, 0.0), None);
        // No track, or one point.
        assert_eq!(missed_waypoint(&s, 1, (0, 0.0), &[], 0.0), None);
        assert_eq!(
            missed_waypoint(&s, 1, (0, 0.0), &pass(35.0, 60.0)[..1], 0.0),
            None
        );
    }

    /// Northward along x = `x` up to y = `y_end`, at 100 m, 20 m/s, sampled at 5 Hz.
    fn north(x: f64, y_end: f64) -> Vec<TrackPoint> {
        (0..=100)
            .map(f64::from)
            .take_while(|k| -200.0 + 4.0 * k <= y_end + 1e-9)
            .map(|k| TrackPoint {
                t_s: 0.2 * k,
                p_m: [x, -200.0 + 4.0 * k],
                alt_m: 100.0,
            })
            .collect()
    }

    #[test]
    fn the_flight_ahead_turns_for_the_item_the_autopilot_has_switched_to() {
        // The autopilot switched from waypoint 0 (at the origin) to the next item while the
        // aircraft, heading north 27 m west of it, was still 39 m short. The straight line
        // ahead passes 27 m off; turning (35 m radius) for an item to the west-south-west it
        // comes no closer than 32 m: a miss (Webster Field, spline seed 193).
        let away = vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::mission(1, [-250.0, -100.0], 100.0),
        ];
        let track = north(-27.0, -28.0);
        assert_eq!(missed_waypoint(&away, 1, (0, 0.0), &track, 0.0), None);
        let m = missed_waypoint(&away, 1, (0, 0.0), &track, 35.0).expect("it turns away");
        assert!(
            m.closest_m > 32.0 && m.closest_m <= 27f64.hypot(28.0),
            "{m:?}"
        );
        // 35 m west and 20 m short, the next item to the north-east: the straight line
        // misses, the turn toward it (round a centre 20 m south of the waypoint) captures.
        let toward = vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::mission(1, [200.0, 200.0], 100.0),
        ];
        let track = north(-35.0, -20.0);
        assert!(missed_waypoint(&toward, 1, (0, 0.0), &track, 0.0).is_some());
        assert_eq!(missed_waypoint(&toward, 1, (0, 0.0), &track, 35.0), None);
    }

    #[test]
    fn only_a_mission_waypoint_just_passed_and_at_most_three_times() {
        let track = pass(35.0, 60.0);
        // Nothing passed yet.
        assert_eq!(missed_waypoint(&stack(), 0, (0, 0.0), &track, 0.0), None);
        // An avoid item just passed.
        let avoid = vec![
            StackItem::avoid([0.0, 0.0], 100.0),
            StackItem::mission(1, [1000.0, 0.0], 100.0),
        ];
        assert_eq!(missed_waypoint(&avoid, 1, (0, 0.0), &track, 0.0), None);
        // Not the item pursued at the last plan: passed before it.
        assert_eq!(missed_waypoint(&stack(), 1, (1, 0.0), &track, 0.0), None);
        // A revisit already planned (mission index 0 later in the stack): not again.
        let again = with_revisit(&stack(), 1).expect("an item to revisit");
        assert_eq!(again.len(), 3);
        assert_eq!(again[1], again[0]);
        assert_eq!(again[2], stack()[1]);
        assert_eq!(missed_waypoint(&again, 1, (0, 0.0), &track, 0.0), None);
        // The revisit passed wide too: flown a third time, and no more.
        let second = missed_waypoint(&again, 2, (1, 0.0), &track, 0.0).expect("a second revisit");
        assert_eq!((second.stack_index, second.mission_index), (1, 0));
        let thrice = with_revisit(&again, 2).expect("a third pass");
        assert_eq!(thrice.len(), 4);
        assert_eq!(missed_waypoint(&thrice, 3, (2, 0.0), &track, 0.0), None);
        assert_eq!(MAX_PASSES, 3);
        // The index past the end names no item after it, and a revisit of the last item
        // appends it.
        assert!(missed_waypoint(&stack(), 3, (2, 0.0), &track, 0.0).is_none());
        let last = with_revisit(&stack(), 2).expect("the last item");
        assert_eq!(last.len(), 3);
        assert_eq!(last[2], stack()[1]);
        assert_eq!(with_revisit(&stack(), 0), None);
    }

    #[test]
    fn a_pass_the_flight_ahead_may_yet_capture_is_watched_then_judged_on_the_track() {
        // 35 m west of waypoint 0 and 20 m short, heading north: the track has not captured
        // it (40.3 m at its closest), the turn for the next item, to the north-east, would.
        let toward = vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::mission(1, [200.0, 200.0], 100.0),
        ];
        let track = north(-35.0, -20.0);
        let last = track.last().expect("a track").t_s;
        let Some(Pass::Watch(w)) = judge_pass(&toward, 1, Some((0, 0.0)), None, &track, 35.0)
        else {
            panic!("watched");
        };
        assert_eq!(w.stack_index, 0);
        assert_eq!((w.since_s, w.until_s), (0.0, last + ANTICIPATE_S));
        // `missed_waypoint` says nothing yet, as before the watch.
        assert_eq!(missed_waypoint(&toward, 1, (0, 0.0), &track, 35.0), None);
        // A second later: the plan sent the aircraft west (the item it now flies to is far
        // to the west-south-west), and it flew west: missed, judged under the watch even
        // though the item pursued at the last plan is now the next one.
        let mut west = track.clone();
        west.extend((1..=5).map(|k| TrackPoint {
            t_s: last + 0.2 * f64::from(k),
            p_m: [-35.0 - 4.0 * f64::from(k), -20.0],
            alt_m: 100.0,
        }));
        let away = vec![
            StackItem::mission(0, [0.0, 0.0], 100.0),
            StackItem::avoid([-250.0, -100.0], 100.0),
            StackItem::mission(1, [200.0, 200.0], 100.0),
        ];
        let Some(Pass::Missed(m)) = judge_pass(&away, 1, Some((2, last)), Some(w), &west, 35.0)
        else {
            panic!("missed");
        };
        assert_eq!((m.stack_index, m.mission_index), (0, 0));
        assert!((m.closest_m - 35f64.hypot(20.0)).abs() < 1e-9, "{m:?}");
        // Without the watch that pass is not judged: it is not the item pursued.
        assert_eq!(
            judge_pass(&away, 1, Some((2, last)), None, &west, 35.0),
            None
        );
        // Turned for it instead, within 11 m of it: captured, the watch ends.
        let mut back = track.clone();
        back.push(TrackPoint {
            t_s: last + 1.0,
            p_m: [-10.0, 5.0],
            alt_m: 100.0,
        });
        assert_eq!(judge_pass(&toward, 1, None, Some(w), &back, 35.0), None);
        // Once the watch is over, the flight ahead no longer counts: the same track that
        // was watched is now a miss.
        let over = Watch { until_s: last, ..w };
        assert!(matches!(
            judge_pass(&toward, 1, None, Some(over), &track, 35.0),
            Some(Pass::Missed(_))
        ));
        // A watch on another item (the autopilot went past one more since): not judged.
        assert_eq!(judge_pass(&toward, 2, None, Some(w), &track, 35.0), None);
    }

    /// An avoid item, then mission waypoint 0 at the origin, then waypoint 1.
    fn detour() -> Vec<StackItem> {
        let mut s = vec![StackItem::avoid([200.0, 300.0], 100.0)];
        s.extend(stack());
        s
    }

    #[test]
    fn a_waypoint_passed_within_25_m_on_the_way_to_an_avoid_item_is_captured() {
        let s = detour();
        // Pursued (stack index 1) since t = 0; the track passes 20 m off it.
        let c = captured_on_the_way(&s, 0, (1, 0.0), &pass(20.0, 60.0)).expect("captured");
        assert_eq!((c.stack_index, c.mission_index), (1, 0));
        assert!((c.closest_m - 20.0).abs() < 1e-9, "{c:?}");
        // 28 m off is within the judges' 100 ft but not within the margin for the
        // telemetry's error; 25 m exactly counts.
        assert_eq!(
            captured_on_the_way(&s, 0, (1, 0.0), &pass(28.0, 60.0)),
            None
        );
        assert!(captured_on_the_way(&s, 0, (1, 0.0), &pass(ON_THE_WAY_M, 60.0)).is_some());
        // In three dimensions: 20 m sideways and 20 m above is 28.3 m.
        let mut high = pass(20.0, 60.0);
        for p in &mut high {
            p.alt_m = 120.0;
        }
        assert_eq!(captured_on_the_way(&s, 0, (1, 0.0), &high), None);
        // The pass between two samples counts (segments, not only samples): samples 80 m
        // apart, none of them within 25 m of the waypoint.
        let sparse: Vec<TrackPoint> = pass(20.0, 60.0).into_iter().step_by(20).collect();
        assert!(
            sparse
                .iter()
                .all(|p| p.p_m[0].hypot(p.p_m[1]) > ON_THE_WAY_M),
            "{sparse:?}"
        );
        assert!(captured_on_the_way(&s, 0, (1, 0.0), &sparse).is_some());
        // Skipped: the avoid item and the waypoint go; the next waypoint is at index 0.
        let skipped = with_captured_skipped(&s, 0, c.stack_index).expect("skipped");
        assert_eq!(skipped, vec![s[2]]);
    }

    #[test]
    fn the_waypoint_flown_toward_is_captured_20_m_short_of_it() {
        // Waypoint 0 at the origin is the item the autopilot flies toward; the aircraft
        // comes straight at it and is 20 m short, 10 m outside the autopilot's acceptance
        // radius and short of the finish line, so the autopilot has not switched.
        let s = stack();
        let short = pass(0.0, -20.0);
        let c = captured_on_the_way(&s, 0, (0, 0.0), &short).expect("captured");
        assert_eq!((c.stack_index, c.mission_index), (0, 0));
        assert!((c.closest_m - 20.0).abs() < 1e-9, "{c:?}");
        // Skipped: waypoint 1 is the item flown toward now.
        assert_eq!(
            with_captured_skipped(&s, 0, c.stack_index).expect("skipped"),
            vec![s[1]]
        );
        // 30 m short is within the judges' 100 ft but not within the margin: kept.
        assert_eq!(
            captured_on_the_way(&s, 0, (0, 0.0), &pass(0.0, -30.0)),
            None
        );
        // Only the last 5 s of the track count for it: 20 m short 6 s before the newest
        // sample (then 300 m out, circling) is too old; 4 s before still counts.
        let later = |after_s: f64| {
            let mut t = short.clone();
            let end = t.last().expect("a track").t_s;
            t.push(TrackPoint {
                t_s: end + after_s,
                p_m: [300.0, 0.0],
                alt_m: 100.0,
            });
            t
        };
        assert_eq!(captured_on_the_way(&s, 0, (0, 0.0), &later(6.0)), None);
        assert!(captured_on_the_way(&s, 0, (0, 0.0), &later(4.0)).is_some());
        // Behind an avoid item the whole track since the pursuit began counts.
        let d = detour();
        assert!(captured_on_the_way(&d, 0, (1, 0.0), &later(60.0)).is_some());
        // Behind the avoid item of a detour, the same waypoint is flown toward once the
        // avoid item is passed (current index 1) and is captured the same way.
        let c = captured_on_the_way(&d, 1, (1, 0.0), &short).expect("captured");
        assert_eq!(c.stack_index, 1);
        assert_eq!(
            with_captured_skipped(&d, 1, 1).expect("skipped"),
            vec![d[0], d[2]]
        );
        // The last item of the stack is never skipped, flown toward or not.
        assert_eq!(
            captured_on_the_way(&s, 1, (1, 0.0), &pass(0.0, 980.0)),
            None
        );
    }

    #[test]
    fn only_evidence_since_it_became_the_target_counts() {
        let s = detour();
        let near = pass(20.0, 60.0);
        // The pass was before the waypoint became the target (it ends at t = 13 s).
        assert_eq!(captured_on_the_way(&s, 0, (1, 20.0), &near), None);
        assert_eq!(captured_on_the_way(&s, 1, (1, 20.0), &near), None);
        // Not the item pursued at the last plan.
        assert_eq!(captured_on_the_way(&s, 0, (2, 0.0), &near), None);
        // An avoid item ahead is not a waypoint; the last item is never skipped.
        let last = vec![
            StackItem::avoid([200.0, 300.0], 100.0),
            StackItem::mission(0, [0.0, 0.0], 100.0),
        ];
        assert_eq!(captured_on_the_way(&last, 0, (1, 0.0), &near), None);
        assert_eq!(with_captured_skipped(&last, 0, 1), None);
        // No track.
        assert_eq!(captured_on_the_way(&s, 0, (1, 0.0), &[]), None);
        // History before the current index stays: two avoid items flown, then the detour.
        let mut long = vec![StackItem::mission(5, [-500.0, 0.0], 100.0)];
        long.extend(detour());
        let c = captured_on_the_way(&long, 1, (2, 0.0), &near).expect("captured");
        assert_eq!(c.stack_index, 2);
        assert_eq!(
            with_captured_skipped(&long, 1, 2).expect("skipped"),
            vec![long[0], long[3]]
        );
    }
}
