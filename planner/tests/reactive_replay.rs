//! Replays the committed example scan file (`tests/data/reactive_scans.jsonl`) through the
//! reactive control loop, as `jink reactive --scans FILE` does.
#![cfg(feature = "serde")]

use planner::reactive::{LoopParams, ReplaySummary, Side, replay};

const FILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/reactive_scans.jsonl"
);

#[test]
fn the_example_scan_file_replays_with_the_documented_decisions() {
    let reader = std::io::BufReader::new(std::fs::File::open(FILE).unwrap());
    let cycles = replay(reader, &LoopParams::default()).unwrap();
    // the file's header comment lists these
    use Side::{Left, Right};
    let expected = [
        (Some(Left), true),  // clear sky
        (Some(Left), true),  // pole at 12 m: only the 15 and 20 m frames, A = 100 * 3/127 = 2.36
        (Some(Left), true),  // pole at 8 m: same frames
        (Some(Left), false), // pole -10..3 deg at 4.5 m: free on the left first
        (Some(Left), false),
        (Some(Right), false), // obstacle -2..15 deg
        (Some(Right), false),
        (None, false),      // wall at 1.5 m all round
        (Some(Left), true), // posts only at the edges
        (Some(Left), true), // returns beyond the largest radius
    ];
    let got: Vec<_> = cycles
        .iter()
        .map(|c| (c.decision.direction, c.decision.way_ahead_clear))
        .collect();
    assert_eq!(got, expected);
    for c in &cycles {
        // the pilot path starts at the aircraft and rejoins the goal line at the goal
        let first = c.points.first().unwrap();
        let last = c.points.last().unwrap();
        assert_eq!((first.x_m, first.y_m), (0.0, 0.0));
        assert!(last.x_m.abs() < 1e-9);
        assert!((last.y_m - (120.0 - c.cycle as f64)).abs() < 1e-9);
        // the path leaves to the side the offset chose
        let sign = c.decision.direction.map_or(0.0, Side::sign);
        assert!(c.plan.deviation_m * sign >= 0.0);
        if c.decision.way_ahead_clear || c.decision.direction.is_none() {
            assert!(c.points.iter().all(|p| p.x_m == 0.0));
        }
    }
    let s = ReplaySummary::of(&cycles);
    assert_eq!(
        (s.cycles, s.left, s.right, s.no_path, s.way_ahead_clear),
        (10, 7, 2, 1, 5)
    );
    assert!((s.duration_s - 0.45).abs() < 1e-9);
}
