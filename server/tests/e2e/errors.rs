//! Bad requests always get a 4xx problem+json, never a 500 or a plain-text rejection.

use serde_json::json;

use crate::both_stores;
use crate::support::{App, Db, fixture, fixture_text, problem, problem_about};

both_stores!(
    malformed_bodies_and_wrong_routes_get_problem_documents,
    unknown_missions_are_404_everywhere
);

async fn malformed_bodies_and_wrong_routes_get_problem_documents(app: App) {
    problem_about(
        app.post_raw("/api/v1/missions", "application/json", "{\"fly_zones\": [")
            .await,
        400,
        "not valid JSON",
    )
    .await;

    problem_about(
        app.post_raw(
            "/api/v1/missions",
            "text/plain",
            fixture_text("mission_2019.json"),
        )
        .await,
        415,
        "JSON",
    )
    .await;
    let r = app
        .client
        .post(app.url("/api/v1/missions"))
        .body("{}")
        .send()
        .await
        .unwrap();
    problem(r, 415).await;

    problem_about(
        app.post_raw("/api/v1/missions", "application/json", "[1, 2]")
            .await,
        400,
        "/0",
    )
    .await;

    problem(app.get("/api/v1/nothing-here").await, 404).await;
    let r = app
        .client
        .put(app.url("/api/v1/missions"))
        .json(&json!({}))
        .send()
        .await
        .unwrap();
    problem(r, 405).await;
    problem(
        app.get("/api/v1/missions/x/observations?after=yesterday")
            .await,
        400,
    )
    .await;

    // Issue 11: a `time=` of multi-byte characters used to panic the RFC 3339 parser (the
    // connection dropped with no answer); now a 400 naming the parameter, nothing stored.
    let id = app.create_mission(&fixture("mission_2018.json")).await;
    for bad in [
        "%ED%95%BC%F3%81%89%97",
        "2018-06-14T15:00:00%C3%A900:00",
        "9999-99-99",
    ] {
        problem_about(
            app.post_raw(
                &format!("/api/v1/missions/{id}/obstacles?time={bad}"),
                "application/json",
                fixture_text("obstacles_2018.json"),
            )
            .await,
            400,
            "time",
        )
        .await;
    }
    let stored = app
        .get_json(&format!("/api/v1/missions/{id}/observations"))
        .await;
    assert_eq!(stored, json!([]));
}

async fn unknown_missions_are_404_everywhere(app: App) {
    let obs = json!({"observations": [{"obstacle_id": "a", "t": 10.0, "lat": 38.0, "lon": -76.0, "alt_msl_m": 50.0, "radius_m": 10.0}]});
    for r in [
        app.get("/api/v1/missions/nope").await,
        app.post_json("/api/v1/missions/nope/obstacles", &obs).await,
        app.get("/api/v1/missions/nope/observations").await,
        app.post_json(
            "/api/v1/missions/nope/telemetry",
            &json!({"lat": 38.0, "lon": -76.0, "alt_msl_m": 50.0, "heading_deg": 10.0}),
        )
        .await,
        app.get("/api/v1/missions/nope/telemetry").await,
    ] {
        problem_about(r, 404, "'nope'").await;
    }
}

#[tokio::test]
async fn an_oversized_body_is_413_and_the_limit_is_a_flag() {
    let app = App::spawn_with(Db::Sqlite, &["--max-body-bytes", "4096"])
        .await
        .unwrap();
    problem_about(
        app.post_raw(
            "/api/v1/missions",
            "application/json",
            fixture_text("mission_2021_webster_field.json"),
        )
        .await,
        413,
        "max-body-bytes",
    )
    .await;
    // A small mission still fits.
    let r = app
        .post_raw(
            "/api/v1/missions",
            "application/json",
            fixture_text("mission_2019.json"),
        )
        .await;
    assert_eq!(r.status(), 201);
}
