//! Judge-style scoring (as the interop server did it): the aircraft's telemetry is
//! interpolated every 0.1 s across gaps of at most 5 s; a sphere is hit when an interpolated
//! point lies within its radius (3-D distance, the sphere's true position at that time), a
//! cylinder when a point lies within its radius horizontally and at or below its top; per
//! class the score is `(fraction of obstacles not hit)^3`; a waypoint is captured when a
//! point comes within 100 ft (30.48 m, 3-D). Also: minimum clearance to any obstacle surface
//! and time spent outside the fly zone or its altitude band.
//!
//! The interop server of 2019-2021 (the one whose JSON `tests/fixtures/interop` holds) also
//! grades each waypoint by how close it was passed and counts only waypoints flown in
//! order: of every sequence of passes that reaches the waypoints in their mission order
//! (any may be left out, so the pattern can be taken up again), the best scores each
//! waypoint in it `max(0, 1 - d / 100 ft)`, `d` the pass's closest approach; the run's
//! score is that sum ([`in_order_waypoint_score`], [`JudgeReport::waypoint_score`]).
//!
//! # Units
//! Seconds, ENU metres, metres MSL.

use serde::{Deserialize, Serialize};

use crate::geometry::{P2, point_in_polygon, xy};
use crate::mission::{Cylinder, Mission, altitude_band_m, fly_zone};

/// Interpolation step of the judges, seconds.
pub const JUDGE_STEP_S: f64 = 0.1;
/// Longest telemetry gap the judges interpolated across, seconds.
pub const JUDGE_MAX_GAP_S: f64 = 5.0;
/// Waypoint capture distance, metres (100 ft).
pub const WAYPOINT_CAPTURE_M: f64 = 30.48;

/// Where the moving spheres truly are.
pub trait SphereTruth {
    /// Number of spheres.
    fn sphere_count(&self) -> usize;
    /// Centre (ENU metres, MSL) and radius (metres) of sphere `i` at `t_s`.
    fn sphere_at(&self, i: usize, t_s: f64) -> ([f64; 3], f64);
}

impl SphereTruth for crate::scenario::Scenario {
    fn sphere_count(&self) -> usize {
        self.spheres.len()
    }
    fn sphere_at(&self, i: usize, t_s: f64) -> ([f64; 3], f64) {
        let s = &self.spheres[i];
        (s.track.at(t_s), s.radius_m)
    }
}

/// The judges' points: every telemetry sample, plus points every 0.1 s between consecutive
/// samples at most 5 s apart (linear interpolation).
pub fn interpolate(telemetry: &[(f64, [f64; 3])]) -> Vec<(f64, [f64; 3])> {
    let mut out = Vec::with_capacity(telemetry.len() * 4);
    for w in telemetry.windows(2) {
        let ((t0, a), (t1, b)) = (w[0], w[1]);
        out.push((t0, a));
        let gap = t1 - t0;
        if gap > JUDGE_MAX_GAP_S || gap <= 0.0 {
            continue;
        }
        let mut k = 1;
        loop {
            let t = t0 + f64::from(k) * JUDGE_STEP_S;
            if t >= t1 - 1e-9 {
                break;
            }
            let f = (t - t0) / gap;
            out.push((
                t,
                [
                    a[0] + (b[0] - a[0]) * f,
                    a[1] + (b[1] - a[1]) * f,
                    a[2] + (b[2] - a[2]) * f,
                ],
            ));
            k += 1;
        }
    }
    if let Some(last) = telemetry.last() {
        out.push(*last);
    }
    out
}

/// What the judges would have scored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JudgeReport {
    /// Per moving sphere: hit?
    pub sphere_hits: Vec<bool>,
    /// Per cylinder: hit?
    pub cylinder_hits: Vec<bool>,
    /// `(fraction of spheres not hit)^3` (1 with no spheres).
    pub sphere_score: f64,
    /// `(fraction of cylinders not hit)^3` (1 with no cylinders).
    pub cylinder_score: f64,
    /// Per mission waypoint: captured?
    pub waypoints_captured: Vec<bool>,
    /// The interop server's in-order waypoint score: the sum over the best in-order
    /// sequence of passes of `max(0, 1 - d / 100 ft)` ([`in_order_waypoint_score`]); at
    /// most the number of waypoints.
    pub waypoint_score: f64,
    /// Smallest distance from a judged point to any obstacle surface (negative inside), metres.
    pub min_clearance_m: f64,
    /// Seconds of judged points outside the fly zone or its altitude band.
    pub boundary_violation_s: f64,
    /// Number of separate excursions out of the fly zone.
    pub boundary_excursions: usize,
}

/// `(fraction not hit)^3`.
pub fn class_score(hits: &[bool]) -> f64 {
    if hits.is_empty() {
        return 1.0;
    }
    let not_hit = hits.iter().filter(|h| !**h).count() as f64 / hits.len() as f64;
    not_hit.powi(3)
}

/// Clearance from `p` to a cylinder's surface (negative inside): horizontal when at or below
/// the top, else the distance to the top disc.
pub fn cylinder_clearance_m(p: [f64; 3], c: &Cylinder) -> f64 {
    let h = ((p[0] - c.center_m[0]).powi(2) + (p[1] - c.center_m[1]).powi(2)).sqrt() - c.radius_m;
    if p[2] <= c.top_m {
        h
    } else {
        (h.max(0.0).powi(2) + (p[2] - c.top_m).powi(2)).sqrt()
    }
}

/// Scores aircraft telemetry `(t, position)` in time order.
pub fn judge(
    telemetry: &[(f64, [f64; 3])],
    spheres: &dyn SphereTruth,
    mission: &Mission,
) -> JudgeReport {
    let waypoints_m: Vec<[f64; 3]> = mission
        .waypoints
        .iter()
        .map(|w| [w.p_m[0], w.p_m[1], w.alt_m])
        .collect();
    judge_points(
        &interpolate(telemetry),
        spheres,
        &mission.cylinders,
        &waypoints_m,
        Some(mission),
    )
}

/// Scores already interpolated points; `mission` (optional) supplies the fly zone.
pub fn judge_points(
    points: &[(f64, [f64; 3])],
    spheres: &dyn SphereTruth,
    cylinders: &[Cylinder],
    waypoints_m: &[[f64; 3]],
    mission: Option<&Mission>,
) -> JudgeReport {
    let ns = spheres.sphere_count();
    let mut sphere_hits = vec![false; ns];
    let mut cylinder_hits = vec![false; cylinders.len()];
    let mut waypoints_captured = vec![false; waypoints_m.len()];
    // Every judged point within 100 ft of a waypoint, in time order: (waypoint, grade).
    let mut passes: Vec<(usize, f64)> = Vec::new();
    let mut min_clearance_m = f64::INFINITY;
    let mut boundary_violation_s = 0.0;
    let mut boundary_excursions = 0;
    let mut was_out = false;
    for &(t, p) in points {
        for i in 0..ns {
            let (c, r) = spheres.sphere_at(i, t);
            let d = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
            if d <= r {
                sphere_hits[i] = true;
            }
            min_clearance_m = min_clearance_m.min(d - r);
        }
        for (k, c) in cylinders.iter().enumerate() {
            let cl = cylinder_clearance_m(p, c);
            if cl <= 0.0 {
                cylinder_hits[k] = true;
            }
            min_clearance_m = min_clearance_m.min(cl);
        }
        for (k, w) in waypoints_m.iter().enumerate() {
            let d = ((p[0] - w[0]).powi(2) + (p[1] - w[1]).powi(2) + (p[2] - w[2]).powi(2)).sqrt();
            if d <= WAYPOINT_CAPTURE_M {
                waypoints_captured[k] = true;
                passes.push((k, 1.0 - d / WAYPOINT_CAPTURE_M));
            }
        }
        if let Some(m) = mission {
            let (beyond_boundary, outside_band) = outside_zone(m, p);
            let out = beyond_boundary || outside_band;
            if out {
                boundary_violation_s += JUDGE_STEP_S;
                if !was_out {
                    boundary_excursions += 1;
                }
            }
            was_out = out;
        }
    }
    JudgeReport {
        sphere_score: class_score(&sphere_hits),
        cylinder_score: class_score(&cylinder_hits),
        sphere_hits,
        cylinder_hits,
        waypoint_score: in_order_waypoint_score(&passes, waypoints_m.len()),
        waypoints_captured,
        min_clearance_m,
        boundary_violation_s,
        boundary_excursions,
    }
}

/// The interop server's waypoint score (2019-2021, `satisfied_waypoints`): `passes` are the
/// judged points within 100 ft of a waypoint in time order, each `(waypoint index, grade)`
/// with grade `max(0, 1 - d / 100 ft)`; the score is the largest sum of grades over
/// sequences of passes whose waypoint indices rise strictly (each waypoint counted once, at
/// its best pass in the sequence; waypoints may be left out). Indices at or past
/// `waypoints` are ignored.
pub fn in_order_waypoint_score(passes: &[(usize, f64)], waypoints: usize) -> f64 {
    // best[i]: the best sum of a sequence ending at waypoint i with the passes so far.
    let mut best = vec![0.0_f64; waypoints];
    // A prefix maximum would be faster; the mission's waypoints are few.
    for &(i, grade) in passes {
        if i >= waypoints {
            continue;
        }
        let before = best[..i].iter().copied().fold(0.0, f64::max);
        best[i] = best[i].max(before + grade.max(0.0));
    }
    best.into_iter().fold(0.0, f64::max)
}

/// Which of the mission's fly-zone limits `p` (ENU metres) breaks, as the judges count time
/// out of bounds: `(beyond the boundary, outside the altitude band)`.
pub(crate) fn outside_zone(m: &Mission, p: [f64; 3]) -> (bool, bool) {
    let (alt_min_m, alt_max_m) = altitude_band_m(m);
    (
        !in_zone(xy(p), fly_zone(m)),
        p[2] < alt_min_m || p[2] > alt_max_m,
    )
}

fn in_zone(p: P2, zone: &[P2]) -> bool {
    zone.len() < 3 || point_in_polygon(p, zone)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere standing still.
    struct Still(Vec<([f64; 3], f64)>);
    impl SphereTruth for Still {
        fn sphere_count(&self) -> usize {
            self.0.len()
        }
        fn sphere_at(&self, i: usize, _t: f64) -> ([f64; 3], f64) {
            self.0[i]
        }
    }

    /// A sphere moving east at 10 m/s from x = 0.
    struct Moving;
    impl SphereTruth for Moving {
        fn sphere_count(&self) -> usize {
            1
        }
        fn sphere_at(&self, _i: usize, t: f64) -> ([f64; 3], f64) {
            ([10.0 * t, 0.0, 100.0], 10.0)
        }
    }

    /// A sphere of radius 30 m standing still at (0, 0, 100).
    fn sphere_at_100_m() -> Still {
        Still(vec![([0.0, 0.0, 100.0], 30.0)])
    }

    /// Two telemetry samples `dt_s` apart, from (-50, 0) to (50, 0) at `alt_m`: a pass over
    /// the origin.
    fn pass(alt_m: f64, dt_s: f64) -> [(f64, [f64; 3]); 2] {
        [(0.0, [-50.0, 0.0, alt_m]), (dt_s, [50.0, 0.0, alt_m])]
    }

    /// The judges' report on [`pass`] at `alt_m`, samples `dt_s` apart, by
    /// [`sphere_at_100_m`] (interpolated, no mission).
    fn judge_pass(alt_m: f64, dt_s: f64) -> JudgeReport {
        no_mission(&pass(alt_m, dt_s), &sphere_at_100_m(), &[])
    }

    fn no_mission(
        points: &[(f64, [f64; 3])],
        s: &dyn SphereTruth,
        cyl: &[Cylinder],
    ) -> JudgeReport {
        judge_points(&interpolate(points), s, cyl, &[], None)
    }

    #[test]
    fn a_pass_between_two_samples_outside_a_sphere_is_caught_by_the_interpolation() {
        // Sphere r = 30 at (0, 0, 100). Samples at t = 0 (-50, 0) and t = 4 (50, 0), both 50 m
        // from the centre (outside), 4 s apart (<= 5 s). The line between them passes through
        // the centre: at t = 2.0 the interpolated point is (0, 0), 0 m away: a hit.
        let r = judge_pass(100.0, 4.0);
        assert_eq!(r.sphere_hits, vec![true]);
        assert_eq!(r.sphere_score, 0.0); // (0/1)^3
        // Only the samples themselves: no hit.
        let raw = judge_points(&pass(100.0, 4.0), &sphere_at_100_m(), &[], &[], None);
        assert_eq!(raw.sphere_hits, vec![false]);
        assert!((raw.min_clearance_m - 20.0).abs() < 1e-9); // 50 - 30
    }

    #[test]
    fn a_gap_longer_than_five_seconds_is_not_interpolated() {
        // Same geometry, samples 6 s apart: the judges did not fill the gap, no hit.
        assert_eq!(judge_pass(100.0, 6.0).sphere_hits, vec![false]);
    }

    #[test]
    fn a_sphere_is_missed_when_the_altitude_clears_it_in_3d() {
        // Pass right over the centre (horizontal distance 0) but 31 m above a r = 30 sphere.
        let r = judge_pass(131.0, 4.0);
        assert_eq!(r.sphere_hits, vec![false]);
        assert!((r.min_clearance_m - 1.0).abs() < 1e-9);
        // 29 m above: inside (3-D distance 29 <= 30).
        assert_eq!(judge_pass(129.0, 4.0).sphere_hits, vec![true]);
    }

    #[test]
    fn a_moving_sphere_is_hit_only_where_it_is_at_that_time() {
        // Sphere moving east 10 m/s, r = 10. Aircraft waits at x = 100: at t = 10 s the sphere
        // is at x = 100 -> hit. Aircraft waiting at x = 100 only for t in [0, 5]: sphere at
        // x <= 50 then, 50 m away -> no hit.
        let hit = [
            (0.0, [100.0, 0.0, 100.0]),
            (4.0, [100.0, 0.0, 100.0]),
            (8.0, [100.0, 0.0, 100.0]),
            (12.0, [100.0, 0.0, 100.0]),
        ];
        assert_eq!(no_mission(&hit, &Moving, &[]).sphere_hits, vec![true]);
        let miss = [(0.0, [100.0, 0.0, 100.0]), (5.0, [100.0, 0.0, 100.0])];
        let r = no_mission(&miss, &Moving, &[]);
        assert_eq!(r.sphere_hits, vec![false]);
        assert!((r.min_clearance_m - 40.0).abs() < 1e-9); // 100 - 50 - 10
    }

    #[test]
    fn a_cylinder_counts_at_or_below_its_top_only() {
        // Cylinder r = 20 at the origin, top 100 m. Passing through its axis at 100 m (= top):
        // hit. At 100.5 m: no hit, clearance 0.5 m (straight above the top disc).
        let c = [Cylinder {
            center_m: [0.0, 0.0],
            radius_m: 20.0,
            top_m: 100.0,
        }];
        let none = Still(vec![]);
        let at_top = pass(100.0, 5.0);
        assert_eq!(no_mission(&at_top, &none, &c).cylinder_hits, vec![true]);
        let above = pass(100.5, 5.0);
        let r = no_mission(&above, &none, &c);
        assert_eq!(r.cylinder_hits, vec![false]);
        assert!((r.min_clearance_m - 0.5).abs() < 1e-9);
        // Passing 21 m to the side at 50 m altitude: no hit, clearance 1 m.
        let side = [(0.0, [-50.0, 21.0, 50.0]), (5.0, [50.0, 21.0, 50.0])];
        let r = no_mission(&side, &none, &c);
        assert_eq!(r.cylinder_hits, vec![false]);
        assert!((r.min_clearance_m - 1.0).abs() < 1e-9);
    }

    #[test]
    fn the_class_score_is_the_cube_of_the_fraction_not_hit() {
        // 1 of 4 hit: (3/4)^3 = 0.421875; none: 1; all: 0.
        assert!((class_score(&[true, false, false, false]) - 0.421875).abs() < 1e-12);
        assert_eq!(class_score(&[false, false]), 1.0);
        assert_eq!(class_score(&[true, true]), 0.0);
        assert_eq!(class_score(&[]), 1.0);
    }

    #[test]
    fn a_waypoint_counts_within_100_ft() {
        // Waypoint at (0, 0, 100). Pass at 30 m lateral: captured (30 <= 30.48); at 31 m: not.
        let none = Still(vec![]);
        let w = [[0.0, 0.0, 100.0]];
        let near = interpolate(&[(0.0, [-50.0, 30.0, 100.0]), (5.0, [50.0, 30.0, 100.0])]);
        assert_eq!(
            judge_points(&near, &none, &[], &w, None).waypoints_captured,
            vec![true]
        );
        let far = interpolate(&[(0.0, [-50.0, 31.0, 100.0]), (5.0, [50.0, 31.0, 100.0])]);
        assert_eq!(
            judge_points(&far, &none, &[], &w, None).waypoints_captured,
            vec![false]
        );
    }

    #[test]
    fn the_waypoint_score_takes_the_best_in_order_passes_graded_by_distance() {
        // By hand: 0 at 0.5 then 1 at 1.0 is 1.5; the later 0.9 pass of waypoint 0 comes
        // after waypoint 1's and cannot precede it, alone it is 0.9.
        assert_eq!(
            in_order_waypoint_score(&[(0, 0.5), (1, 1.0), (0, 0.9)], 2),
            1.5
        );
        // Waypoint 2 passed first: 0 then 1 (2.0) beats 2 alone (1.0).
        assert_eq!(
            in_order_waypoint_score(&[(2, 1.0), (0, 1.0), (1, 1.0)], 3),
            2.0
        );
        // Waypoint 1 put off and flown last (0, 2, 3, 1): 0, 2, 3 count.
        assert_eq!(
            in_order_waypoint_score(&[(0, 1.0), (2, 1.0), (3, 1.0), (1, 1.0)], 4),
            3.0
        );
        // A waypoint counts once, at its best pass in the sequence.
        assert_eq!(
            in_order_waypoint_score(&[(0, 0.25), (0, 0.75), (1, 0.5)], 2),
            1.25
        );
        assert_eq!(in_order_waypoint_score(&[], 3), 0.0);
        assert_eq!(
            in_order_waypoint_score(&[(5, 1.0)], 3),
            0.0,
            "no such waypoint"
        );
        // Through the judge: a straight pass 50 ft (15.24 m) abeam of the first waypoint,
        // then one over the second: about 0.5 + 1.0; the first passed 31 m off: 0 + 1.0.
        let none = Still(vec![]);
        let w = [[0.0, 0.0, 100.0], [200.0, 0.0, 100.0]];
        let pass = |y0: f64| {
            interpolate(&[
                (0.0, [-50.0, y0, 100.0]),
                (5.0, [50.0, y0, 100.0]),
                (10.0, [150.0, 0.0, 100.0]),
                (15.0, [250.0, 0.0, 100.0]),
            ])
        };
        let s = judge_points(&pass(15.24), &none, &[], &w, None).waypoint_score;
        assert!((s - 1.5).abs() < 1e-3, "{s}");
        let s = judge_points(&pass(31.0), &none, &[], &w, None).waypoint_score;
        assert!((s - 1.0).abs() < 1e-3, "{s}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        #[test]
        fn interpolation_keeps_every_sample_and_fills_short_gaps_every_tenth_of_a_second(
            gaps in proptest::collection::vec(0.05f64..8.0, 1..12)
        ) {
            let mut t = 0.0;
            let mut tel = vec![(0.0, [0.0, 0.0, 100.0])];
            for (i, g) in gaps.iter().enumerate() {
                t += g;
                tel.push((t, [i as f64 * 10.0, 0.0, 100.0]));
            }
            let pts = interpolate(&tel);
            for s in &tel {
                proptest::prop_assert!(pts.iter().any(|p| p.0 == s.0));
            }
            for w in pts.windows(2) {
                let dt = w[1].0 - w[0].0;
                proptest::prop_assert!(dt > 0.0);
                // a step longer than 0.1 s only across a gap longer than 5 s
                if dt > JUDGE_STEP_S + 1e-9 {
                    proptest::prop_assert!(dt > JUDGE_MAX_GAP_S);
                }
            }
        }
    }
}
