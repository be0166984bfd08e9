//! Hand-computed cases of the Offset Algorithm (seed 000) and its workspace.

use super::*;
use approx::assert_relative_eq;
use proptest::prelude::*;

const INF: f64 = f64::INFINITY;

/// 11 beams at -50, -40, ..., +50 degrees (index i at -50 + 10 i), all free.
/// L = 11: left windows start at floor(11/2) + k = 5 + k, right windows at
/// ceil(11/2) - k - 4 = 2 - k; cycles = 6 - 4 + 1 = 3.
fn eleven(dist: &[(usize, f64)]) -> Vec<Beam> {
    let mut scan: Vec<Beam> = (0..11)
        .map(|i| Beam::new(-50.0 + 10.0 * i as f64, INF))
        .collect();
    for &(i, d) in dist {
        scan[i].distance_m = d;
    }
    scan
}

fn params(radii: &[f64]) -> OffsetParams {
    OffsetParams::default().with_scan_radii_m(radii.to_vec())
}

#[test]
fn weights_sum_to_one_and_halve_outward() {
    for n in 1..=20 {
        let s: f64 = (1..=n).map(|i| frame_weight(n, i)).sum();
        assert_relative_eq!(s, 1.0, epsilon = 1e-12);
    }
    // n = 3: 4/7, 2/7, 1/7
    assert_relative_eq!(frame_weight(3, 1), 4.0 / 7.0);
    assert_relative_eq!(frame_weight(3, 2), 2.0 / 7.0);
    assert_relative_eq!(frame_weight(3, 3), 1.0 / 7.0);
    // n = 1: the single frame weighs 2^0 / (2^1 - 1) = 1
    assert_relative_eq!(frame_weight(1, 1), 1.0);
}

#[test]
fn frames_are_built_from_unsorted_radii_nearest_first() {
    // radii given as [4, 1, 2] -> sorted [1, 2, 4]
    let scan = eleven(&[(0, 0.5), (1, 1.5), (2, 3.0), (3, 5.0), (4, 1.0)]);
    let mut ws = OffsetWorkspace::new();
    ws.decide(&scan, &params(&[4.0, 1.0, 2.0])).unwrap();
    assert_eq!(ws.radii_m(), &[1.0, 2.0, 4.0]);
    // beam 0 (0.5) blocked in all; 1 (1.5) from R=2; 2 (3.0) only R=4; 3 (5.0) never;
    // 4 (1.0) in all (d <= R is inclusive); the rest inf -> free
    assert_eq!(ws.frame(0), &[1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0]);
    assert_eq!(ws.frame(1), &[1, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0]);
    assert_eq!(ws.frame(2), &[1, 1, 1, 0, 1, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn beams_are_sorted_by_bearing_and_filtered_by_fov() {
    // given left to right and with a 300-degree bearing (= -60) and one outside +-60
    let scan = vec![
        Beam::new(50.0, 0.5),
        Beam::new(300.0, INF),
        Beam::new(-70.0, 0.5),
        Beam::new(0.0, INF),
        Beam::new(-30.0, INF),
        Beam::new(20.0, INF),
        Beam::new(-10.0, 0.5),
    ];
    let mut ws = OffsetWorkspace::new();
    ws.decide(&scan, &params(&[1.0]).with_window(2)).unwrap();
    let b: Vec<f64> = ws.bearings_deg().collect();
    assert_eq!(b, vec![-60.0, -30.0, -10.0, 0.0, 20.0, 50.0]);
    assert_eq!(ws.frame(0), &[0, 0, 1, 0, 0, 1]);
}

#[test]
fn unusual_readings_nan_inf_far_are_free_and_below_min_is_blocked() {
    // indices 0..4: NaN, +inf, 30 m (> range_max 25), -1 (negative), 0.05 (< range_min 0.1)
    let scan = eleven(&[
        (0, f64::NAN),
        (1, INF),
        (2, 30.0),
        (3, -1.0),
        (4, 0.05),
        (5, f64::NEG_INFINITY),
    ]);
    let mut ws = OffsetWorkspace::new();
    ws.decide(&scan, &params(&[1.0, 50.0]).with_range_m(0.1, 25.0))
        .unwrap();
    assert_eq!(ws.frame(0), &[0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0]);
    // 30 m is beyond range_max so free even in the 50 m frame
    assert_eq!(ws.frame(1), &[0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0]);
}

#[test]
fn first_cycle_tie_goes_left_even_when_right_is_lower() {
    // radii [1, 2, 4]: weights 4/7, 2/7, 1/7.
    // beam 8 (+30 deg) at 3.0 m: blocked only in the R=4 frame.
    // cycle 0: left window beams 5..=8 -> S = (0, 0, 25) -> A_L = 25/7 = 3.571 <= 5
    //          right window beams 2..=5 -> A_R = 0 <= 5  -> both pass at cycle 0 -> LEFT
    let d = offset_decide(&eleven(&[(8, 3.0)]), &params(&[1.0, 2.0, 4.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Left));
    assert_eq!(d.cycle, 0);
    assert!(d.way_ahead_clear);
    assert_relative_eq!(d.aggregate_left, 25.0 / 7.0, epsilon = 1e-12);
    assert_relative_eq!(d.aggregate_right, 0.0);
    assert_eq!(d.deviation_m, 0.0);
    assert_eq!(d.heading_change_deg, 0.0);
}

#[test]
fn only_left_passes() {
    // beam 4 (-10 deg) at 0.5 m: blocked in every frame.
    // cycle 0: right window 2..=5 has one blocked -> S = 25 in each frame -> A_R = 25 > 5
    //          left window 5..=8 is clear -> A_L = 0 -> LEFT at cycle 0 (not a tie)
    // window 5..=8 = 0..30 deg, centre 15 deg; look-ahead = largest radius 4 m
    // deviation = 4 sin 15 deg = 1.03528 m
    let d = offset_decide(&eleven(&[(4, 0.5)]), &params(&[1.0, 2.0, 4.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Left));
    assert_eq!(d.cycle, 0);
    assert!(!d.way_ahead_clear);
    assert_relative_eq!(d.aggregate_right, 25.0, epsilon = 1e-12);
    assert_eq!(d.aggregate_left, 0.0);
    let w = d.window.unwrap();
    assert_eq!((w.first_beam, w.last_beam), (5, 8));
    assert_relative_eq!(d.heading_change_deg, 15.0);
    assert_relative_eq!(
        d.deviation_m,
        4.0 * 15f64.to_radians().sin(),
        epsilon = 1e-12
    );
    assert_relative_eq!(d.deviation_m, 1.035276, epsilon = 1e-6);
}

#[test]
fn only_right_passes() {
    // mirror of only_left_passes: beam 6 (+10 deg) blocked -> left window 5..=8 has A_L = 25
    // right window 2..=5 = -30..0 deg clear -> RIGHT, centre -15 deg, deviation -1.03528 m
    let d = offset_decide(&eleven(&[(6, 0.5)]), &params(&[1.0, 2.0, 4.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Right));
    assert_eq!(d.cycle, 0);
    assert_relative_eq!(d.aggregate_left, 25.0, epsilon = 1e-12);
    let w = d.window.unwrap();
    assert_eq!((w.first_beam, w.last_beam), (2, 5));
    assert_relative_eq!(d.heading_change_deg, -15.0);
    assert_relative_eq!(d.deviation_m, -1.035276, epsilon = 1e-6);
}

#[test]
fn both_pass_later_and_the_lower_wins() {
    // radii [1, 2, 4, 8]: weights 8/15, 4/15, 2/15, 1/15.
    // beam 5 (0 deg) at 0.5 m: in both cycle-0 windows, S = 25 everywhere -> A = 25 > 5.
    // cycle 1: left 6..=9, right 1..=4.
    //   beam 9 (+40) at 3.0 m: blocked in R=4, R=8 -> A_L = 25 * (2 + 1) / 15 = 5.0 <= 5
    //   beam 1 (-40) at 6.0 m: blocked in R=8 only -> A_R = 25 * 1 / 15 = 1.667 <= 5
    // both pass, right lower -> RIGHT at cycle 1; window 1..=4 = -40..-10, centre -25 deg
    // deviation = 8 sin(-25 deg) = -3.38095 m
    let scan = eleven(&[(5, 0.5), (9, 3.0), (1, 6.0)]);
    let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0, 8.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Right));
    assert_eq!(d.cycle, 1);
    assert_eq!(d.cycles_evaluated, 2);
    assert_relative_eq!(d.aggregate_left, 5.0, epsilon = 1e-12);
    assert_relative_eq!(d.aggregate_right, 25.0 / 15.0, epsilon = 1e-12);
    assert_relative_eq!(d.heading_change_deg, -25.0);
    assert_relative_eq!(d.deviation_m, -3.380946, epsilon = 1e-6);

    // swap the sides: beam 1 at 3.0, beam 9 at 6.0 -> LEFT, centre (10 + 40) / 2 = 25 deg
    let scan = eleven(&[(5, 0.5), (1, 3.0), (9, 6.0)]);
    let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0, 8.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Left));
    assert_eq!(d.cycle, 1);
    assert_relative_eq!(d.heading_change_deg, 25.0);

    // equal aggregates after cycle 0 (both 6.0 m -> 1.667 each) go LEFT
    let scan = eleven(&[(5, 0.5), (1, 6.0), (9, 6.0)]);
    let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0, 8.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Left));
    assert_eq!(d.cycle, 1);
}

#[test]
fn exhausted_scan_has_no_path() {
    // every beam at 0.5 m: every window S = 100 in every frame -> A = 100 > 5 for all
    // 3 cycles -> no path, aggregates of the last cycle reported
    let scan: Vec<Beam> = eleven(&[])
        .into_iter()
        .map(|b| Beam::new(b.angle_deg, 0.5))
        .collect();
    let d = offset_decide(&scan, &params(&[1.0, 2.0, 4.0])).unwrap();
    assert_eq!(d.direction, None);
    assert_eq!(d.cycles_evaluated, 3);
    assert_eq!(d.cycle, 2);
    assert_relative_eq!(d.aggregate_left, 100.0, epsilon = 1e-12);
    assert_relative_eq!(d.aggregate_right, 100.0, epsilon = 1e-12);
    assert_eq!(d.window, None);
    assert_eq!(d.deviation_m, 0.0);
}

#[test]
fn the_last_cycle_reaches_the_outermost_beams() {
    // only beams 7..=10 (+20..+50) free; the rest at 0.5 m.
    // cycle 2 left window = 7..=10 -> A_L = 0 -> LEFT at cycle 2, centre 35 deg
    let mut scan: Vec<Beam> = eleven(&[])
        .into_iter()
        .map(|b| Beam::new(b.angle_deg, 0.5))
        .collect();
    for b in &mut scan[7..] {
        b.distance_m = INF;
    }
    let d = offset_decide(&scan, &params(&[1.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Left));
    assert_eq!(d.cycle, 2);
    assert_relative_eq!(d.heading_change_deg, 35.0);
}

#[test]
fn even_beam_counts_split_at_the_heading() {
    // 10 beams at -45..45 step 10 (no centre beam): L = 10, left windows start at 5 + k,
    // right windows at 5 - k - 4 = 1 - k; cycles = 5 - 4 + 1 = 2.
    // beam 5 (+5 deg) blocked -> left 5..=8 fails; right 1..=4 (-35..-5) clear -> RIGHT,
    // centre -20 deg
    let scan: Vec<Beam> = (0..10)
        .map(|i| {
            let a = -45.0 + 10.0 * i as f64;
            Beam::new(a, if i == 5 { 0.5 } else { INF })
        })
        .collect();
    let d = offset_decide(&scan, &params(&[1.0])).unwrap();
    assert_eq!(d.direction, Some(Side::Right));
    assert_eq!(d.cycle, 0);
    assert_relative_eq!(d.heading_change_deg, -20.0);
}

#[test]
fn bad_input_is_an_error() {
    let scan = eleven(&[]);
    let e = |p: OffsetParams| offset_decide(&scan, &p).unwrap_err();
    assert_eq!(e(params(&[])), OffsetError::NoScanRadii);
    assert!(matches!(
        e(params(&[1.0, -2.0])),
        OffsetError::InvalidScanRadius { index: 1, .. }
    ));
    assert_eq!(e(params(&[1.0]).with_window(0)), OffsetError::ZeroWindow);
    assert!(matches!(
        e(params(&[1.0]).with_fov_deg(0.0)),
        OffsetError::InvalidFov(_)
    ));
    assert!(matches!(
        e(params(&[1.0]).with_threshold(f64::NAN)),
        OffsetError::InvalidThreshold(_)
    ));
    assert_eq!(
        e(params(&[1.0]).with_window(7)),
        OffsetError::TooFewBeams {
            in_fov: 11,
            window: 7,
            needed: 13
        }
    );
    assert_eq!(
        offset_decide(&[], &params(&[1.0])).unwrap_err(),
        OffsetError::EmptyScan
    );
    let mut bad = scan.clone();
    bad[3].angle_deg = f64::NAN;
    assert_eq!(
        offset_decide(&bad, &params(&[1.0])).unwrap_err(),
        OffsetError::NonFiniteAngle { index: 3 }
    );
}

#[test]
fn the_workspace_gives_the_same_answer_as_a_fresh_call() {
    let mut ws = OffsetWorkspace::new();
    let a = eleven(&[(4, 0.5)]);
    let b = eleven(&[(6, 0.5), (5, 0.7)]);
    let p = params(&[1.0, 2.0, 4.0]);
    for scan in [&a, &b, &a] {
        assert_eq!(
            ws.decide(scan, &p).unwrap(),
            offset_decide(scan, &p).unwrap()
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// One free corridor at least N beams wide lying on one side of the heading, every
    /// other beam blocked in every frame: the algorithm goes to that side, through a
    /// window inside the corridor.
    #[test]
    fn a_single_corridor_is_found_on_its_side(
        l in 12usize..90,
        n in 1usize..6,
        extra in 0usize..5,
        pos in 0.0f64..1.0,
        left in any::<bool>(),
        near in 0.01f64..0.99,
    ) {
        let half_up = l.div_ceil(2);
        prop_assume!(half_up >= n);
        let width = (n + extra).min(l / 2);
        prop_assume!(width >= n);
        // strictly one side: indices >= ceil(l/2) (left) or < floor(l/2) (right), so an
        // odd scan's centre beam (shared by both cycle-0 windows) stays blocked
        let (lo, hi) = if left { (half_up, l.saturating_sub(width)) } else { (0, (l / 2).saturating_sub(width)) };
        prop_assume!(hi >= lo && lo + width <= l);
        let start = lo + ((hi - lo) as f64 * pos).round() as usize;
        let step = 120.0 / l as f64;
        let scan: Vec<Beam> = (0..l)
            .map(|i| {
                let a = -60.0 + step * (i as f64 + 0.5);
                let free = (start..start + width).contains(&i);
                Beam::new(a, if free { INF } else { near })
            })
            .collect();
        let p = OffsetParams::default().with_scan_radii_m(vec![1.0, 3.0, 9.0]).with_window(n);
        let d = offset_decide(&scan, &p).unwrap();
        let side = if left { Side::Left } else { Side::Right };
        prop_assert_eq!(d.direction, Some(side));
        let w = d.window.unwrap();
        prop_assert!(w.first_beam >= start && w.last_beam < start + width);
        prop_assert!(!d.way_ahead_clear);
        prop_assert!(d.deviation_m * side.sign() > 0.0);
    }
}
