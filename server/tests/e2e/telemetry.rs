//! Telemetry ingest: formats, units, duplicates, ordering, validation.

use approx::assert_abs_diff_eq;
use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, fixture, ingest_counts, num, nums, pointers, problem, problem_about};

both_stores!(
    duplicate_and_out_of_order_observations_are_stored_once_in_time_order,
    an_interop_2018_snapshot_is_stored_by_index_in_metres,
    aircraft_telemetry_is_accepted_in_all_three_formats,
    invalid_telemetry_names_the_field_and_stores_nothing,
);

fn obs(id: &str, t: f64, lat: f64) -> Value {
    json!({"obstacle_id": id, "t": t, "lat": lat, "lon": -76.43, "alt_msl_m": 80.0, "radius_m": 15.0})
}

async fn duplicate_and_out_of_order_observations_are_stored_once_in_time_order(app: App) {
    let id = app.create_webster_mission().await;
    let path = format!("/api/v1/missions/{id}/obstacles");
    // Radio links reorder: t = 3, 1, 2 for obstacle a; b interleaved; an RFC 3339 time.
    let batch = json!({"observations": [obs("a", 1_700_000_003.0, 38.143), obs("a", 1_700_000_001.0, 38.141),
        obs("b", 1_700_000_002.5, 38.150), obs("a", 1_700_000_002.0, 38.142)]});
    let r = app.post_json(&path, &batch).await;
    assert_eq!(ingest_counts(r).await, (4, 0));

    // The same observation twice (and one new one): counted as duplicates.
    let again = json!({"observations": [obs("a", 1_700_000_001.0, 38.141), obs("a", 1_700_000_002.0, 38.142),
        {"obstacle_id": "a", "t": "2023-11-14T22:13:24Z", "lat": 38.144, "lon": -76.43, "alt_msl_m": 80.0, "radius_m": 15.0}]});
    let r = app.post_json(&path, &again).await;
    assert_eq!(ingest_counts(r).await, (1, 2));

    let all = app
        .get_json(&format!("/api/v1/missions/{id}/observations"))
        .await;
    let ts = nums(&all, "t");
    assert_eq!(
        ts,
        vec![
            1_700_000_001.0,
            1_700_000_002.0,
            1_700_000_002.5,
            1_700_000_003.0,
            1_700_000_004.0
        ]
    );
    let a = app
        .get_json(&format!(
            "/api/v1/missions/{id}/observations?obstacle_id=a&after=1700000002"
        ))
        .await;
    let lats = nums(&a, "lat");
    assert_eq!(lats, vec![38.143, 38.144]);
}

async fn an_interop_2018_snapshot_is_stored_by_index_in_metres(app: App) {
    let id = app.create_mission(&fixture("mission_2018.json")).await;
    let path = format!("/api/v1/missions/{id}/obstacles");
    let mut snap = fixture("obstacles_2018.json");
    let at = |time: &str| format!("{path}?time={time}");
    let r = app.post_json(&at("2018-06-14T15:00:00Z"), &snap).await;
    assert_eq!(ingest_counts(r).await, (2, 0));
    // The same snapshot at the same time is a duplicate.
    let r = app.post_json(&at("1528988400"), &snap).await;
    assert_eq!(ingest_counts(r).await, (0, 2));
    // A `time` field in the body stamps it too.
    snap["time"] = json!(1528988401.0);
    let r = app.post_json(&path, &snap).await;
    assert_eq!(ingest_counts(r).await, (2, 0));

    let all = app
        .get_json(&format!("/api/v1/missions/{id}/observations"))
        .await;
    let all = all.as_array().unwrap();
    assert_eq!(all.len(), 4);
    assert_eq!(all[0]["obstacle_id"], "0");
    assert_eq!(all[1]["obstacle_id"], "1");
    assert_eq!(all[0]["t"].as_f64().unwrap(), 1528988400.0);
    assert_abs_diff_eq!(num(&all[0], "/radius_m"), 45.72, epsilon = 1e-9); // 150 ft
    assert_abs_diff_eq!(num(&all[1], "/alt_msl_m"), 76.2, epsilon = 1e-9); // 250 ft
    assert_abs_diff_eq!(num(&all[0], "/lat"), 38.141826869853645, epsilon = 1e-15);
}

async fn aircraft_telemetry_is_accepted_in_all_three_formats(app: App) {
    let id = app.create_mission(&fixture("mission_2018.json")).await;
    let path = format!("/api/v1/missions/{id}/telemetry");
    // Native, out of order, one duplicate.
    let r = app.post_json(&path, &json!([
        {"t": 1000.5, "lat": 38.1, "lon": -76.4, "alt_msl_m": 60.0, "heading_deg": 90.0, "speed_mps": 18.0},
        {"t": 1000.0, "lat": 38.0, "lon": -76.4, "alt_msl_m": 61.0, "heading_deg": 91.0}
    ])).await;
    assert_eq!(ingest_counts(r).await, (2, 0));
    let r = app.post_json(&path, &json!({"t": 1000.0, "lat": 38.0, "lon": -76.4, "alt_msl_m": 61.0, "heading_deg": 91.0})).await;
    assert_eq!(ingest_counts(r).await, (0, 1));

    // Interop 2018: form-encoded, feet, stamped on receipt.
    let r = app
        .post_raw(
            &path,
            "application/x-www-form-urlencoded",
            "latitude=38.145&longitude=-76.428&altitude_msl=200&uas_heading=270.5",
        )
        .await;
    assert_eq!(r.status(), 202);
    // Interop 2019 JSON (the fixture), feet.
    let r = app.post_json(&path, &fixture("telemetry_2019.json")).await;
    assert_eq!(r.status(), 202);

    let all = app.get_json(&path).await;
    let all = all.as_array().unwrap();
    assert_eq!(all.len(), 4);
    assert_eq!(all[0]["t"].as_f64().unwrap(), 1000.0);
    assert_eq!(all[1]["speed_mps"].as_f64().unwrap(), 18.0);
    assert_abs_diff_eq!(num(&all[2], "/alt_msl_m"), 60.96, epsilon = 1e-9);
    assert_eq!(all[2]["heading_deg"].as_f64().unwrap(), 270.5);
    assert_abs_diff_eq!(num(&all[3], "/alt_msl_m"), 15.24, epsilon = 1e-9); // 50 ft
    assert_eq!(all[3]["lon"].as_f64().unwrap(), -75.0);
    let last = app.get_json(&format!("{path}?last=1")).await;
    assert_eq!(last.as_array().unwrap().len(), 1);
    assert_eq!(last[0]["lat"].as_f64().unwrap(), 38.0);
}

async fn invalid_telemetry_names_the_field_and_stores_nothing(app: App) {
    let id = app.create_mission(&fixture("mission_2018.json")).await;
    let obs_path = format!("/api/v1/missions/{id}/obstacles");
    let bad = json!({"observations": [obs("a", 1.0, 38.0),
        {"obstacle_id": "a", "t": 2.0, "lat": 38.0, "lon": -76.43, "alt_msl_m": 80.0, "radius_m": -1.0}]});
    let p = problem(app.post_json(&obs_path, &bad).await, 422).await;
    assert_eq!(pointers(&p), vec!["/observations/1/radius_m".to_string()]);
    let bad = json!({"observations": [{"obstacle_id": "a", "t": "soon", "lat": 38.0, "lon": -76.43, "alt_msl_m": 80.0, "radius_m": 5.0}]});
    let p = problem(app.post_json(&obs_path, &bad).await, 400).await;
    assert_eq!(pointers(&p), vec!["/observations/0/t".to_string()], "{p}");
    let mut snap = fixture("obstacles_2018.json");
    snap["moving_obstacles"][1]["latitude"] = json!(120.0);
    let p = problem(app.post_json(&obs_path, &snap).await, 422).await;
    assert_eq!(
        pointers(&p),
        vec!["/moving_obstacles/1/latitude".to_string()]
    );
    assert_eq!(
        app.get_json(&format!("/api/v1/missions/{id}/observations"))
            .await,
        json!([])
    );

    let tel = format!("/api/v1/missions/{id}/telemetry");
    let p = problem(
        app.post_json(
            &tel,
            &json!({"lat": 38.0, "lon": -76.0, "alt_msl_m": 50.0, "heading_deg": 400.0}),
        )
        .await,
        422,
    )
    .await;
    assert_eq!(pointers(&p), vec!["/heading_deg".to_string()]);
    problem_about(
        app.post_raw(
            &tel,
            "application/x-www-form-urlencoded",
            "latitude=38&longitude=-76",
        )
        .await,
        400,
        "altitude_msl",
    )
    .await;
    problem(app.post_raw(&tel, "text/csv", "1,2,3").await, 415).await;
    assert_eq!(app.get_json(&tel).await, json!([]));
}
