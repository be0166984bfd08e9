//! `jink demo --flights`: flights in real time over HTTP (interop obstacle snapshots and
//! telemetry at 5 Hz, a plan a second flown while the aircraft flies on), each scored the
//! judges' way, beside the simulator's strategies flown in process on the same scenarios.

use std::process::{Command, Output};

fn demo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_jink"))
        .arg("demo")
        .args(["--port", "0", "--exit"])
        .args(args)
        .env("RUST_LOG", "warn")
        .output()
        .unwrap()
}

/// The table row whose first cell is `client`, as its cells.
fn row<'a>(stdout: &'a str, client: &str) -> Vec<&'a str> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(&format!("| {client} |")))
        .unwrap_or_else(|| panic!("no row for {client} in\n{stdout}"));
    line.trim_matches('|').split('|').map(str::trim).collect()
}

#[test]
fn judged_flights_in_real_time_print_each_score_and_a_table_beside_the_oracle() {
    let out = demo(&[
        "--flights",
        "2",
        "--seed",
        "3",
        "--duration",
        "8",
        "--obstacles",
        "10",
        "--compare",
        "oracle",
        "--aircraft-speed",
        "18",
        "--max-bank-deg",
        "43.3",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for seed in [3, 4] {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("jink demo: seed {seed}, mission ")))
            .unwrap_or_else(|| panic!("no line for seed {seed} in\n{stdout}"));
        assert!(
            line.contains(", 0 failed requests,") && line.contains("; judged: "),
            "{line}"
        );
        // 8 s is a small part of the mission: no path ratio for a flight cut short.
        assert!(line.contains("path ratio - (not finished)"), "{line}");
    }
    let http = row(&stdout, "jink over HTTP, real time");
    let oracle = row(&stdout, "`oracle` (in process, same scenarios)");
    for r in [&http, &oracle] {
        assert_eq!(r[1], "2", "two flights: {r:?}");
        // Both flew the 8 s asked for (the in-process runs are cut to the same length),
        // scored on the Webster Field mission's 14 waypoints each.
        let mean_s: f64 = r[7].parse().unwrap();
        assert!((7.5..=9.5).contains(&mean_s), "{r:?}");
        assert!(r[5].ends_with("/ 28"), "{r:?}");
        assert_eq!(r[6], "-", "flights cut short have no path ratio: {r:?}");
    }
}

#[test]
fn a_bad_demo_flag_is_refused_naming_it() {
    for (args, names) in [
        (&["--compare", "warp-drive"][..], "warp-drive"),
        (&["--compare", "server"][..], "server"),
        (&["--aircraft-speed", "1"][..], "--aircraft-speed"),
        (&["--max-bank-deg", "80"][..], "--max-bank-deg"),
    ] {
        let out = demo(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(stderr.contains(names), "{args:?}: {stderr}");
    }
}

/// The latest plan revision of mission `id`, read without planning: a base revision that
/// cannot exist is refused (422) with the latest in the problem's `latest_revision`.
async fn latest_revision(app: &crate::support::App, id: &str) -> i64 {
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/plan"),
            &serde_json::json!({"base_revision": 1_000_000_000, "current_index": 0}),
        )
        .await;
    assert_eq!(r.status(), 422);
    let p = r.json::<serde_json::Value>().await.unwrap();
    p["latest_revision"]
        .as_i64()
        .unwrap_or_else(|| panic!("no latest revision in {p}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_demo_whose_base_revision_went_stale_plans_on_from_the_mission() {
    // Another client plans once (as a plan answered after the demo gave up on it, or a
    // server restart between a plan and its answer, would leave things): the demo's next
    // plan names a base revision older than the latest and is refused with 409. It must
    // plan on from the mission's own waypoints and take up the new revisions; before, it
    // sent its stale revision for ever (the operator page's browser test, once in CI: no
    // plan within 20 s after a restart).
    let app = crate::support::App::spawn(crate::support::Db::Sqlite)
        .await
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (mut demo, mut out) = crate::support::spawn_jink(
        &[
            "demo",
            "--server",
            &app.base,
            "--seed",
            "3",
            "--duration",
            "60",
            "--obstacles",
            "4",
        ],
        dir.path(),
        "demo.log",
    );
    let id = out
        .find_map(|l| {
            l.strip_prefix("jink demo: the live page is ")
                .map(|u| u.rsplit('/').next().unwrap().to_string())
        })
        .expect("the demo prints the page's URL");
    let wait_past = |floor: i64, what: &'static str| {
        let (app, id) = (&app, id.clone());
        async move {
            let end = std::time::Instant::now() + std::time::Duration::from_secs(20);
            loop {
                let latest = latest_revision(app, &id).await;
                if latest > floor {
                    return latest;
                }
                assert!(
                    std::time::Instant::now() < end,
                    "{what}: the latest revision stayed {latest}"
                );
                tokio::time::sleep(std::time::Duration::from_millis(200)).await;
            }
        }
    };
    let before = wait_past(1, "the demo plans").await;
    // The other client: a plan with no base revision.
    let r = app
        .post_json(
            &format!("/api/v1/missions/{id}/plan"),
            &serde_json::json!({"current_index": 0, "deadline_ms": 200}),
        )
        .await;
    assert_eq!(r.status(), 201, "a plan is created");
    let ours = r.json::<serde_json::Value>().await.unwrap()["revision"]
        .as_i64()
        .unwrap();
    assert!(ours > before, "{ours} after {before}");
    // The demo's base is now stale; it plans on.
    let after = wait_past(ours + 1, "the demo plans on after its base went stale").await;
    assert!(after >= ours + 2, "{after}");
    let _ = demo.kill();
    let _ = demo.wait();
}
