//! The reactive avoiders over HTTP (`/api/v1/reactive/*`) and the `jink reactive --scans`
//! replay CLI. The routes are stateless, so SQLite alone is enough.

use serde_json::{Value, json};

use crate::support::{App, Db, pointers, problem, problem_about};

/// 11 beams at -50..50 degrees (10 apart); `blocked` lists (index, distance).
fn eleven(blocked: &[(usize, f64)]) -> Value {
    let beams: Vec<Value> = (0..11)
        .map(|i| {
            let d = blocked.iter().find(|(j, _)| *j == i).map(|(_, d)| *d);
            json!({"angle_deg": -50.0 + 10.0 * i as f64, "distance_m": d})
        })
        .collect();
    Value::Array(beams)
}

#[tokio::test]
async fn the_offset_route_decides_like_the_hand_computed_cases() {
    let app = App::spawn(Db::Sqlite).await.unwrap();
    // beam 4 (-10 deg) 0.5 m away, radii [1, 2, 4]: the right window (beams 2..5) scores
    // 25 in every frame, the left window (0..30 deg) is clear -> left at cycle 0, window
    // centre 15 deg, deviation 4 sin 15 deg = 1.0353 m
    let v = app
        .post_ok(
            "/api/v1/reactive/offset",
            &json!({"scan": eleven(&[(4, 0.5)]), "scan_radii_m": [4, 1, 2]}),
        )
        .await;
    assert_eq!(v["direction"], "left", "{v}");
    assert_eq!(v["cycle"], 0);
    assert_eq!(v["aggregate_left"], 0.0);
    assert!(
        (v["aggregate_right"].as_f64().unwrap() - 25.0).abs() < 1e-9,
        "{v}"
    );
    assert!(
        (v["deviation_m"].as_f64().unwrap() - 1.035276).abs() < 1e-6,
        "{v}"
    );
    assert_eq!(v["window"]["centre_deg"], 15.0);

    // all clear (null = no return): first-cycle tie -> left, no deviation
    let v = app
        .post_ok(
            "/api/v1/reactive/offset",
            &json!({"scan": eleven(&[]), "scan_radii_m": [1.0]}),
        )
        .await;
    assert_eq!(v["direction"], "left");
    assert_eq!(v["way_ahead_clear"], true);
    assert_eq!(v["deviation_m"], 0.0);

    // everything 0.5 m away: no path -> direction null, 3 cycles evaluated
    let all: Vec<(usize, f64)> = (0..11).map(|i| (i, 0.5)).collect();
    let v = app.post_ok("/api/v1/reactive/offset", &json!({"scan": eleven(&all), "scan_radii_m": [1.0, 2.0], "window": 4, "threshold": 5.0, "fov_deg": 120})).await;
    assert!(v["direction"].is_null(), "{v}");
    assert_eq!(v["cycles_evaluated"], 3);
    assert!(v["window"].is_null());
}

#[tokio::test]
async fn invalid_reactive_requests_are_422_naming_the_field() {
    let app = App::spawn(Db::Sqlite).await.unwrap();
    let post = |body: Value| {
        let app = &app;
        async move { app.post_json("/api/v1/reactive/offset", &body).await }
    };
    let p = problem(post(json!({"scan": [], "scan_radii_m": [1.0]})).await, 422).await;
    assert_eq!(pointers(&p), vec!["/scan"]);
    let p = problem(
        post(json!({"scan": eleven(&[]), "scan_radii_m": [1.0, -2.0]})).await,
        422,
    )
    .await;
    assert_eq!(pointers(&p), vec!["/scan_radii_m/1"]);
    let p = problem(
        post(json!({"scan": eleven(&[]), "scan_radii_m": [1.0], "window": 0})).await,
        422,
    )
    .await;
    assert_eq!(pointers(&p), vec!["/window"]);
    let p = problem_about(
        post(json!({"scan": eleven(&[]), "scan_radii_m": [1.0], "window": 9})).await,
        422,
        "beams",
    )
    .await;
    assert_eq!(pointers(&p), vec!["/scan"]);
    // a string where a number belongs: 400 naming the field
    let p = problem(
        post(json!({"scan": [{"angle_deg": "left", "distance_m": 1.0}], "scan_radii_m": [1.0]}))
            .await,
        400,
    )
    .await;
    assert_eq!(pointers(&p), vec!["/scan/0/angle_deg"]);

    let p = problem(
        app.post_json(
            "/api/v1/reactive/pilot",
            &json!({"deviation_m": 1.0, "scan_range_m": 5.0, "goal_distance_m": 0.0}),
        )
        .await,
        422,
    )
    .await;
    assert_eq!(pointers(&p), vec!["/goal_distance_m"]);
    let p = problem(
        app.post_json("/api/v1/reactive/sectors", &json!({"ranges_m": []}))
            .await,
        422,
    )
    .await;
    assert_eq!(pointers(&p), vec!["/ranges_m"]);
    let p = problem(
        app.post_json(
            "/api/v1/reactive/sectors",
            &json!({"ranges_m": [1.0], "obj_threshold_m": -1}),
        )
        .await,
        422,
    )
    .await;
    assert_eq!(pointers(&p), vec!["/obj_threshold_m"]);
}

#[tokio::test]
async fn the_pilot_route_returns_the_bezier_path() {
    let app = App::spawn(Db::Sqlite).await.unwrap();
    // d = 3, l = 5, goal 50: g = 30, P2 = (0, 50); 4 samples per segment -> 9 points
    let v = app.post_ok("/api/v1/reactive/pilot", &json!({"deviation_m": 3.0, "scan_range_m": 5.0, "goal_distance_m": 50.0, "samples_per_segment": 4})).await;
    let pts = v["points"].as_array().unwrap();
    assert_eq!(pts.len(), 9);
    assert_eq!(pts[0], json!({"x_m": 0.0, "y_m": 0.0}));
    assert_eq!(pts[4], json!({"x_m": 3.0, "y_m": 30.0}));
    assert!((pts[8]["y_m"].as_f64().unwrap() - 50.0).abs() < 1e-9);
    assert!(pts[8]["x_m"].as_f64().unwrap().abs() < 1e-9);
    assert_eq!(v["control_points"]["p1"], json!({"x_m": 3.0, "y_m": 5.0}));
    assert_eq!(v["cost"], 9.0);
    assert!(v["limited_by"].is_null());

    // the funnel limits a large deviation near the goal: |d| <= 0.5 * 10
    let v = app
        .post_ok(
            "/api/v1/reactive/pilot",
            &json!({"deviation_m": -20.0, "scan_range_m": 5.0, "goal_distance_m": 10.0}),
        )
        .await;
    assert_eq!(v["deviation_m"], -5.0);
    assert_eq!(v["limited_by"], "goal_funnel");
}

#[tokio::test]
async fn the_sectors_route_turns_away_from_a_blocked_front() {
    let app = App::spawn(Db::Sqlite).await.unwrap();
    // 8 beams, 45 degrees apart from straight ahead: the front beam at 0.4 m, the rest none
    let v = app
        .post_ok(
            "/api/v1/reactive/sectors",
            &json!({"ranges_m": [0.4, null, null, null, null, null, null, null]}),
        )
        .await;
    assert_eq!(v["obstacle_detected"], true, "{v}");
    assert_eq!(v["region"], 1);
    assert_eq!(v["angular_velocity"], 0.7);
    assert_eq!(v["linear_velocity"], -0.1);
    assert_eq!(v["regions"][0]["nearest_m"], 0.4);
    assert_eq!(v["regions"][0]["free"], false);

    // all blocked, the right (index 6 = 270 deg) farthest -> region 6, turn clockwise
    let v = app
        .post_ok(
            "/api/v1/reactive/sectors",
            &json!({"ranges_m": [0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.9, 0.3]}),
        )
        .await;
    assert_eq!(v["region"], 6);
    assert_eq!(v["angular_velocity"], -0.7);

    // clear: cruise
    let v = app
        .post_ok(
            "/api/v1/reactive/sectors",
            &json!({"ranges_m": [5.0, 5.0, 5.0, 5.0]}),
        )
        .await;
    assert_eq!(v["obstacle_detected"], false);
    assert_eq!(v["linear_velocity"], 0.5);
}

fn example_scans() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../planner/tests/data/reactive_scans.jsonl")
}

#[test]
fn the_reactive_cli_replays_the_example_scan_file() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
        .args(["reactive", "--scans"])
        .arg(example_scans())
        .output()
        .unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 11, "{stdout}");
    // the file's documented decisions
    let dirs: Vec<&str> = lines[..10]
        .iter()
        .map(|l| l.split_whitespace().nth(3).unwrap())
        .collect();
    assert_eq!(
        dirs,
        [
            "left", "left", "left", "left", "left", "right", "right", "none", "left", "left"
        ],
        "{stdout}"
    );
    assert!(
        lines[0].starts_with("cycle 0 t=0.000s left clear=yes"),
        "{stdout}"
    );
    assert!(
        lines[10].starts_with(
            "summary: 10 cycles over 0.450 s: 7 left (5 clear ahead), 2 right, 1 no path"
        ),
        "{stdout}"
    );

    // JSON output: one object per cycle plus the summary
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
        .args(["reactive", "--json", "--scans"])
        .arg(example_scans())
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let docs: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(docs.len(), 11);
    assert_eq!(docs[5]["decision"]["direction"], "right");
    assert_eq!(docs[10]["summary"]["no_path"], 1);

    // a bad file names the line
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.jsonl");
    let good: Vec<Value> = (-3..=3)
        .map(|i| json!({"angle_deg": 2 * i, "distance_m": null}))
        .collect();
    std::fs::write(&bad, format!("{}\nnope\n", json!({"t_s": 0, "scan": good}))).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
        .args(["reactive", "--scans"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 2"), "{err}");
}
