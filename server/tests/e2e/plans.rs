//! Plans: the Webster mission planned from telemetry with moving obstacles, revisions and
//! 409 on a stale base, the three download formats, same seed same plan; waypoint
//! insertion over HTTP.

use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, fixture, num, pointers, problem};

both_stores!(
    the_webster_mission_is_planned_from_telemetry_around_moving_obstacles,
    a_stale_base_revision_is_refused_with_409,
    a_plan_downloads_as_json_qgc_wpl_and_qgc_plan,
    the_same_seed_replays_the_same_plan,
    insert_waypoint_answers_the_seed_004_example,
    a_stored_plan_replays_identically_even_after_more_telemetry,
    the_search_area_ladder_covers_the_search_grid_with_validated_parameters,
    the_time_the_next_waypoint_has_been_pending_is_carried_from_the_base_revision,
    a_client_keeping_no_revision_keeps_the_clock_of_the_waypoint_it_flies_toward,
    a_start_without_a_reported_speed_flies_at_the_speed_its_telemetry_shows,
    without_a_turn_radius_the_plan_turns_at_the_bank_the_telemetry_has_shown,
    a_waypoint_passed_wider_than_100_ft_is_flown_again_at_most_twice,
    a_pass_the_turn_ahead_may_capture_is_judged_again_at_the_next_plan,
    a_waypoint_captured_on_the_way_to_an_avoid_item_is_skipped,
    the_waypoint_flown_toward_captured_short_of_it_is_skipped,
    a_waypoint_pursued_for_four_minutes_is_put_off_to_the_end_of_the_stack,
);

/// Time of obstacle "0"'s first observation, Unix seconds.
const T0: f64 = 1_700_000_000.0;
/// Obstacle "0"'s sphere radius, metres.
const OBSTACLE_0_RADIUS_M: f64 = 20.0;
/// The aircraft's telemetry: at waypoint 0 at `T0 + 10`, 20 m/s.
const AIRCRAFT: (f64, f64, f64) = (38.1446916666667, -76.4279944444445, 20.0);

/// Obstacle "0" flies due west at 0.00005 degrees of longitude (about 4.4 m) per second:
/// its observed track, and (past the last observation) its straight-line extrapolation.
fn obstacle_0(t: f64) -> (f64, f64) {
    (38.1455, -76.4245 - 0.00005 * (t - T0))
}

/// Closest horizontal approach, metres, of an aircraft flying `route` (`{lat, lon}`
/// objects, from the aircraft's telemetry position) at its telemetry speed from `T0 + 10`,
/// to obstacle "0" extrapolated along its straight track, over the 60 s horizon. An
/// evaluation independent of the planner: flat distances in the mission's frame, the
/// obstacle where its own track puts it, the route sampled every metre.
fn closest_approach_to_obstacle_0_m(route: &[Value]) -> f64 {
    let frame = wire::geodesy::LocalFrame::new(AIRCRAFT.0, AIRCRAFT.1);
    let mut pts = vec![frame.to_enu(AIRCRAFT.0, AIRCRAFT.1)];
    pts.extend(
        route
            .iter()
            .map(|w| frame.to_enu(w["lat"].as_f64().unwrap(), w["lon"].as_f64().unwrap())),
    );
    let (t_start, horizon_s) = (T0 + 10.0, 60.0);
    let mut flown_m = 0.0;
    let mut closest = f64::INFINITY;
    for leg in pts.windows(2) {
        let len = ((leg[1][0] - leg[0][0]).powi(2) + (leg[1][1] - leg[0][1]).powi(2)).sqrt();
        let n = len.ceil().max(1.0) as usize;
        for k in 0..=n {
            let f = k as f64 / n as f64;
            let t = t_start + (flown_m + f * len) / AIRCRAFT.2;
            if t > t_start + horizon_s {
                return closest;
            }
            let p = [
                leg[0][0] + f * (leg[1][0] - leg[0][0]),
                leg[0][1] + f * (leg[1][1] - leg[0][1]),
            ];
            let (olat, olon) = obstacle_0(t);
            let o = frame.to_enu(olat, olon);
            closest = closest.min(((p[0] - o[0]).powi(2) + (p[1] - o[1]).powi(2)).sqrt());
        }
        flown_m += len;
    }
    closest
}

/// The plan's remaining route (from its current index) keeps obstacle "0" beyond its
/// radius, and the mission's own route from the same index does not: so the check would
/// fail if the planner left the stack alone.
fn assert_plan_keeps_clear_of_obstacle_0(plan: &Value, mission_waypoints: &[Value]) {
    let from = plan["current_index"].as_u64().unwrap() as usize;
    let planned = closest_approach_to_obstacle_0_m(&plan["waypoints"].as_array().unwrap()[from..]);
    let base = closest_approach_to_obstacle_0_m(&mission_waypoints[from..]);
    eprintln!("closest approach to obstacle 0: plan {planned:.1} m, mission route {base:.1} m");
    assert!(
        base < OBSTACLE_0_RADIUS_M,
        "the scenario must put obstacle 0 on the mission's route: closest approach {base:.1} m"
    );
    assert!(
        planned > OBSTACLE_0_RADIUS_M,
        "the plan passes {planned:.1} m from obstacle 0 (radius {OBSTACLE_0_RADIUS_M} m): {plan}"
    );
}

/// The Webster mission's waypoints as `{lat, lon}` objects (the fixture is in feet;
/// only the horizontal position matters here).
fn webster_waypoints() -> Vec<Value> {
    fixture("mission_2021_webster_field.json")["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| json!({"lat": w["latitude"], "lon": w["longitude"]}))
        .collect()
}

async fn webster_with_traffic(app: &App) -> String {
    let id = app.create_webster_mission().await;
    // Aircraft at waypoint 0 (38.14469, -76.42799, 200 ft), heading to waypoint 1.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/telemetry"),
            &json!({"t": T0 + 10.0, "lat": AIRCRAFT.0, "lon": AIRCRAFT.1,
                    "alt_msl_m": 60.96, "heading_deg": 60.0, "speed_mps": AIRCRAFT.2}),
        )
        .await;
    assert_eq!(r.status(), 202);
    // Obstacle "0" flies west across the first leg toward the aircraft; "1" sits north.
    let mut obs = Vec::new();
    for k in 0..=10 {
        let t = T0 + f64::from(k);
        let (lat, lon) = obstacle_0(t);
        obs.push(json!({"obstacle_id": "0", "t": t, "lat": lat, "lon": lon,
                        "alt_msl_m": 60.0, "radius_m": OBSTACLE_0_RADIUS_M}));
        obs.push(json!({"obstacle_id": "1", "t": t, "lat": 38.149, "lon": -76.430, "alt_msl_m": 80.0, "radius_m": 15.0}));
    }
    app.post_observations(&id, json!(obs)).await;
    id
}

/// Asks for a plan and expects 201.
pub async fn plan(app: &App, id: &str, body: Value) -> Value {
    let r = app
        .post_json(&format!("/api/v1/missions/{id}/plan"), &body)
        .await;
    let status = r.status();
    let v: Value = r.json().await.unwrap();
    assert_eq!(status, 201, "{v}");
    v
}

async fn the_webster_mission_is_planned_from_telemetry_around_moving_obstacles(app: App) {
    let id = webster_with_traffic(&app).await;
    let p = plan(&app, &id, json!({"seed": 7, "current_index": 1})).await;
    assert_eq!(p["revision"], 1);
    assert_eq!(p["seed"], 7);
    assert_eq!(p["current_index"], 1);
    assert_eq!(p["start"]["source"], "telemetry");
    assert_eq!(p["dynamic_risk"]["source"], "risk_map");
    assert_eq!(p["dynamic_risk"]["obstacles"], 2);
    // Obstacle 0 has flown for 10 s with no lap of a tour: the plan says it is still being
    // learned (start jink at set-up); obstacle 1 sits still and is not named.
    let learning = warning(&p, "tours_not_learned").unwrap_or_else(|| panic!("{}", p["warnings"]));
    assert!(
        learning.starts_with("1 moving obstacle(s)") && learning.contains(": 0 (10 s)."),
        "{learning}"
    );
    let wps = p["waypoints"].as_array().unwrap();
    // Every mission waypoint, in order, at its own coordinates.
    let idx: Vec<u64> = wps
        .iter()
        .filter_map(|w| w["mission_index"].as_u64())
        .collect();
    assert_eq!(idx, (0..14).collect::<Vec<u64>>());
    assert!(
        wps.iter()
            .all(|w| ["mission", "avoid"].contains(&w["kind"].as_str().unwrap()))
    );
    assert_plan_keeps_clear_of_obstacle_0(&p, &webster_waypoints());
    // The diff rewrites a tail from the current index on.
    if let Some(first) = p["diff"]["first_changed"].as_u64() {
        assert!(first >= 1);
        assert_eq!(
            p["diff"]["insert"].as_array().unwrap().len() as u64,
            wps.len() as u64 - first
        );
    }
    for key in ["outcome", "plan_id", "length_m"] {
        assert!(!p[key].is_null(), "{key}");
    }
}

async fn a_stale_base_revision_is_refused_with_409(app: App) {
    let id = webster_with_traffic(&app).await;
    let p1 = plan(&app, &id, json!({"seed": 1})).await;
    assert_eq!(p1["revision"], 1);
    let p2 = plan(
        &app,
        &id,
        json!({"seed": 2, "base_revision": 1, "current_index": 2}),
    )
    .await;
    assert_eq!(p2["revision"], 2);
    assert_eq!(p2["base_revision"], 1);
    // Items before the current index keep their place.
    assert_eq!(p2["waypoints"][0], p1["waypoints"][0]);
    assert_eq!(p2["waypoints"][1], p1["waypoints"][1]);
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/plan"),
            &json!({"base_revision": 1}),
        )
        .await;
    let prob = problem(r, 409).await;
    assert!(
        prob["detail"]
            .as_str()
            .unwrap()
            .contains("latest revision 2"),
        "{prob}"
    );
    // A revision that does not exist is a validation error.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/plan"),
            &json!({"base_revision": 9}),
        )
        .await;
    assert_eq!(
        pointers(&problem(r, 422).await),
        vec!["/base_revision".to_string()]
    );
    let r = app
        .post_json("/api/v1/missions/nope/plan", &json!({}))
        .await;
    problem(r, 404).await;
    // An absurd aircraft is refused at its field, not planned: the forward flight the
    // verification simulates steps in time that shrink with speed, and schemathesis found
    // a plan at 3e16 m/s that never ended.
    for (aircraft, field) in [
        (json!({"speed_mps": 2.98e16}), "/aircraft/speed_mps"),
        (json!({"speed_mps": 201.0}), "/aircraft/speed_mps"),
        (json!({"turn_radius_m": 5.3e307}), "/aircraft/turn_radius_m"),
        (
            json!({"acceptance_radius_m": 501.0}),
            "/aircraft/acceptance_radius_m",
        ),
        (
            json!({"acceptance_radius_m": -1.0}),
            "/aircraft/acceptance_radius_m",
        ),
        (json!({"l1_period_s": 4.0}), "/aircraft/l1_period_s"),
        (json!({"l1_period_s": 61.0}), "/aircraft/l1_period_s"),
    ] {
        let r = app
            .post_json(
                &format!("/api/v1/missions/{id}/plan"),
                &json!({"aircraft": aircraft}),
            )
            .await;
        assert_eq!(pointers(&problem(r, 422).await), vec![field.to_string()]);
    }
    for wait in [json!(-1.0), json!(86_401.0)] {
        let r = app
            .post_json(
                &format!("/api/v1/missions/{id}/plan"),
                &json!({"defer_after_s": wait}),
            )
            .await;
        assert_eq!(pointers(&problem(r, 422).await), vec!["/defer_after_s"]);
    }
    // Telemetry speed wins over the plan's, so it has the same bound.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/telemetry"),
            &json!({"t": 500.0, "lat": 38.145, "lon": -76.428, "alt_msl_m": 100.0,
                    "heading_deg": 90.0, "speed_mps": 1.0e9}),
        )
        .await;
    let prob = problem(r, 422).await;
    assert!(
        pointers(&prob).iter().any(|p| p.ends_with("speed_mps")),
        "{prob}"
    );
}

async fn a_plan_downloads_as_json_qgc_wpl_and_qgc_plan(app: App) {
    let id = webster_with_traffic(&app).await;
    let p = plan(&app, &id, json!({"seed": 3})).await;
    let pid = p["plan_id"].as_str().unwrap();
    let base = format!("/api/v1/missions/{id}/plans/{pid}");
    assert_eq!(app.get_json(&base).await, p);
    assert_eq!(app.get_json(&format!("{base}?format=json")).await, p);

    let text = app.get_text(&format!("{base}/qgc-wpl"), "text/plain").await;
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "QGC WPL 110");
    assert_eq!(lines.len(), 2 + p["waypoints"].as_array().unwrap().len());
    assert!(
        lines[1].starts_with("0\t1\t0\t16\t"),
        "home first: {}",
        lines[1]
    );
    assert!(lines.iter().skip(1).all(|l| l.split('\t').count() == 12));
    // The older `?format=` form answers 303 to the same download (reqwest follows it).
    let old = app.get(&format!("{base}?format=qgc-wpl")).await;
    assert_eq!(old.url().path(), format!("{base}/qgc-wpl"));
    assert_eq!(old.text().await.unwrap(), text);

    let r = app.get(&format!("{base}/qgc-plan")).await;
    assert_eq!(r.status(), 200);
    let v: Value = r.json().await.unwrap();
    assert_eq!(v["fileType"], "Plan");
    assert_eq!(v["groundStation"], "jink");
    assert_eq!(
        v["mission"]["items"].as_array().unwrap().len(),
        p["waypoints"].as_array().unwrap().len()
    );
    assert_eq!(
        v["geoFence"]["polygons"][0]["polygon"]
            .as_array()
            .unwrap()
            .len(),
        12
    );
    // Webster Field's six cylinders are exclusion circles (radius in metres).
    let circles = v["geoFence"]["circles"].as_array().unwrap();
    assert_eq!(circles.len(), 6);
    assert!(circles.iter().all(|c| c["inclusion"] == false));
    assert_eq!(
        circles[0]["circle"]["center"],
        json!([38.146689, -76.426475])
    );
    assert!((circles[0]["circle"]["radius"].as_f64().unwrap() - 150.0 * 0.3048).abs() < 0.01);

    let r = app.get(&format!("{base}?format=kml")).await;
    problem(r, 400).await;
    let r = app.get(&format!("/api/v1/missions/{id}/plans/nope")).await;
    problem(r, 404).await;
}

async fn the_same_seed_replays_the_same_plan(app: App) {
    let id = webster_with_traffic(&app).await;
    let a = plan(&app, &id, json!({"seed": 12345})).await;
    let b = plan(&app, &id, json!({"seed": 12345})).await;
    assert_eq!(a["revision"], 1);
    assert_eq!(b["revision"], 2);
    for key in ["waypoints", "diff", "risk", "outcome", "length_m", "seed"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    // Without a seed, one is drawn and returned.
    let c = plan(&app, &id, json!({})).await;
    assert!(c["seed"].as_u64().is_some());
}

async fn insert_waypoint_answers_the_seed_004_example(app: App) {
    const PATH: &str = "/api/v1/avoid/insert-waypoint";
    // A leg east along 38 N from 76 W to longitude `to_lon`, and an obstacle `(lat, lon, r)`.
    let leg = |to_lon: f64, (lat, lon, radius_m): (f64, f64, f64)| {
        json!({"from": {"lat": 38.0, "lon": -76.0}, "to": {"lat": 38.0, "lon": to_lon},
               "obstacle": {"lat": lat, "lon": lon, "radius_m": radius_m}})
    };
    // A 1 km leg with an obstacle of radius 40 m 10 m north of its middle: the chosen
    // waypoint is south of the leg (the shorter detour), on the r + 2b = 56 m circle: 46 m
    // south of the leg, so the latitude drops by ~46 / 111000 deg.
    let v = app
        .post_ok(PATH, &leg(-75.98865, (38.00009, -75.994325, 40.0)))
        .await;
    assert_eq!(v["outcome"], "inserted", "{v}");
    assert_eq!(v["candidates"].as_array().unwrap().len(), 2);
    let lat = v["waypoint"]["lat"].as_f64().unwrap();
    assert!(lat < 38.0, "{v}");
    assert!((lat - 38.0 + 46.0 / 111_000.0).abs() < 0.00003, "{lat}");
    // A leg far from the obstacle needs nothing.
    let v = app
        .post_ok(PATH, &leg(-75.99, (38.01, -75.995, 40.0)))
        .await;
    assert_eq!(v["outcome"], "not_needed");
    assert!(v["waypoint"].is_null());
    let r = app
        .post_json(PATH, &leg(-75.99, (38.0, -75.995, -1.0)))
        .await;
    assert_eq!(
        pointers(&problem(r, 422).await),
        vec!["/obstacle/radius_m".to_string()]
    );
}

#[test]
fn jink_plan_prints_the_same_plan_offline_for_the_same_seed() {
    let mission = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/interop/mission_2021_webster_field.json");
    let dir = tempfile::tempdir().unwrap();
    let obs = dir.path().join("obs.json");
    let list: Vec<Value> = (0..=10)
        .map(|k| {
            let t = T0 + f64::from(k);
            let (lat, lon) = obstacle_0(t);
            json!({"obstacle_id": "0", "t": t, "lat": lat, "lon": lon,
                   "alt_msl_m": 60.0, "radius_m": OBSTACLE_0_RADIUS_M})
        })
        .collect();
    std::fs::write(&obs, json!({ "observations": list }).to_string()).unwrap();
    let run = || {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
            .args(["plan", "--mission"])
            .arg(&mission)
            .arg("--obstacles")
            .arg(&obs)
            .args(["--seed", "11"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<Value>(&out.stdout).unwrap()
    };
    let (a, b) = (run(), run());
    assert_eq!(a["seed"], 11);
    assert_eq!(a["dynamic_risk"]["source"], "risk_map");
    assert_eq!(a["waypoints"], b["waypoints"]);
    let idx: Vec<u64> = a["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w["mission_index"].as_u64())
        .collect();
    assert_eq!(idx, (0..14).collect::<Vec<u64>>());
    // Offline, the start is waypoint 0 at the newest observation's time (`T0 + 10`).
    assert_plan_keeps_clear_of_obstacle_0(&a, &webster_waypoints());
}

async fn a_stored_plan_replays_identically_even_after_more_telemetry(app: App) {
    let id = webster_with_traffic(&app).await;
    let p = plan(&app, &id, json!({"seed": 7})).await;
    assert_eq!(p["dynamic_risk"]["obstacles"], 2, "{p}");
    let plan_id = p["plan_id"].as_str().unwrap();
    let replay_path = format!("/api/v1/missions/{id}/plans/{plan_id}/replay");
    let r = app.client.post(app.url(&replay_path)).send().await.unwrap();
    assert_eq!(r.status(), 200);
    let v: Value = r.json().await.unwrap();
    assert_eq!(v["identical"], true, "{v}");
    assert_eq!(v["replayed"]["waypoints"], p["waypoints"]);
    assert!(v["caveat"].is_null());

    // Late observations inside the plan's time window (radio links reorder) arrive after
    // the plan: the replay still uses exactly what the plan used.
    let late: Vec<Value> = (0..5)
        .map(|k| {
            json!({"obstacle_id": "2", "t": 1_700_000_005.5 + f64::from(k), "lat": 38.1450,
                        "lon": -76.4262, "alt_msl_m": 60.0, "radius_m": 30.0})
        })
        .collect();
    app.post_observations(&id, json!(late)).await;
    let v: Value = app
        .client
        .post(app.url(&replay_path))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(v["identical"], true, "{v}");
    assert_eq!(v["replayed"]["dynamic_risk"]["obstacles"], 2, "{v}");
    // A new plan sees the late obstacle.
    let p2 = plan(&app, &id, json!({"seed": 7})).await;
    assert_eq!(p2["dynamic_risk"]["obstacles"], 3, "{p2}");

    let r = app
        .client
        .post(app.url(&format!("/api/v1/missions/{id}/plans/nope/replay")))
        .send()
        .await
        .unwrap();
    problem(r, 404).await;
}

async fn the_search_area_ladder_covers_the_search_grid_with_validated_parameters(app: App) {
    let m = fixture("mission_2021_webster_field.json");
    let id = app.create_mission(&m).await;
    let path = format!("/api/v1/missions/{id}/search-pattern");
    let v = app
        .post_ok(&path, &json!({"spacing_m": 100.0, "heading_deg": 90.0}))
        .await;
    let lines = v["lines"].as_u64().unwrap();
    let wps = v["waypoints"].as_array().unwrap();
    assert!(lines >= 2, "{v}");
    assert_eq!(wps.len() as u64, 2 * lines);
    assert_eq!(v["order"], "boustrophedon");
    // Every waypoint lies within the search grid's bounds (1 m of slack).
    let grid = m["searchGridPoints"].as_array().unwrap();
    let range = |k: &str| {
        grid.iter()
            .map(|p| p[k].as_f64().unwrap())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            })
    };
    let ((lat0, lat1), (lon0, lon1)) = (range("latitude"), range("longitude"));
    for w in wps {
        let (lat, lon) = (w["lat"].as_f64().unwrap(), w["lon"].as_f64().unwrap());
        assert!(lat > lat0 - 1e-5 && lat < lat1 + 1e-5, "{w}");
        assert!(lon > lon0 - 1e-5 && lon < lon1 + 1e-5, "{w}");
    }
    // Lines closer than two turn radii are flown in skip order.
    let v = app
        .post_json(&path, &json!({"spacing_m": 30.0, "turn_radius_m": 40.0}))
        .await
        .json::<Value>()
        .await
        .unwrap();
    assert_eq!(v["order"], "skip", "{v}");
    // Bad parameters are 422 naming each field.
    let r = app
        .post_json(&path, &json!({"spacing_m": 0.5, "heading_deg": 400.0}))
        .await;
    assert_eq!(
        pointers(&problem(r, 422).await),
        vec!["/spacing_m".to_string(), "/heading_deg".to_string()]
    );
    let r = app.post_json(&path, &json!({"order": "spiral"})).await;
    problem(r, 400).await;
    let r = app
        .post_json("/api/v1/missions/nope/search-pattern", &json!({}))
        .await;
    problem(r, 404).await;
}

#[test]
fn jink_plan_flies_its_check_with_the_autopilots_l1_period_and_acceptance_radius() {
    // The plan's check flies each route as the autopilot would: it switches to the next
    // item within the acceptance radius and follows legs with the L1 distance of its
    // period. Told either, `jink plan` plans for that autopilot (found by trying: these
    // are settings where the Webster Field plan changes, not the only ones).
    let mission = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/interop/mission_2021_webster_field.json");
    let jink = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
            .args(["plan", "--mission"])
            .arg(&mission)
            .args(["--seed", "5", "--turn-radius-m", "21"])
            .args(extra)
            .output()
            .unwrap()
    };
    let plan = |extra: &[&str]| {
        let out = jink(extra);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<Value>(&out.stdout).unwrap()
    };
    let route = |p: &Value| (p["waypoints"].clone(), p["length_m"].clone());
    // The defaults told explicitly give the plan of the defaults assumed.
    let slow = ["--speed-mps", "14"];
    let assumed = plan(&slow);
    let told = plan(
        &[
            &slow[..],
            &["--l1-period-s", "17", "--acceptance-radius-m", "10"],
        ]
        .concat(),
    );
    assert_eq!(route(&assumed), route(&told));
    // An autopilot that switches 60 m short of each item turns away before the judges'
    // 100 ft: the plan sets up a straight approach to a waypoint it would miss.
    let early = plan(&[&slow[..], &["--acceptance-radius-m", "60"]].concat());
    assert_ne!(route(&assumed), route(&early), "{early}");
    assert!(
        early["waypoints"].as_array().unwrap().len()
            > assumed["waypoints"].as_array().unwrap().len(),
        "{early}"
    );
    // A fast aircraft (30 m/s) on a 60 s period (L1 430 m, against 122 m at 17 s) swings
    // wide of a corner the default period passes, and the plan changes with it.
    let fast = ["--speed-mps", "30"];
    let default_period = plan(&fast);
    let long_period = plan(&[&fast[..], &["--l1-period-s", "60"]].concat());
    assert_ne!(route(&default_period), route(&long_period), "{long_period}");
    // Out of range: refused, naming the flag.
    for (flag, value) in [
        ("--l1-period-s", "4.9"),
        ("--l1-period-s", "61"),
        ("--l1-period-s", "NaN"),
        ("--acceptance-radius-m", "-1"),
        ("--acceptance-radius-m", "501"),
    ] {
        let out = jink(&[&format!("{flag}={value}")]);
        assert!(!out.status.success(), "{flag} {value} was taken");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(flag), "{flag} {value}: {err}");
    }
}

#[test]
fn jink_plan_starts_from_a_given_position_and_writes_wpl_and_qgc_plan_files() {
    let mission = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/interop/mission_2021_webster_field.json");
    let dir = tempfile::tempdir().unwrap();
    let jink = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
            .args(["plan", "--mission"])
            .arg(&mission)
            .args(["--seed", "3"])
            .args(extra)
            .output()
            .unwrap()
    };
    // JSON: the start is the given position and heading.
    let out = jink(&["--position", "38.1450,-76.4270,70", "--heading", "45"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let p: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(p["start"]["lat"], 38.145);
    assert_eq!(p["start"]["lon"], -76.427);
    assert_eq!(p["start"]["alt_msl_m"], 70.0);
    assert_eq!(p["start"]["heading_deg"], 45.0);
    // WPL to a file: header, home, then one line per stack item.
    let wpl = dir.path().join("plan.waypoints");
    let out = jink(&[
        "--position",
        "38.1450,-76.4270",
        "--format",
        "wpl",
        "--out",
        wpl.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stdout.is_empty());
    let text = std::fs::read_to_string(&wpl).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "QGC WPL 110");
    assert_eq!(lines.len(), 2 + p["waypoints"].as_array().unwrap().len());
    // .plan: the six cylinders as exclusion circles.
    let out = jink(&["--format", "qgc-plan"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["fileType"], "Plan");
    assert_eq!(v["geoFence"]["circles"].as_array().unwrap().len(), 6);
    // Bad input names the flag.
    for (args, flag) in [
        (&["--position", "95,-76.4"][..], "--position"),
        (&["--heading", "400"][..], "--heading"),
        (&["--format", "kml"][..], "format"),
    ] {
        let out = jink(args);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(flag), "{err}");
    }
}

/// Index of the first mission waypoint at or after `from` in a plan's stack.
fn next_mission_item(plan: &Value, from: usize) -> usize {
    let wps = plan["waypoints"].as_array().unwrap();
    from + wps[from..]
        .iter()
        .position(|w| w["kind"] == "mission")
        .expect("a mission waypoint is left")
}

/// Posts the aircraft still at waypoint 0 (`AIRCRAFT`, heading 60 degrees), reporting at `t`.
async fn aircraft_at_waypoint_0(app: &App, id: &str, t: f64) {
    let body = json!({"t": t, "lat": AIRCRAFT.0, "lon": AIRCRAFT.1, "alt_msl_m": 60.96,
                      "heading_deg": 60.0, "speed_mps": AIRCRAFT.2});
    let r = app
        .post_json(&format!("/api/v1/missions/{id}/telemetry"), &body)
        .await;
    assert_eq!(r.status(), 202);
}

/// Replays stored plan `plan_id` of mission `id`: the answer (200).
async fn replay(app: &App, id: &str, plan_id: &str) -> Value {
    let r = app
        .client
        .post(app.url(&format!("/api/v1/missions/{id}/plans/{plan_id}/replay")))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    r.json().await.unwrap()
}

async fn the_time_the_next_waypoint_has_been_pending_is_carried_from_the_base_revision(app: App) {
    let id = webster_with_traffic(&app).await;
    let telemetry_at = |t: f64| aircraft_at_waypoint_0(&app, &id, t);
    // The first plan starts the clock of its next waypoint (telemetry at T0 + 10).
    let p1 = plan(&app, &id, json!({"seed": 1, "current_index": 1})).await;
    assert_eq!(p1["target_pending_s"], 0.0, "{p1}");
    // 30 s later, still flying toward the same waypoint: 30 s pending.
    telemetry_at(T0 + 40.0).await;
    let p2 = plan(
        &app,
        &id,
        json!({"seed": 2, "base_revision": 1, "current_index": 1}),
    )
    .await;
    assert_eq!(p2["target_pending_s"], 30.0, "{p2}");
    // The stored plan says the same, and replays identically from what it recorded.
    let plan_id = p2["plan_id"].as_str().unwrap();
    let stored: Value = app
        .get_json(&format!("/api/v1/missions/{id}/plans/{plan_id}"))
        .await;
    assert_eq!(stored["target_pending_s"], 30.0, "{stored}");
    let v = replay(&app, &id, plan_id).await;
    assert_eq!(v["identical"], true, "{v}");
    // Past that waypoint the next one is new: its clock starts again.
    let past = next_mission_item(&p2, 1) + 1;
    telemetry_at(T0 + 45.0).await;
    let p3 = plan(
        &app,
        &id,
        json!({"seed": 3, "base_revision": 2, "current_index": past}),
    )
    .await;
    assert_eq!(p3["target_pending_s"], 0.0, "{p3}");
}

/// A client that sends no `base_revision` plans from the mission's own waypoints every time
/// (`current_index` a mission index): the clock of the waypoint it flies toward is carried
/// from the latest revision when that one pursued the same mission waypoint, so putting it
/// off stays bounded; another waypoint starts its own clock, and the stored plan replays.
async fn a_client_keeping_no_revision_keeps_the_clock_of_the_waypoint_it_flies_toward(app: App) {
    let id = webster_with_traffic(&app).await;
    let telemetry_at = |t: f64| aircraft_at_waypoint_0(&app, &id, t);
    // The first plan starts the clock of mission waypoint 1 (telemetry at T0 + 10).
    let p1 = plan(&app, &id, json!({"seed": 1, "current_index": 1})).await;
    assert_eq!(p1["target_pending_s"], 0.0, "{p1}");
    // 30 s later, no base again, still toward mission waypoint 1: 30 s pending.
    telemetry_at(T0 + 40.0).await;
    let p2 = plan(&app, &id, json!({"seed": 2, "current_index": 1})).await;
    assert_eq!(p2["revision"], 2, "{p2}");
    assert_eq!(p2["target_pending_s"], 30.0, "{p2}");
    let plan_id = p2["plan_id"].as_str().unwrap();
    let v = replay(&app, &id, plan_id).await;
    assert_eq!(v["identical"], true, "{v}");
    // Toward mission waypoint 2 the clock starts again ...
    telemetry_at(T0 + 45.0).await;
    let p3 = plan(&app, &id, json!({"seed": 3, "current_index": 2})).await;
    assert_eq!(p3["target_pending_s"], 0.0, "{p3}");
    // ... and runs from there.
    telemetry_at(T0 + 50.0).await;
    let p4 = plan(&app, &id, json!({"seed": 4, "current_index": 2})).await;
    assert_eq!(p4["target_pending_s"], 5.0, "{p4}");
    // A plan from the latest revision itself is unchanged: its own clock.
    let past = next_mission_item(&p4, 2);
    let p5 = plan(
        &app,
        &id,
        json!({"seed": 5, "base_revision": 4, "current_index": past}),
    )
    .await;
    assert_eq!(p5["target_pending_s"], 5.0, "{p5}");
}

/// Telemetry in a form that carries no speed (as the interop forms): the plan's start takes
/// the ground speed between the newest sample and the one 0.5-2 s before it, so the route
/// is timed at what the aircraft flies, not at the 20 m/s default; a reported speed wins;
/// the stored plan replays with the speed it used. A request without a turn radius gets the
/// radius of a 30-degree-bank turn at that speed, and a `turn_radius_assumed` warning
/// naming it; a request that gives one gets no such warning.
async fn a_start_without_a_reported_speed_flies_at_the_speed_its_telemetry_shows(app: App) {
    let id = app.create_webster_mission().await;
    // About 111 km per degree of latitude (the server measures in its own frame, hence
    // the tolerance below).
    let north = |m: f64| (AIRCRAFT.0 + m / 111_000.0, AIRCRAFT.1);
    // 5 Hz for 2 s, northward at about 15 m/s, no speed.
    let track: Vec<Value> = (0..=10)
        .map(|k| {
            let (lat, lon) = north(3.0 * f64::from(k));
            json!({"t": T0 + 0.2 * f64::from(k), "lat": lat, "lon": lon,
                   "alt_msl_m": 60.96, "heading_deg": 0.0})
        })
        .collect();
    let r = app
        .post_json(&format!("/api/v1/missions/{id}/telemetry"), &json!(track))
        .await;
    assert_eq!(r.status(), 202);
    let first = plan(&app, &id, json!({"seed": 3, "current_index": 1})).await;
    let v = num(&first, "/start/speed_mps");
    assert!((v - 15.0).abs() < 0.3, "{v}: {}", first["start"]);
    assert_eq!(num(&first, "/start/t"), T0 + 2.0);
    // v^2 / (g tan 30 deg) at the estimated speed (about 39.7 m at 15 m/s).
    let radius = v * v / (9.806_65 * 30f64.to_radians().tan());
    let assumed = warning(&first, "turn_radius_assumed").expect("a turn_radius_assumed warning");
    assert!(
        assumed.contains(&format!("{radius:.1} m")),
        "{assumed} (expected {radius:.1} m)"
    );
    let given = plan(
        &app,
        &id,
        json!({"seed": 3, "current_index": 1, "aircraft": {"turn_radius_m": 35.0}}),
    )
    .await;
    assert_eq!(
        warning(&given, "turn_radius_assumed"),
        None,
        "{}",
        given["warnings"]
    );

    // The aircraft now reports its speed: that wins.
    let (lat, lon) = north(33.0);
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/telemetry"),
            &json!({"t": T0 + 2.2, "lat": lat, "lon": lon, "alt_msl_m": 60.96,
                    "heading_deg": 0.0, "speed_mps": 18.0}),
        )
        .await;
    assert_eq!(r.status(), 202);
    let second = plan(&app, &id, json!({"seed": 3})).await;
    assert_eq!(num(&second, "/start/speed_mps"), 18.0);
    let assumed = warning(&second, "turn_radius_assumed").expect("a turn_radius_assumed warning");
    assert!(assumed.contains("57.2 m"), "{assumed}");

    // The first plan replays from what it used, the estimated speed included.
    assert_replays_identically(&app, &id, &first).await;
}

/// The turn radius a `turn_radius_assumed` warning names ("turns assumed at R m").
fn assumed_radius_m(plan: &Value) -> f64 {
    let w = warning(plan, "turn_radius_assumed").expect("a turn_radius_assumed warning");
    let tail = w.split("turns assumed at ").nth(1).expect("a radius");
    tail.split(" m").next().unwrap().parse().expect("a number")
}

/// A client that sends no turn radius (the interop forms have no such field) gets turns
/// at the bank its aircraft has shown in its telemetry, 3 degrees less, rather than the
/// cautious 30-degree default, once it has turned harder than that: an aircraft banking
/// 43 degrees flies every turn tighter than a 30-degree plan assumed. The bank is carried
/// from the base revision when the newest telemetry shows no turn, and the plan replays
/// with the radius it used.
async fn without_a_turn_radius_the_plan_turns_at_the_bank_the_telemetry_has_shown(app: App) {
    let id = app.create_webster_mission().await;
    const V: f64 = 18.0;
    const G: f64 = 9.806_65;
    let omega = G * 43.3f64.to_radians().tan() / V;
    let r = V / omega;
    // Metres east / north of the aircraft's position, as latitude and longitude.
    let at = |east: f64, north: f64| {
        (
            AIRCRAFT.0 + north / 111_000.0,
            AIRCRAFT.1 + east / (111_000.0 * AIRCRAFT.0.to_radians().cos()),
        )
    };
    let post = |samples: Vec<Value>| {
        let (app, id) = (&app, &id);
        async move {
            let r = app
                .post_json(&format!("/api/v1/missions/{id}/telemetry"), &json!(samples))
                .await;
            assert_eq!(r.status(), 202);
        }
    };
    // Straight north at 18 m/s, no speed reported (as the interop forms): the default.
    let straight = |from_s: f64, n: u32| -> Vec<Value> {
        (0..n)
            .map(|k| {
                let t = from_s + 0.2 * f64::from(k);
                let (lat, lon) = at(0.0, V * t);
                json!({"t": T0 + t, "lat": lat, "lon": lon, "alt_msl_m": 60.96, "heading_deg": 0.0})
            })
            .collect()
    };
    post(straight(0.0, 15)).await;
    let before = plan(&app, &id, json!({"seed": 5, "current_index": 1})).await;
    let v0 = num(&before, "/start/speed_mps");
    let default_r = v0 * v0 / (G * 30f64.to_radians().tan());
    assert!(
        (assumed_radius_m(&before) - default_r).abs() < 0.11,
        "{}",
        before["warnings"]
    );
    // Then a left turn at 43.3 degrees of bank (35 m), 5 Hz for 4 s.
    let turn: Vec<Value> = (1..=20)
        .map(|k| {
            let a = omega * 0.2 * f64::from(k);
            let (lat, lon) = at(-r + r * a.cos(), V * 2.8 + r * a.sin());
            json!({"t": T0 + 2.8 + 0.2 * f64::from(k), "lat": lat, "lon": lon,
                   "alt_msl_m": 60.96, "heading_deg": (-a.to_degrees()).rem_euclid(360.0)})
        })
        .collect();
    post(turn).await;
    let turned = plan(
        &app,
        &id,
        json!({"seed": 5, "base_revision": 1, "current_index": 1}),
    )
    .await;
    let v = num(&turned, "/start/speed_mps");
    let planned = |bank_deg: f64| v * v / (G * bank_deg.to_radians().tan());
    let radius = assumed_radius_m(&turned);
    // 43.3 shown, 40.3 planned (the track is measured in the server's own frame: a
    // degree either way).
    assert!(
        (planned(41.3)..=planned(39.3)).contains(&radius),
        "{radius} m, expected about {:.1}: {}",
        planned(40.3),
        turned["warnings"]
    );
    assert!(
        radius > V * V / (G * 43.3f64.to_radians().tan()),
        "never tighter than flown"
    );
    assert!(
        warning(&turned, "turn_radius_assumed")
            .unwrap()
            .contains("the telemetry has shown turns at 4"),
        "{}",
        turned["warnings"]
    );
    // Straight again, long enough that the newest samples show no turn: the bank shown
    // is carried from the base revision...
    let heading = (-(omega * 4.0).to_degrees()).rem_euclid(360.0);
    let (lat, lon) = at(
        -r + r * (omega * 4.0).cos(),
        V * 2.8 + r * (omega * 4.0).sin(),
    );
    let level: Vec<Value> = (1..=40)
        .map(|k| {
            let d = V * 0.2 * f64::from(k);
            let h = heading.to_radians();
            let (dlat, dlon) = (
                d * h.cos() / 111_000.0,
                d * h.sin() / (111_000.0 * AIRCRAFT.0.to_radians().cos()),
            );
            json!({"t": T0 + 6.8 + 0.2 * f64::from(k), "lat": lat + dlat, "lon": lon + dlon,
                   "alt_msl_m": 60.96, "heading_deg": heading})
        })
        .collect();
    post(level).await;
    let carried = plan(
        &app,
        &id,
        json!({"seed": 5, "base_revision": 2, "current_index": 1}),
    )
    .await;
    let vc = num(&carried, "/start/speed_mps");
    let rc = assumed_radius_m(&carried);
    assert!(
        rc < 0.8 * vc * vc / (G * 30f64.to_radians().tan()),
        "{rc} m at {vc} m/s: {}",
        carried["warnings"]
    );
    assert_replays_identically(&app, &id, &carried).await;
    // ... and not without one (nothing says which flight the newest samples belong to).
    let fresh = plan(&app, &id, json!({"seed": 5, "current_index": 1})).await;
    let rf = assumed_radius_m(&fresh);
    assert!(
        (rf - vc * vc / (G * 30f64.to_radians().tan())).abs() < 0.11,
        "{rf}: {}",
        fresh["warnings"]
    );
    // A radius in the request still wins.
    let given = plan(
        &app,
        &id,
        json!({"seed": 5, "aircraft": {"turn_radius_m": 50.0}}),
    )
    .await;
    assert_eq!(warning(&given, "turn_radius_assumed"), None);
}

/// The message of a plan's warning `code`, if it has one.
fn warning(plan: &Value, code: &str) -> Option<String> {
    plan["warnings"]
        .as_array()
        .expect("warnings")
        .iter()
        .find(|w| w["code"] == code)
        .map(|w| w["message"].as_str().expect("message").to_string())
}

/// Asserts that the stored `plan` replays identically.
async fn assert_replays_identically(app: &App, id: &str, plan: &Value) {
    let replay = app
        .post_ok(
            &format!(
                "/api/v1/missions/{id}/plans/{}/replay",
                plan["plan_id"].as_str().unwrap()
            ),
            &json!({}),
        )
        .await;
    assert_eq!(replay["identical"], true, "{replay}");
}

/// Posts the aircraft flying north at 20 m/s at 5 Hz, `east_m` east of `at` (a waypoint),
/// samples `samples` of the flight from 300 m south of it (sample 0, at `t0`) to 100 m north
/// of it (sample 100).
async fn fly_past(
    app: &App,
    id: &str,
    at: &Value,
    east_m: f64,
    t0: f64,
    samples: std::ops::RangeInclusive<u32>,
) {
    let track = samples.map(|k| {
        let k = f64::from(k);
        (t0 + 0.2 * k, east_m, -300.0 + 4.0 * k, 0.0)
    });
    post_track(app, id, at, track).await;
}

/// Posts the aircraft's telemetry at 20 m/s: `(t, east_m, north_m, heading_deg)` each, the
/// offsets from `at` (a waypoint), at its altitude.
async fn post_track(
    app: &App,
    id: &str,
    at: &Value,
    track: impl Iterator<Item = (f64, f64, f64, f64)>,
) {
    let (lat, lon, alt) = (num(at, "/lat"), num(at, "/lon"), num(at, "/alt_msl_m"));
    // Metres per degree at this latitude (WGS-84, to well under 0.1%).
    let m_lat = 111_132.9 - 559.8 * (2.0 * lat.to_radians()).cos();
    let m_lon = 111_412.8 * lat.to_radians().cos();
    let track: Vec<Value> = track
        .map(|(t, east, north, heading)| {
            json!({"t": t, "lat": lat + north / m_lat, "lon": lon + east / m_lon,
                   "alt_msl_m": alt, "heading_deg": heading, "speed_mps": 20.0})
        })
        .collect();
    let r = app
        .post_json(&format!("/api/v1/missions/{id}/telemetry"), &json!(track))
        .await;
    assert_eq!(r.status(), 202);
}

/// The distance ("passed N m") in `plan`'s warning `code`, which must be there.
fn passed_at(plan: &Value, code: &str) -> f64 {
    let message =
        warning(plan, code).unwrap_or_else(|| panic!("a {code} warning: {}", plan["warnings"]));
    message
        .split("passed ")
        .nth(1)
        .and_then(|m| m.split(" m").next())
        .and_then(|m| m.parse().ok())
        .unwrap_or_else(|| panic!("a distance in: {message}"))
}

/// A new Webster mission's id and its waypoint 1 as stored.
async fn webster_waypoint_1(app: &App) -> (String, Value) {
    let id = app.create_webster_mission().await;
    let m = app.get_json(&format!("/api/v1/missions/{id}")).await;
    let wp = m["waypoints"][1].clone();
    (id, wp)
}

/// The autopilot went past the waypoint the last plan pursued 40 m off (it crossed the
/// waypoint's finish line): the judges count 100 ft, so the next plan flies that waypoint
/// again (a copy of it is the next mission item, after any turn-back item; warning
/// `waypoint_revisited` with the distance),
/// replays identically; a copy passed wide is flown again too, but a waypoint is passed
/// three times at most (`planner::revisit::MAX_PASSES`). Passed within 100 ft, or with
/// `"revisit_missed": false`, the plan goes on.
async fn a_waypoint_passed_wider_than_100_ft_is_flown_again_at_most_twice(app: App) {
    // A Webster mission, the aircraft 300 m south of waypoint 1 `east_m` east of it, a
    // first plan toward waypoint 1, then the rest of the pass.
    let pass = |east_m: f64| {
        let app = &app;
        async move {
            let (id, wp) = webster_waypoint_1(app).await;
            fly_past(app, &id, &wp, east_m, T0, 0..=0).await;
            let p1 = plan(app, &id, json!({"seed": 1, "current_index": 1})).await;
            let k = next_mission_item(&p1, 1);
            assert_eq!(p1["waypoints"][k]["mission_index"], 1, "{p1}");
            fly_past(app, &id, &wp, east_m, T0, 1..=100).await;
            (id, wp, k)
        }
    };
    let same_place = |a: &Value, b: &Value| {
        a["mission_index"] == 1 && a["lat"] == b["lat"] && a["lon"] == b["lon"]
    };
    let (id, wp, k) = pass(40.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": k + 1});
    let p2 = plan(&app, &id, body).await;
    let passed = passed_at(&p2, "waypoint_revisited");
    assert!((passed - 40.0).abs() < 0.5, "{passed}");
    let wps = p2["waypoints"].as_array().unwrap();
    assert!(
        same_place(&wps[k], &wp),
        "the items before the current one stay"
    );
    let copy = next_mission_item(&p2, k + 1);
    assert!(
        same_place(&wps[copy], &wp),
        "a copy of it is flown next: {p2}"
    );
    assert!(
        wps[k + 1..copy].iter().all(|w| w["kind"] == "avoid"),
        "only turn-back items before the copy: {p2}"
    );
    assert_eq!(p2["current_index"], k + 1);
    assert_eq!(p2["diff"]["first_changed"], k + 1, "{}", p2["diff"]);
    assert_replays_identically(&app, &id, &p2).await;
    let copies = |p: &Value| {
        p["waypoints"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|w| same_place(w, &wp))
            .count()
    };
    // The copy missed too (the track goes on from the last plan's time, so the evidence
    // is there): flown a third time.
    fly_past(&app, &id, &wp, 40.0, T0 + 20.2, 0..=100).await;
    let body = json!({"seed": 3, "base_revision": 2, "current_index": copy + 1});
    let p3 = plan(&app, &id, body).await;
    assert!(
        warning(&p3, "waypoint_revisited").is_some(),
        "{}",
        p3["warnings"]
    );
    assert_eq!(copies(&p3), 3, "{p3}");
    let third = next_mission_item(&p3, copy + 1);
    assert!(same_place(&p3["waypoints"][third], &wp), "{p3}");
    // Missed a third time, with the same evidence: not a fourth.
    fly_past(&app, &id, &wp, 40.0, T0 + 40.4, 0..=100).await;
    let body = json!({"seed": 4, "base_revision": 3, "current_index": third + 1});
    let p4 = plan(&app, &id, body).await;
    assert_eq!(
        warning(&p4, "waypoint_revisited"),
        None,
        "{}",
        p4["warnings"]
    );
    assert_eq!(copies(&p4), 3, "{p4}");

    // Within 100 ft (25 m off): captured, nothing to fly again.
    let (id, wp, k) = pass(25.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": k + 1});
    let near = plan(&app, &id, body).await;
    assert_eq!(
        warning(&near, "waypoint_revisited"),
        None,
        "{}",
        near["warnings"]
    );
    assert!(!same_place(
        &near["waypoints"][next_mission_item(&near, k + 1)],
        &wp
    ));
    // 40 m off, but the client turned revisits off.
    let (id, wp, k) = pass(40.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": k + 1,
                      "revisit_missed": false});
    let off = plan(&app, &id, body).await;
    assert_eq!(
        warning(&off, "waypoint_revisited"),
        None,
        "{}",
        off["warnings"]
    );
    assert!(!same_place(
        &off["waypoints"][next_mission_item(&off, k + 1)],
        &wp
    ));
}

/// The autopilot went past the waypoint the last plan pursued 35 m west of it and 20 m
/// short (40.3 m at the closest), heading north, with the next waypoint to the south-east:
/// the turn for it (35 m radius) would capture the waypoint, so the next plan does not fly
/// it again but keeps it under watch (`planner::Watch`, stored with the plan). The aircraft
/// then flew west instead: the plan after that flies it again (`waypoint_revisited`,
/// 40.3 m). Without the watch that pass was never judged again (Webster Field, spline
/// seed 124, a waypoint lost).
async fn a_pass_the_turn_ahead_may_capture_is_judged_again_at_the_next_plan(app: App) {
    let (id, wp) = webster_waypoint_1(&app).await;
    let radius = json!({"turn_radius_m": 35.0});
    fly_past(&app, &id, &wp, -35.0, T0, 0..=0).await;
    let p1 = plan(
        &app,
        &id,
        json!({"seed": 1, "current_index": 1, "aircraft": radius}),
    )
    .await;
    let k = next_mission_item(&p1, 1);
    assert_eq!(p1["waypoints"][k]["mission_index"], 1, "{p1}");
    // North up to 20 m short of it: the autopilot switched to the next item.
    fly_past(&app, &id, &wp, -35.0, T0, 1..=70).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": k + 1, "aircraft": radius});
    let p2 = plan(&app, &id, body).await;
    assert_eq!(
        warning(&p2, "waypoint_revisited"),
        None,
        "the turn ahead may yet capture it: {}",
        p2["warnings"]
    );
    assert_eq!(
        p2["waypoints"][next_mission_item(&p2, k + 1)]["mission_index"],
        2,
        "{p2}"
    );
    // Then one second west, away from it.
    let west = (1..=5).map(|j| {
        let j = f64::from(j);
        (T0 + 14.0 + 0.2 * j, -35.0 - 4.0 * j, -20.0, 270.0)
    });
    post_track(&app, &id, &wp, west).await;
    let body = json!({"seed": 3, "base_revision": 2, "current_index": k + 1, "aircraft": radius});
    let p3 = plan(&app, &id, body).await;
    let passed = passed_at(&p3, "waypoint_revisited");
    assert!((passed - 35f64.hypot(20.0)).abs() < 0.5, "{passed}");
    let copy = next_mission_item(&p3, k + 1);
    assert_eq!(p3["waypoints"][copy]["mission_index"], 1, "{p3}");
    assert_replays_identically(&app, &id, &p3).await;
}

/// The aircraft went past the waypoint the last plan pursued 15 m off while the autopilot
/// still flew toward an avoid item before it (the plan's detour round a sphere sitting on
/// the straight line): the judges count it, so the next plan drops the avoid items and the
/// waypoint and goes on to the next one (warning `waypoint_captured_on_the_way` with the
/// distance), and replays identically. 40 m off, or with `"skip_captured": false`, the
/// waypoint stays the next mission item.
async fn a_waypoint_captured_on_the_way_to_an_avoid_item_is_skipped(app: App) {
    let detour = |east_m: f64| {
        let app = &app;
        async move {
            let (id, wp) = webster_waypoint_1(app).await;
            let (lat, lon, alt) = (num(&wp, "/lat"), num(&wp, "/lon"), num(&wp, "/alt_msl_m"));
            // A sphere of 40 m 150 m south of waypoint 1, still for 5 s.
            let south = 150.0 / (111_132.9 - 559.8 * (2.0 * lat.to_radians()).cos());
            let obs: Vec<Value> = (0..=10)
                .map(|k| {
                    json!({"obstacle_id": "9", "t": T0 - 5.0 + 0.5 * f64::from(k),
                           "lat": lat - south, "lon": lon, "alt_msl_m": alt, "radius_m": 40.0})
                })
                .collect();
            app.post_observations(&id, json!(obs)).await;
            fly_past(app, &id, &wp, east_m, T0, 0..=0).await;
            let p1 = plan(app, &id, json!({"seed": 1, "current_index": 1})).await;
            let k = next_mission_item(&p1, 1);
            assert_eq!(p1["waypoints"][k]["mission_index"], 1, "{p1}");
            assert!(k > 1, "avoid items before waypoint 1: {p1}");
            // The rest of the pass; the autopilot still flies toward item 1.
            fly_past(app, &id, &wp, east_m, T0, 1..=100).await;
            (id, p1)
        }
    };
    let has_waypoint_1 = |p: &Value| {
        p["waypoints"].as_array().unwrap()[1..]
            .iter()
            .any(|w| w["mission_index"] == 1)
    };
    let (id, p1) = detour(15.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": 1});
    let p2 = plan(&app, &id, body).await;
    let passed = passed_at(&p2, "waypoint_captured_on_the_way");
    assert!((passed - 15.0).abs() < 0.5, "{passed}");
    assert!(!has_waypoint_1(&p2), "waypoint 1 is skipped: {p2}");
    assert_eq!(
        p2["waypoints"][0], p1["waypoints"][0],
        "the item before stays"
    );
    assert_eq!(
        p2["waypoints"][next_mission_item(&p2, 1)]["mission_index"],
        2,
        "{p2}"
    );
    assert_eq!(p2["current_index"], 1);
    assert_eq!(p2["diff"]["first_changed"], 1, "{}", p2["diff"]);
    assert_replays_identically(&app, &id, &p2).await;

    // 40 m off: not captured (the judges' 100 ft less the margin is 25 m).
    let (id, _) = detour(40.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": 1});
    let wide = plan(&app, &id, body).await;
    assert_eq!(warning(&wide, "waypoint_captured_on_the_way"), None);
    assert!(has_waypoint_1(&wide), "{wide}");
    // 15 m off, but the client turned the skip off.
    let (id, _) = detour(15.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": 1,
                      "skip_captured": false});
    let off = plan(&app, &id, body).await;
    assert_eq!(warning(&off, "waypoint_captured_on_the_way"), None);
    assert!(has_waypoint_1(&off), "{off}");
}

/// The autopilot flies toward waypoint 1 (no obstacle: the plan is the mission's own
/// stack) and the aircraft is 20 m short of it, outside the autopilot's 10 m acceptance
/// radius and short of the finish line, so the autopilot has not switched: the judges
/// count it (within 100 ft less the margin), so the next plan drops it, flies toward
/// waypoint 2 (warning `waypoint_captured_on_the_way` with the distance) and replays
/// identically; waypoint 2's clock (`target_pending_s`) starts at that plan, not with
/// waypoint 1's. 40 m short, or with `"skip_captured": false`, waypoint 1 stays the
/// item flown toward.
async fn the_waypoint_flown_toward_captured_short_of_it_is_skipped(app: App) {
    // From 300 m south of waypoint 1 to `short_m` short of it, at 20 m/s.
    let approach = |short_m: f64| {
        let app = &app;
        async move {
            let (id, wp) = webster_waypoint_1(app).await;
            let last = ((300.0 - short_m) / 4.0).round() as u32;
            fly_past(app, &id, &wp, 0.0, T0, 0..=0).await;
            let p1 = plan(app, &id, json!({"seed": 1, "current_index": 1})).await;
            assert_eq!(p1["waypoints"][1]["mission_index"], 1, "{p1}");
            assert_eq!(p1["waypoints"][1]["kind"], "mission", "{p1}");
            fly_past(app, &id, &wp, 0.0, T0, 1..=last).await;
            (id, p1, wp)
        }
    };
    let (id, p1, wp) = approach(20.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": 1});
    let p2 = plan(&app, &id, body).await;
    let passed = passed_at(&p2, "waypoint_captured_on_the_way");
    assert!((passed - 20.0).abs() < 0.5, "{passed}");
    assert_eq!(p2["current_index"], 1);
    let k = next_mission_item(&p2, 1);
    assert_eq!(p2["waypoints"][k]["mission_index"], 2, "{p2}");
    assert_eq!(
        p2["waypoints"][0], p1["waypoints"][0],
        "the item before stays"
    );
    assert_eq!(p2["diff"]["first_changed"], 1, "{}", p2["diff"]);
    assert_replays_identically(&app, &id, &p2).await;
    // Waypoint 2 has been the target since p2 (14 s after p1), not since p1, which began
    // waypoint 1's clock.
    let pending = |p: &Value| p["target_pending_s"].as_f64().unwrap();
    fly_past(&app, &id, &wp, 0.0, T0, 71..=75).await;
    let body = json!({"seed": 3, "base_revision": 2, "current_index": 1});
    let p3 = plan(&app, &id, body).await;
    assert!((pending(&p3) - 1.0).abs() < 1e-6, "{p3}");
    fly_past(&app, &id, &wp, 0.0, T0, 76..=80).await;
    let body = json!({"seed": 4, "base_revision": 3, "current_index": 1});
    let p4 = plan(&app, &id, body).await;
    assert!((pending(&p4) - 2.0).abs() < 1e-6, "{p4}");

    // 40 m short: not yet captured, waypoint 1 is still flown toward.
    let (id, _, _) = approach(40.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": 1});
    let far = plan(&app, &id, body).await;
    assert_eq!(warning(&far, "waypoint_captured_on_the_way"), None);
    assert_eq!(
        far["waypoints"][next_mission_item(&far, 1)]["mission_index"],
        1,
        "{far}"
    );
    // 20 m short, but the client turned the skip off.
    let (id, _, _) = approach(20.0).await;
    let body = json!({"seed": 2, "base_revision": 1, "current_index": 1,
                      "skip_captured": false});
    let off = plan(&app, &id, body).await;
    assert_eq!(warning(&off, "waypoint_captured_on_the_way"), None);
    assert_eq!(
        off["waypoints"][next_mission_item(&off, 1)]["mission_index"],
        1,
        "{off}"
    );
}

/// The mission indices of a plan's stack from `from` on (`None` for avoid items).
fn mission_indices(plan: &Value, from: usize) -> Vec<Option<u64>> {
    plan["waypoints"].as_array().unwrap()[from..]
        .iter()
        .map(|w| w["mission_index"].as_u64())
        .collect()
}

/// Whether a plan carries the warning `code`.
fn warns(plan: &Value, code: &str) -> bool {
    plan["warnings"]
        .as_array()
        .is_some_and(|w| w.iter().any(|w| w["code"] == code))
}

/// Asks for a plan (`seed`, `base_revision`, `current_index`) with the fields of `extra`
/// added, and expects 201.
async fn plan_from(
    app: &App,
    id: &str,
    (seed, base, current): (u64, i64, usize),
    extra: Value,
) -> Value {
    let mut body = json!({"seed": seed, "base_revision": base, "current_index": current});
    if let (Some(b), Value::Object(extra)) = (body.as_object_mut(), extra) {
        b.extend(extra);
    }
    plan(app, id, body).await
}

/// A waypoint the aircraft has flown toward for longer than `defer_after_s` (240 s by
/// default) is put off: the plan moves it to the end of the stack, flies the waypoints
/// after it first and warns `waypoint_deferred`; the next waypoint's clock starts again.
/// `"defer_after_s": 0` keeps it, and the stored plan replays identically.
async fn a_waypoint_pursued_for_four_minutes_is_put_off_to_the_end_of_the_stack(app: App) {
    let id = webster_with_traffic(&app).await;
    let telemetry_at = |t: f64| aircraft_at_waypoint_0(&app, &id, t);
    // Revision 1 starts the clock of mission waypoint 1 (telemetry at T0 + 10).
    let p1 = plan(&app, &id, json!({"seed": 1, "current_index": 1})).await;
    let toward = next_mission_item(&p1, 1);
    let flown = |p: &Value| mission_indices(p, toward);
    assert_eq!(flown(&p1)[0], Some(1), "{p1}");
    // 240 s on, still toward it: not longer than the limit, kept.
    telemetry_at(T0 + 250.0).await;
    let p2 = plan_from(&app, &id, (2, 1, toward), json!({})).await;
    assert_eq!(p2["target_pending_s"], 240.0, "{p2}");
    assert!(!warns(&p2, "waypoint_deferred"), "{p2}");
    let toward = next_mission_item(&p2, toward);
    assert_eq!(p2["waypoints"][toward]["mission_index"], 1, "{p2}");
    // 250 s: with the rule off it is still the waypoint flown toward ...
    telemetry_at(T0 + 260.0).await;
    let off = plan_from(&app, &id, (3, 2, toward), json!({"defer_after_s": 0})).await;
    assert!(!warns(&off, "waypoint_deferred"), "{off}");
    assert_eq!(
        off["waypoints"][next_mission_item(&off, toward)]["mission_index"],
        1
    );
    // ... and by default it is put off: waypoints 2-13 first, then 1, the items before
    // the current index as they were.
    let p4 = plan_from(&app, &id, (4, 3, toward), json!({})).await;
    assert_eq!(p4["target_pending_s"], 250.0, "{p4}");
    assert!(warns(&p4, "waypoint_deferred"), "{p4}");
    let missions: Vec<u64> = mission_indices(&p4, toward).into_iter().flatten().collect();
    assert_eq!(missions, (2..14).chain([1]).collect::<Vec<u64>>(), "{p4}");
    assert_eq!(
        p4["waypoints"].as_array().unwrap()[..toward],
        off["waypoints"].as_array().unwrap()[..toward]
    );
    assert_eq!(p4["diff"]["first_changed"], toward, "{p4}");
    let plan_id = p4["plan_id"].as_str().unwrap();
    let v = replay(&app, &id, plan_id).await;
    assert_eq!(v["identical"], true, "{v}");
    // The next waypoint's clock starts at that plan.
    telemetry_at(T0 + 265.0).await;
    let p5 = plan_from(&app, &id, (5, 4, toward), json!({})).await;
    assert_eq!(p5["target_pending_s"], 5.0, "{p5}");
    assert!(!warns(&p5, "waypoint_deferred"), "{p5}");
}
