//! The operator's pages (issue 13): the mission list at `/`, the live page
//! `/missions/{id}`, its server-sent events, its risk layer and its replay. (A real browser drives the
//! page in `tests/browser.rs`.)

use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::both_stores;
use crate::live::webster_flight;
use crate::plans::plan;
use crate::support::{App, problem};

both_stores!(
    the_events_carry_the_mission_then_the_live_state_a_plan_used,
    the_mission_list_names_interop_missions_and_links_their_live_page,
);

/// Reads the event stream at `path` until an event named `name` and returns its data.
async fn next_event(app: &App, path: &str, name: &str) -> Value {
    let mut r = app.get(path).await;
    assert_eq!(r.status(), 200);
    assert_eq!(
        r.headers()["content-type"].to_str().unwrap(),
        "text/event-stream"
    );
    let end = Instant::now() + Duration::from_secs(20);
    let mut text = String::new();
    while Instant::now() < end {
        let chunk = tokio::time::timeout(Duration::from_secs(10), r.chunk())
            .await
            .expect("an event within 10 s")
            .unwrap()
            .expect("the stream stays open");
        text.push_str(&String::from_utf8_lossy(&chunk));
        for block in text.split("\n\n") {
            let mut lines = block.lines();
            if lines.any(|l| l == format!("event: {name}")) {
                let data = block
                    .lines()
                    .find_map(|l| l.strip_prefix("data: "))
                    .expect("the event has data");
                return serde_json::from_str(data).unwrap();
            }
        }
    }
    panic!("no {name} event on {path}: {text}");
}

async fn the_events_carry_the_mission_then_the_live_state_a_plan_used(app: App) {
    let id = webster_flight(&app, 6).await;
    let p = plan(&app, &id, json!({"seed": 3, "current_index": 1})).await;

    let page = app.get(&format!("/missions/{id}")).await;
    assert_eq!(page.status(), 200);
    let html = page.text().await.unwrap();
    assert!(
        html.contains("<title>Interop mission 1 · jink</title>"),
        "{html:.300}"
    );
    assert!(!html.contains("{{"), "every placeholder is filled");
    let horizon = planner::DEFAULT_HORIZON_S;
    assert!(
        html.contains(&format!(
            r#"<input id="ahead" type="range" min="0" max="{horizon}""#
        )),
        "the look-ahead slider spans the live map's {horizon} s horizon"
    );
    let dt = planner::replan::SLICE_DT_S;
    assert!(
        html.contains(&format!(r#"max="{horizon}" step="{dt}""#)),
        "the look-ahead slider steps one map slice ({dt} s)"
    );
    // No asset from elsewhere (the only URL is the SVG namespace's name).
    for from_elsewhere in ["src=\"http", "href=\"http", "url(http", "@import", "//cdn"] {
        assert!(!html.contains(from_elsewhere), "{from_elsewhere}");
    }

    let m = next_event(&app, &format!("/missions/{id}/events"), "mission").await;
    assert_eq!(m["id"], id.as_str());
    assert_eq!(m["waypoints"].as_array().unwrap().len(), 14);
    assert_eq!(m["cylinders"].as_array().unwrap().len(), 6);

    let s = next_event(&app, &format!("/missions/{id}/events"), "state").await;
    let obstacles = s["obstacles"].as_array().unwrap();
    assert_eq!(obstacles.len(), 2, "{s}");
    // 6 s of 5 Hz observations: the 30 s track holds every one.
    for o in obstacles {
        assert_eq!(o["track"].as_array().unwrap().len(), 30, "{o}");
        assert_eq!(o["in_map"], true);
    }
    assert_eq!(s["plan"]["revision"], 1);
    assert_eq!(s["plan"]["plan_id"], p["plan_id"]);
    assert_eq!(
        s["plan"]["waypoints"].as_array().unwrap().len(),
        p["waypoints"].as_array().unwrap().len()
    );
    assert_eq!(s["history"][0]["revision"], 1);
    assert_eq!(s["aircraft"]["track"].as_array().unwrap().len(), 1);
    // The flight's clock is 2023: by the server's clock its data is stale.
    let codes: Vec<&str> = s["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["code"].as_str().unwrap())
        .collect();
    assert!(
        codes.contains(&"stale_telemetry") && codes.contains(&"stale_obstacles"),
        "{codes:?}"
    );
    // Both obstacles have flown for 6 s: the page says they are still being learned, once
    // (the plan's own copy of that warning is not repeated).
    assert!(codes.contains(&"tours_not_learned"), "{codes:?}");
    assert!(!codes.contains(&"plan_tours_not_learned"), "{codes:?}");

    // The risk layer: one pixel per cell, placed by its header, not empty near the
    // obstacles; a look-ahead beyond the horizon names the field.
    let r = app
        .get(&format!("/missions/{id}/risk-layer.png?t=10"))
        .await;
    assert_eq!(r.status(), 200);
    let numbers = |header: &str| -> Vec<f64> {
        r.headers()[header]
            .to_str()
            .unwrap()
            .split(' ')
            .map(|v| v.parse().unwrap())
            .collect()
    };
    let (grid, t) = (numbers("x-jink-risk-grid"), numbers("x-jink-risk-t"));
    assert_eq!(t[0], 10.0);
    let png = r.bytes().await.unwrap();
    let mut reader = png::Decoder::new(std::io::Cursor::new(png.to_vec()))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(
        (f64::from(info.width), f64::from(info.height)),
        (grid[3], grid[4])
    );
    let opaque = buf.chunks(4).filter(|px| px[3] == 255).count();
    assert!(opaque > 0, "the obstacles' spread is drawn");
    let bad = app
        .get(&format!("/missions/{id}/risk-layer.png?t=31"))
        .await;
    let doc = problem(bad, 422).await;
    assert_eq!(doc["errors"][0]["pointer"], "/t", "{doc}");

    // The replay: the recording on one timeline, and the judges' scoring of it. The
    // aircraft's one telemetry point is inside no obstacle and far from the waypoints.
    let r = app.get_json(&format!("/missions/{id}/replay")).await;
    assert_eq!(r["telemetry"].as_array().unwrap().len(), 1);
    let obstacles = r["obstacles"].as_array().unwrap();
    assert_eq!(obstacles.len(), 2);
    // 6 s of 5 Hz observations, sent at least 0.5 s apart: one in three (0.6 s apart).
    assert_eq!(
        obstacles[0]["samples"].as_array().unwrap().len(),
        10,
        "{}",
        obstacles[0]
    );
    assert_eq!(r["plans"][0]["plan_id"], p["plan_id"]);
    assert_eq!(r["scoring"]["sphere_score"], 1.0);
    assert_eq!(r["scoring"]["spheres_hit"], json!([]));
    assert_eq!(r["scoring"]["waypoints"], 14);
    assert!(r["scoring"]["min_clearance_m"].as_f64().unwrap() > 0.0);

    for path in [
        "/missions/nope",
        "/missions/nope/events",
        "/missions/nope/risk-layer.png",
        "/missions/nope/replay",
    ] {
        problem(app.get(path).await, 404).await;
    }
}

async fn the_mission_list_names_interop_missions_and_links_their_live_page(app: App) {
    let id = webster_flight(&app, 2).await;
    let html = app.get("/").await.text().await.unwrap();
    assert!(
        html.contains(&format!("<a href=\"/missions/{id}\">Interop mission 1</a>")),
        "{html}"
    );
    // Counts: 14 waypoints, 6 cylinders, no plan yet.
    assert!(html.contains("<td>14</td><td>6</td>"), "{html}");
    assert!(html.contains("no plan yet"));
    plan(&app, &id, json!({"seed": 1})).await;
    let html = app.get("/").await.text().await.unwrap();
    assert!(html.contains("plan 1</a>"), "{html}");
    assert!(html.contains(&format!("/api/v1/missions/{id}/plans/")));
}
