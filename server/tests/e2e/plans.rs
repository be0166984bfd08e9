//! Plans: the Webster mission planned from telemetry with moving obstacles, revisions and
//! 409 on a stale base, the three download formats, same seed same plan; waypoint
//! insertion over HTTP.

use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, fixture, pointers, problem};

both_stores!(
    the_webster_mission_is_planned_from_telemetry_around_moving_obstacles,
    a_stale_base_revision_is_refused_with_409,
    a_plan_downloads_as_json_qgc_wpl_and_qgc_plan,
    the_same_seed_replays_the_same_plan,
    insert_waypoint_answers_the_seed_004_example,
    a_stored_plan_replays_identically_even_after_more_telemetry,
);

async fn webster_with_traffic(app: &App) -> String {
    let id = app
        .create_mission(&fixture("mission_2021_webster_field.json"))
        .await;
    // Aircraft at waypoint 0 (38.14469, -76.42799, 200 ft), heading to waypoint 1.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/telemetry"),
            &json!({"t": 1_700_000_010.0, "lat": 38.1446916666667, "lon": -76.4279944444445,
                    "alt_msl_m": 60.96, "heading_deg": 60.0, "speed_mps": 20.0}),
        )
        .await;
    assert_eq!(r.status(), 202);
    // Obstacle "0" flies east along the first leg toward the aircraft; "1" sits north.
    let mut obs = Vec::new();
    for k in 0..=10 {
        let t = 1_700_000_000.0 + f64::from(k);
        obs.push(json!({"obstacle_id": "0", "t": t, "lat": 38.1455, "lon": -76.4245 - 0.00005 * f64::from(k),
                        "alt_msl_m": 60.0, "radius_m": 20.0}));
        obs.push(json!({"obstacle_id": "1", "t": t, "lat": 38.149, "lon": -76.430, "alt_msl_m": 80.0, "radius_m": 15.0}));
    }
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/obstacles"),
            &json!({"observations": obs}),
        )
        .await;
    assert_eq!(r.status(), 202);
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
    assert!(p["risk"].as_f64().unwrap() <= p["base_risk"].as_f64().unwrap());
    // The diff rewrites a tail from the current index on.
    if let Some(first) = p["diff"]["first_changed"].as_u64() {
        assert!(first >= 1);
        assert_eq!(
            p["diff"]["insert"].as_array().unwrap().len() as u64,
            wps.len() as u64 - first
        );
    }
    assert!(p["compute_ms"].as_f64().unwrap() >= 0.0);
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
}

async fn a_plan_downloads_as_json_qgc_wpl_and_qgc_plan(app: App) {
    let id = webster_with_traffic(&app).await;
    let p = plan(&app, &id, json!({"seed": 3})).await;
    let pid = p["plan_id"].as_str().unwrap();
    let base = format!("/api/v1/missions/{id}/plans/{pid}");
    assert_eq!(app.get_json(&base).await, p);
    assert_eq!(app.get_json(&format!("{base}?format=json")).await, p);

    let r = app.get(&format!("{base}/qgc-wpl")).await;
    assert_eq!(r.status(), 200);
    assert!(
        r.headers()["content-type"]
            .to_str()
            .unwrap()
            .starts_with("text/plain")
    );
    let text = r.text().await.unwrap();
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
    // A 1 km east-west leg at 38 N with an obstacle of radius 40 m 10 m north of its middle:
    // the chosen waypoint is south of the leg (the shorter detour), on the r + 2b = 56 m
    // circle: 46 m south of the leg, so the latitude drops by ~46 / 111000 deg.
    let r = app
        .post_json(
            "/api/v1/avoid/insert-waypoint",
            &json!({"from": {"lat": 38.0, "lon": -76.0}, "to": {"lat": 38.0, "lon": -75.98865},
                    "obstacle": {"lat": 38.00009, "lon": -75.994325, "radius_m": 40.0}}),
        )
        .await;
    assert_eq!(r.status(), 200);
    let v: Value = r.json().await.unwrap();
    assert_eq!(v["outcome"], "inserted", "{v}");
    assert_eq!(v["candidates"].as_array().unwrap().len(), 2);
    let lat = v["waypoint"]["lat"].as_f64().unwrap();
    assert!(lat < 38.0, "{v}");
    assert!((lat - 38.0 + 46.0 / 111_000.0).abs() < 0.00003, "{lat}");
    // A leg far from the obstacle needs nothing.
    let r = app
        .post_json(
            "/api/v1/avoid/insert-waypoint",
            &json!({"from": {"lat": 38.0, "lon": -76.0}, "to": {"lat": 38.0, "lon": -75.99},
                    "obstacle": {"lat": 38.01, "lon": -75.995, "radius_m": 40.0}}),
        )
        .await;
    let v: Value = r.json().await.unwrap();
    assert_eq!(v["outcome"], "not_needed");
    assert!(v["waypoint"].is_null());
    let r = app
        .post_json(
            "/api/v1/avoid/insert-waypoint",
            &json!({"from": {"lat": 38.0, "lon": -76.0}, "to": {"lat": 38.0, "lon": -75.99},
                    "obstacle": {"lat": 38.0, "lon": -75.995, "radius_m": -1.0}}),
        )
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
            json!({"obstacle_id": "0", "t": 1_700_000_000 + k, "lat": 38.1455, "lon": -76.4245 - 0.00005 * f64::from(k),
                   "alt_msl_m": 60.0, "radius_m": 20.0})
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
    assert!(a["risk"].as_f64().unwrap() <= a["base_risk"].as_f64().unwrap());
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
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/obstacles"),
            &json!({"observations": late}),
        )
        .await;
    assert_eq!(r.status(), 202);
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
