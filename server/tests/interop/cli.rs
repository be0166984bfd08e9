//! `jink interop pull` and `jink interop status` against a jink standing in for the
//! judges' server.

use std::time::Duration;

use serde_json::Value;

use crate::support::{Jink, fixture};

fn link_args(upstream: &str) -> Vec<String> {
    [
        "--interop-url",
        upstream,
        "--interop-username",
        "team",
        "--interop-password",
        "pw",
        "--interop-mission",
        "1",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

fn run(local: &Jink, sub: &str, upstream: &str) -> std::process::Output {
    let mut args = vec!["interop".to_string(), sub.to_string()];
    args.extend(link_args(upstream));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    local.jink(&args)
}

#[tokio::test]
async fn pull_stores_the_mission_once_and_status_reports_what_the_link_sees() {
    let upstream = Jink::start(&[]);
    upstream
        .create_mission(&fixture("mission_2021_webster_field.json"))
        .await;
    let mut local = Jink::new(
        &link_args(&upstream.base)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );

    let out = run(&local, "pull", &upstream.base);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let id = String::from_utf8(out.stdout).unwrap().trim().to_string();
    assert_eq!(id.len(), 16, "{id}");
    // Unchanged upstream: the same mission, not a second one.
    let again = run(&local, "pull", &upstream.base);
    assert_eq!(String::from_utf8(again.stdout).unwrap().trim(), id);
    assert!(String::from_utf8_lossy(&again.stderr).contains("unchanged"));

    let out = run(&local, "status", &upstream.base);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let status: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(status["login"], "ok");
    assert_eq!(status["api"], "2019");
    assert_eq!(status["mission"]["waypoints"], 14);
    assert_eq!(status["mission"]["stationary_obstacles"], 6);
    assert_eq!(status["local"]["linked_mission"], id.as_str());
    assert_eq!(status["local"]["queue_depth"], 0);

    // `serve` with the same link continues with the pulled mission.
    local.run();
    let l = local
        .wait_link(Duration::from_secs(30), "the link connected", |l| {
            l["connected"] == true
        })
        .await;
    assert_eq!(l["mission_id"], id.as_str());
    assert_eq!(
        local
            .get_json("/api/v1/missions")
            .await
            .as_array()
            .unwrap()
            .len(),
        1
    );
}

#[tokio::test]
async fn status_fails_with_the_reason_when_the_server_cannot_be_reached() {
    let local = Jink::new(&[]);
    // A port nothing listens on: bind one, then free it.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let out = run(&local, "status", &format!("http://127.0.0.1:{port}"));
    assert_eq!(out.status.code(), Some(1));
    let status: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        status["login"].as_str().unwrap().contains("cannot reach"),
        "{status}"
    );
    // Without --interop-url: a usage error naming the flag.
    let out = local.jink(&["interop", "pull"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--interop-url"));
}
