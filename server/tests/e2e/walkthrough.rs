//! The README's "A walk-through with curl", step by step against the binary, with the
//! answers the README promises. Keep the two in step: a README change that this test does
//! not follow is a broken promise.

use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, fixture, fixture_text, warning_codes};

both_stores!(the_readme_walk_through_does_what_it_says);

async fn the_readme_walk_through_does_what_it_says(app: App) {
    // 1. Upload the Webster Field mission (2021 protobuf-JSON, feet).
    let r = app
        .client
        .post(app.url("/api/v1/missions"))
        .header("content-type", "application/json")
        .body(fixture_text("mission_2021_webster_field.json"))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let m: Value = r.json().await.unwrap();
    let id = m["id"].as_str().unwrap().to_string();
    // 2. Read it back: 200 ft became 60.96 m, a cylinder's height became top_msl_m.
    let m = app.get_json(&format!("/api/v1/missions/{id}")).await;
    assert!(
        (m["waypoints"][0]["alt_msl_m"].as_f64().unwrap() - 60.96).abs() < 1e-6,
        "{m}"
    );
    assert!(m["stationary_obstacles"][0]["top_msl_m"].is_number());
    // 3. An interop 2018 snapshot stamped with ?time=, twice; then a native batch.
    let snap = fixture("obstacles_2018.json");
    let path = format!("/api/v1/missions/{id}/obstacles?time=2026-06-14T15:00:00Z");
    let r: Value = app.post_json(&path, &snap).await.json().await.unwrap();
    assert_eq!(r, json!({"accepted": 2, "duplicate": 0}));
    let r: Value = app.post_json(&path, &snap).await.json().await.unwrap();
    assert_eq!(r, json!({"accepted": 0, "duplicate": 2}));
    app.post_observations(
        &id,
        json!([
            {"obstacle_id": "7", "t": "2026-06-14T15:00:01Z", "lat": 38.1450, "lon": -76.4300, "alt_msl_m": 80, "radius_m": 15},
            {"obstacle_id": "7", "t": "2026-06-14T15:00:00Z", "lat": 38.1449, "lon": -76.4301, "alt_msl_m": 80, "radius_m": 15}]),
    )
    .await;
    // 4. Native telemetry, then interop 2018 form-encoded (no time: stamped on receipt).
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/telemetry"),
            &json!({"t": "2026-06-14T15:00:01Z", "lat": 38.1447, "lon": -76.4280, "alt_msl_m": 91.4, "heading_deg": 45, "speed_mps": 18}),
        )
        .await;
    assert_eq!(r.status(), 202);
    app.post_telemetry_form(
        &id,
        "latitude=38.1448&longitude=-76.4279&altitude_msl=300&uas_heading=46",
    )
    .await;
    // 5. What is stored, in time order.
    let o = app
        .get_json(&format!("/api/v1/missions/{id}/observations?obstacle_id=7"))
        .await;
    assert_eq!(o.as_array().unwrap().len(), 2);
    let tel = app
        .get_json(&format!("/api/v1/missions/{id}/telemetry?last=10"))
        .await;
    assert_eq!(tel.as_array().unwrap().len(), 2);
    // 6. Bad input: 422 problem naming the field.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/obstacles"),
            &json!({"observations": [{"obstacle_id": "7", "t": 5, "lat": 95, "lon": -76.43, "alt_msl_m": 80, "radius_m": 15}]}),
        )
        .await;
    assert_eq!(r.status(), 422);
    let p: Value = r.json().await.unwrap();
    assert_eq!(p["type"], "urn:jink:problem:validation");
    assert_eq!(p["errors"][0]["pointer"], "/observations/0/lat");
    // 7. Obstacles with stages; the risk map 5 s ahead as a PNG.
    let obs = app
        .get_json(&format!("/api/v1/missions/{id}/obstacles"))
        .await;
    let moving: Vec<&str> = obs
        .as_array()
        .unwrap()
        .iter()
        .filter(|o| o["kind"] == "moving")
        .map(|o| o["id"].as_str().unwrap())
        .collect();
    assert_eq!(moving, ["0", "1", "7"]);
    let r = app
        .get(&format!("/api/v1/missions/{id}/risk/png?t=5"))
        .await;
    assert_eq!(r.status(), 200);
    assert_eq!(&r.bytes().await.unwrap()[1..4], b"PNG");
    // 8. The plan: receipt-stamped telemetry months after client-stamped obstacles.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/plan"),
            &json!({"seed": 42, "current_index": 1,
                    "aircraft": {"speed_mps": 20, "turn_radius_m": 58}}),
        )
        .await;
    assert_eq!(r.status(), 201);
    let plan: Value = r.json().await.unwrap();
    let codes = warning_codes(&plan);
    assert_eq!(codes, ["clock_mismatch", "obstacles_left_out"], "{plan}");
    let listed: Vec<(&str, &Value, &Value)> = plan["obstacles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| (o["id"].as_str().unwrap(), &o["considered"], &o["left_out"]))
        .collect();
    assert_eq!(
        listed,
        [
            ("0", &json!(false), &json!("stale")),
            ("1", &json!(false), &json!("stale")),
            ("7", &json!(false), &json!("stale"))
        ]
    );
    assert_eq!(plan["outcome"], "exact");
    let pid = plan["plan_id"].as_str().unwrap();
    // 9. QGC WPL 110 download.
    let r = app
        .get(&format!("/api/v1/missions/{id}/plans/{pid}?format=qgc-wpl"))
        .await;
    assert_eq!(r.status(), 200);
    assert!(r.text().await.unwrap().starts_with("QGC WPL 110"));
    // 10. Planning from an older revision than the latest: 409.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/plan"),
            &json!({"base_revision": 0}),
        )
        .await;
    assert_eq!(r.status(), 409);
    let p: Value = r.json().await.unwrap();
    assert_eq!(p["type"], "urn:jink:problem:conflict");
    assert_eq!(
        p["detail"],
        "base_revision 0 is older than the latest revision 1: plan from revision 1"
    );
    // The latest revision is a member of its own, for clients to replan from.
    assert_eq!(p["latest_revision"], 1);
    // A revision that does not exist: 422 naming the field, and the latest too.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/plan"),
            &json!({"base_revision": 7}),
        )
        .await;
    assert_eq!(r.status(), 422);
    let p: Value = r.json().await.unwrap();
    assert_eq!(p["errors"][0]["pointer"], "/base_revision");
    assert_eq!(p["latest_revision"], 1);
}
