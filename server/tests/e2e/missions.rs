//! Mission upload in every format, unit conversion, read-back, validation errors.

use approx::assert_abs_diff_eq;
use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, fixture, num, pointers, problem, problem_about};

both_stores!(
    every_interop_fixture_uploads_and_reads_back_in_metres,
    the_2018_mission_list_creates_each_mission,
    a_native_mission_round_trips_and_can_be_deleted,
    snake_case_2019_keys_upload_like_camel_case,
    each_invalid_mission_field_is_named_with_its_status,
    interop_validation_errors_point_into_the_document_as_sent,
    forcing_a_format_parses_the_body_as_that_format,
);

fn square(alt_min: f64, alt_max: f64) -> Value {
    json!({
        "name": "square",
        "fly_zones": [{
            "boundary": [{"lat": 38.0, "lon": -76.0}, {"lat": 38.01, "lon": -76.0},
                         {"lat": 38.01, "lon": -75.99}, {"lat": 38.0, "lon": -75.99}],
            "alt_min_msl_m": alt_min, "alt_max_msl_m": alt_max
        }],
        "waypoints": [{"lat": 38.005, "lon": -75.995, "alt_msl_m": 100.0},
                      {"lat": 38.008, "lon": -75.992, "alt_msl_m": 120.0}],
        "stationary_obstacles": [{"lat": 38.006, "lon": -75.994, "radius_m": 30.0, "top_msl_m": 150.0}]
    })
}

async fn every_interop_fixture_uploads_and_reads_back_in_metres(app: App) {
    // Webster Field, 2021 protobuf-JSON: 12-point fly zone 100-750 ft, 14 waypoints,
    // 6 cylinders.
    let id = app.create_webster_mission().await;
    let m = app.get_json(&format!("/api/v1/missions/{id}")).await;
    assert_eq!(m["source_format"], "interop-2019");
    assert_eq!(m["interop_id"], 1);
    let zone = &m["fly_zones"][0];
    assert_eq!(zone["boundary"].as_array().unwrap().len(), 12);
    assert_abs_diff_eq!(num(zone, "/alt_min_msl_m"), 30.48, epsilon = 1e-9); // 100 ft
    assert_abs_diff_eq!(num(zone, "/alt_max_msl_m"), 228.6, epsilon = 1e-9); // 750 ft
    let wps = m["waypoints"].as_array().unwrap();
    assert_eq!(wps.len(), 14);
    assert_abs_diff_eq!(num(&m, "/waypoints/0/alt_msl_m"), 60.96, epsilon = 1e-9); // 200 ft
    assert_abs_diff_eq!(num(&m, "/waypoints/2/alt_msl_m"), 121.92, epsilon = 1e-9); // 400 ft
    assert_abs_diff_eq!(
        num(&m, "/waypoints/0/lat"),
        38.1446916666667,
        epsilon = 1e-12
    );
    let cyl = m["stationary_obstacles"].as_array().unwrap();
    assert_eq!(cyl.len(), 6);
    assert_abs_diff_eq!(
        num(&m, "/stationary_obstacles/1/radius_m"),
        91.44,
        epsilon = 1e-9
    ); // 300 ft
    assert_abs_diff_eq!(
        num(&m, "/stationary_obstacles/1/top_msl_m"),
        91.44,
        epsilon = 1e-9
    ); // height 300 ft
    assert_eq!(m["search_grid"].as_array().unwrap().len(), 9);
    // The lost-comms position is the home (the 2019+ format has no home field).
    assert_abs_diff_eq!(num(&m, "/home/lat"), 38.144778, epsilon = 1e-12);

    // 2018: feet, `order` fields, home_pos.
    let id = app.create_mission(&fixture("mission_2018.json")).await;
    let m = app.get_json(&format!("/api/v1/missions/{id}")).await;
    assert_eq!(m["source_format"], "interop-2018");
    assert_abs_diff_eq!(num(&m, "/waypoints/0/alt_msl_m"), 60.96, epsilon = 1e-9);
    assert_abs_diff_eq!(num(&m, "/fly_zones/0/alt_min_msl_m"), 30.48, epsilon = 1e-9);
    assert_abs_diff_eq!(num(&m, "/home/lon"), -76.427995, epsilon = 1e-12);

    // 2019: a cylinder's `height` becomes `top_msl_m`.
    let id = app.create_mission(&fixture("mission_2019.json")).await;
    let m = app.get_json(&format!("/api/v1/missions/{id}")).await;
    let c = &m["stationary_obstacles"][0];
    assert_abs_diff_eq!(num(c, "/top_msl_m"), 60.96, epsilon = 1e-9); // 200 ft
    assert_abs_diff_eq!(num(c, "/radius_m"), 45.72, epsilon = 1e-9); // 150 ft
    assert_abs_diff_eq!(
        num(&m, "/stationary_obstacles/1/top_msl_m"),
        91.44,
        epsilon = 1e-9
    );

    let all = app.get_json("/api/v1/missions").await;
    assert_eq!(all.as_array().unwrap().len(), 3);
}

async fn the_2018_mission_list_creates_each_mission(app: App) {
    let r = app
        .post_json(
            "/api/v1/missions",
            &fixture("missions_list_2018_fixture.json"),
        )
        .await;
    assert_eq!(r.status(), 201);
    let location = r.headers()["location"].to_str().unwrap().to_string();
    let v: Value = r.json().await.unwrap();
    let list = v.as_array().expect("a list answers with a list");
    assert_eq!(list.len(), 1);
    assert_eq!(
        location,
        format!("/api/v1/missions/{}", list[0]["id"].as_str().unwrap())
    );
    let m = app.get_json(&location).await;
    assert_abs_diff_eq!(num(&m, "/fly_zones/0/alt_max_msl_m"), 228.6, epsilon = 1e-9);
    assert_abs_diff_eq!(num(&m, "/waypoints/0/alt_msl_m"), 60.96, epsilon = 1e-9);
}

async fn a_native_mission_round_trips_and_can_be_deleted(app: App) {
    let r = app
        .post_json("/api/v1/missions", &square(30.0, 200.0))
        .await;
    assert_eq!(r.status(), 201);
    let location = r.headers()["location"].to_str().unwrap().to_string();
    let created: Value = r.json().await.unwrap();
    let got = app.get_json(&location).await;
    assert_eq!(created, got);
    assert_eq!(got["source_format"], "native");
    assert_eq!(got["name"], "square");
    assert_eq!(
        got["home"],
        json!({"lat": 38.0, "lon": -76.0}),
        "home defaults to the first vertex"
    );
    assert_eq!(got["stationary_obstacles"][0]["id"], "0");
    assert_eq!(
        got["waypoints"][1],
        json!({"lat": 38.008, "lon": -75.992, "alt_msl_m": 120.0})
    );

    let r = app.client.delete(app.url(&location)).send().await.unwrap();
    assert_eq!(r.status(), 204);
    problem(app.get(&location).await, 404).await;
    problem(
        app.client.delete(app.url(&location)).send().await.unwrap(),
        404,
    )
    .await;
}

async fn snake_case_2019_keys_upload_like_camel_case(app: App) {
    let snake = json!({
        "id": 7,
        "fly_zones": [{"altitude_min": 100.0, "altitude_max": 750.0, "boundary_points": [
            {"latitude": 38.142544, "longitude": -76.434088},
            {"latitude": 38.141833, "longitude": -76.425263},
            {"latitude": 38.144678, "longitude": -76.427995}]}],
        "waypoints": [{"latitude": 38.142544, "longitude": -76.434088, "altitude": 200.0}],
        "stationary_obstacles": [{"latitude": 38.14792, "longitude": -76.427995, "radius": 150.0, "height": 200.0}]
    });
    let id = app.create_mission(&snake).await;
    let m = app.get_json(&format!("/api/v1/missions/{id}")).await;
    assert_eq!(m["source_format"], "interop-2019");
    assert_eq!(m["interop_id"], 7);
    assert_abs_diff_eq!(
        num(&m, "/stationary_obstacles/0/top_msl_m"),
        60.96,
        epsilon = 1e-9
    );
}

/// Posts mission `body`: it must be refused as invalid (422, a validation problem), which is
/// returned.
async fn refused(app: &App, body: &Value) -> Value {
    let p = problem(app.post_json("/api/v1/missions", body).await, 422).await;
    assert_eq!(p["type"], "urn:jink:problem:validation", "{p}");
    p
}

async fn each_invalid_mission_field_is_named_with_its_status(app: App) {
    async fn expect(app: &App, body: Value, pointer: &str, needle: &str) {
        let p = refused(app, &body).await;
        let ptrs = pointers(&p);
        assert!(
            ptrs.iter().any(|x| x == pointer),
            "expected {pointer} in {ptrs:?}: {p}"
        );
        let text = p.to_string();
        assert!(text.contains(needle), "expected '{needle}' in {text}");
    }
    let mut m = square(30.0, 200.0);
    m["waypoints"][0]["lat"] = json!(91.0);
    expect(&app, m, "/waypoints/0/lat", "[-90, 90]").await;

    let mut m = square(30.0, 200.0);
    m["waypoints"][1]["lon"] = json!(-180.5);
    expect(&app, m, "/waypoints/1/lon", "[-180, 180]").await;

    let mut m = square(30.0, 200.0);
    m["fly_zones"][0]["boundary"] =
        json!([{"lat": 38.0, "lon": -76.0}, {"lat": 38.01, "lon": -76.0}]);
    expect(&app, m, "/fly_zones/0/boundary", "at least 3").await;

    let mut m = square(30.0, 200.0);
    // A bow tie: the second and third vertices swapped.
    m["fly_zones"][0]["boundary"] = json!([{"lat": 38.0, "lon": -76.0}, {"lat": 38.01, "lon": -75.99},
        {"lat": 38.01, "lon": -76.0}, {"lat": 38.0, "lon": -75.99}]);
    expect(&app, m, "/fly_zones/0/boundary", "self-intersection").await;

    expect(
        &app,
        square(250.0, 200.0),
        "/fly_zones/0/alt_min_msl_m",
        "above the maximum",
    )
    .await;

    let mut m = square(30.0, 200.0);
    m["waypoints"][1] = json!({"lat": 38.02, "lon": -75.995, "alt_msl_m": 100.0});
    expect(&app, m, "/waypoints/1", "outside every fly zone").await;

    let mut m = square(30.0, 200.0);
    m["waypoints"][0]["alt_msl_m"] = json!(250.0);
    expect(
        &app,
        m,
        "/waypoints/0/alt_msl_m",
        "outside the fly zone's band",
    )
    .await;

    for radius in [0.0, -5.0] {
        let mut m = square(30.0, 200.0);
        m["stationary_obstacles"][0]["radius_m"] = json!(radius);
        expect(
            &app,
            m,
            "/stationary_obstacles/0/radius_m",
            "must be positive",
        )
        .await;
    }

    let mut m = square(30.0, 200.0);
    m["fly_zones"] = json!([]);
    expect(&app, m, "/fly_zones", "at least one fly zone").await;

    // JSON has no NaN or infinity: an out-of-range number is a parse error at its field.
    let body = square(30.0, 200.0)
        .to_string()
        .replace("\"lat\":38.005", "\"lat\":1e999");
    let p = problem(
        app.post_raw("/api/v1/missions", "application/json", body)
            .await,
        400,
    )
    .await;
    assert_eq!(p["type"], "urn:jink:problem:bad-request", "{p}");

    // A wrong type names the field.
    let mut m = square(30.0, 200.0);
    m["waypoints"][1]["alt_msl_m"] = json!("high");
    let p = problem(app.post_json("/api/v1/missions", &m).await, 400).await;
    assert_eq!(
        pointers(&p),
        vec!["/waypoints/1/alt_msl_m".to_string()],
        "{p}"
    );

    // Nothing invalid was stored.
    assert_eq!(app.get_json("/api/v1/missions").await, json!([]));
}

async fn interop_validation_errors_point_into_the_document_as_sent(app: App) {
    let mut m = fixture("mission_2021_webster_field.json");
    m["stationaryObstacles"][2]["radius"] = json!(-10.0);
    let p = refused(&app, &m).await;
    assert_eq!(pointers(&p), ["/stationaryObstacles/2/radius"], "{p}");

    let mut m = fixture("mission_2021_webster_field.json");
    m["waypoints"][4]["altitude"] = json!(800.0); // above the 750 ft ceiling
    let p = refused(&app, &m).await;
    assert_eq!(pointers(&p), ["/waypoints/4/altitude"], "{p}");

    // 2018: points are sorted by `order`; the pointer names the document's index.
    let mut m = fixture("mission_2018.json");
    m["mission_waypoints"] = json!([
        {"altitude_msl": 150.0, "latitude": 38.143, "longitude": -76.429, "order": 2},
        {"altitude_msl": 150.0, "latitude": 38.20, "longitude": -76.429, "order": 1}
    ]);
    let p = refused(&app, &m).await;
    assert_eq!(pointers(&p), ["/mission_waypoints/1"], "{p}");
}

async fn forcing_a_format_parses_the_body_as_that_format(app: App) {
    // A 2019 document forced to native lacks native fields: 400 naming one.
    let r = app
        .post_json(
            "/api/v1/missions?format=native",
            &fixture("mission_2019.json"),
        )
        .await;
    // serde names the first native field it cannot find (`/waypoints/0` lacks `lat`).
    let p = problem_about(r, 400, "missing field").await;
    assert!(!pointers(&p).is_empty(), "{p}");
    // An unknown format name is a 400 too.
    problem(
        app.post_json("/api/v1/missions?format=kml", &fixture("mission_2019.json"))
            .await,
        400,
    )
    .await;
    // Forcing the right format works.
    let r = app
        .post_json(
            "/api/v1/missions?format=interop-2019",
            &fixture("mission_2019.json"),
        )
        .await;
    assert_eq!(r.status(), 201);
}
