//! A real mission (Webster Field 2021, the interop fixture) with generated moving spheres.
//!
//! The fixture is read and converted to ENU metres by the `wire` crate (WGS84, origin at
//! the lost-comms position), the same reader the server and `jink simulate` use.

use sim::mission::{Mission, fly_zone};
use sim::run::{RunConfig, run};
use sim::scenario::{Family, with_moving_spheres};
use sim::strategy::StrategyKind;

fn webster() -> (Mission, [f64; 3]) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/fixtures/interop/mission_2021_webster_field.json"
    ))
    .expect("fixture");
    let pm = wire::domain::read_mission_text(&text, "webster")
        .expect("a valid mission")
        .to_planner();
    let first = &pm.waypoints[0];
    // start 200 m south of the first waypoint, at its altitude
    let start_m = [first.p_m[0], first.p_m[1] - 200.0, first.alt_m];
    (pm, start_m)
}

#[test]
fn the_webster_field_mission_is_flown_with_generated_moving_spheres() {
    let (m, start_m) = webster();
    assert_eq!(m.waypoints.len(), 14);
    assert_eq!(m.cylinders.len(), 6);
    assert_eq!(fly_zone(&m).len(), 12);
    let s = with_moving_spheres(m, start_m, Family::Spline, 5, 6, 20.0);
    assert_eq!(s.spheres.len(), 6);
    let r = run(&s, StrategyKind::Tangent, &RunConfig::default());
    assert!(r.metrics.completed, "mission finished in the time limit");
    // the tangent graph keeps the aircraft out of the cylinders here (checked: none hit)
    assert_eq!(r.metrics.cylinders_hit, 0);
    assert!(
        r.metrics.waypoints_captured >= 12,
        "{}",
        r.metrics.waypoints_captured
    );
}
