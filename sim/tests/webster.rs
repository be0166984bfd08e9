//! A real mission (Webster Field 2021, the interop fixture) with generated moving spheres.
//!
//! `sim` must not depend on the server, so this test reads the fixture's camelCase JSON
//! itself and converts it with a local spherical tangent-plane approximation (metre-level
//! agreement with WGS84 over a 1 km field, enough for a simulation test).

use serde_json::Value;
use sim::mission::{Cylinder, Mission};
use sim::run::{RunConfig, run};
use sim::scenario::{FT, Family, with_moving_spheres};
use sim::strategy::StrategyKind;

fn webster() -> Mission {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/fixtures/interop/mission_2021_webster_field.json"
    ))
    .expect("fixture");
    let v: Value = serde_json::from_str(&text).unwrap();
    let zone = &v["flyZones"][0];
    let lat0 = zone["boundaryPoints"][0]["latitude"].as_f64().unwrap();
    let lon0 = zone["boundaryPoints"][0]["longitude"].as_f64().unwrap();
    let r = 6_371_000.0_f64;
    let enu = |p: &Value| {
        let (lat, lon) = (
            p["latitude"].as_f64().unwrap(),
            p["longitude"].as_f64().unwrap(),
        );
        [
            (lon - lon0).to_radians() * r * lat0.to_radians().cos(),
            (lat - lat0).to_radians() * r,
        ]
    };
    let waypoints_m: Vec<[f64; 3]> = v["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| {
            let p = enu(w);
            [p[0], p[1], w["altitude"].as_f64().unwrap() * FT]
        })
        .collect();
    let first = waypoints_m[0];
    Mission {
        fly_zone_m: zone["boundaryPoints"]
            .as_array()
            .unwrap()
            .iter()
            .map(enu)
            .collect(),
        alt_min_m: zone["altitudeMin"].as_f64().unwrap() * FT,
        alt_max_m: zone["altitudeMax"].as_f64().unwrap() * FT,
        // start 200 m south of the first waypoint, at its altitude
        start_m: [first[0], first[1] - 200.0, first[2]],
        waypoints_m,
        cylinders: v["stationaryObstacles"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| Cylinder {
                center_m: enu(c),
                radius_m: c["radius"].as_f64().unwrap() * FT,
                top_m: c["height"].as_f64().unwrap() * FT,
            })
            .collect(),
    }
}

#[test]
fn the_webster_field_mission_is_flown_with_generated_moving_spheres() {
    let m = webster();
    assert_eq!(m.waypoints_m.len(), 14);
    assert_eq!(m.cylinders.len(), 6);
    assert_eq!(m.fly_zone_m.len(), 12);
    let s = with_moving_spheres(m, Family::Spline, 5, 6, 20.0);
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
