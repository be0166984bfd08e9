//! Tokens and roles: 401 without a token on a non-loopback bind, 403 for a role too low
//! (and nothing stored), revocation on both replicas of a PostgreSQL pair, who wrote what.

use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::server::{Db, Server, observation};
use crate::support::problem;

#[tokio::test]
async fn serve_refuses_a_non_loopback_bind_while_no_token_exists() {
    let db = Db::sqlite();
    let log = match Server::try_start(&db, &["--bind", "0.0.0.0:0"]) {
        Ok(_) => panic!("jink started on 0.0.0.0 with no token defined"),
        Err(log) => log,
    };
    assert!(log.contains("jink token create"), "{log}");
    // Explicitly open: it starts.
    let s = Server::start(&db, &["--bind", "0.0.0.0:0", "--auth", "off"]);
    assert_eq!(s.get("/healthz", None).await.status(), 200);
}

#[tokio::test]
async fn no_token_gets_401_on_a_non_loopback_bind() {
    let db = Db::sqlite();
    let admin = db.create_token("ops", "admin");
    let s = Server::start(&db, &["--bind", "0.0.0.0:0"]);
    let r = s.get("/api/v1/missions", None).await;
    let challenge = r.headers()["www-authenticate"]
        .to_str()
        .unwrap()
        .to_string();
    assert!(challenge.starts_with("Bearer"), "{challenge}");
    let p = problem(r, 401).await;
    assert_eq!(p["type"], "urn:jink:problem:unauthorized");
    // A made-up token is no better.
    let r = s.get("/api/v1/missions", Some("jink_not_a_token")).await;
    problem(r, 401).await;
    // Health stays open for probes; the token opens the rest.
    assert_eq!(s.get("/healthz", None).await.status(), 200);
    assert_eq!(s.get("/api/v1/missions", Some(&admin)).await.status(), 200);
    // A browser's Basic prompt carries the token as the password.
    let r = s
        .client
        .get(s.url("/api/v1/missions"))
        .basic_auth("operator", Some(&admin))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
}

#[tokio::test]
async fn a_read_token_cannot_post_and_nothing_is_stored() {
    let db = Db::sqlite();
    let admin = db.create_token("ops", "admin");
    let read = db.create_token("viewer", "read");
    let write = db.create_token("gcs-1", "write");
    let s = Server::start(&db, &["--bind", "127.0.0.1:0", "--auth", "on"]);
    // Missions need admin.
    let r = s
        .post(
            "/api/v1/missions",
            &crate::support::fixture("mission_2021_webster_field.json"),
            Some(&write),
        )
        .await;
    assert_eq!(problem(r, 403).await["type"], "urn:jink:problem:forbidden");
    let id = s.webster(Some(&admin)).await;
    let obs = format!("/api/v1/missions/{id}/obstacles");
    let body = json!({"observations": [observation("0", 1_700_000_000.0)]});
    let p = problem(s.post(&obs, &body, Some(&read)).await, 403).await;
    assert!(p["detail"].as_str().unwrap().contains("viewer"), "{p}");
    let tel = json!({"t": 1_700_000_000.0, "lat": 38.1447, "lon": -76.428, "alt_msl_m": 61.0, "heading_deg": 60.0});
    problem(
        s.post(
            &format!("/api/v1/missions/{id}/telemetry"),
            &tel,
            Some(&read),
        )
        .await,
        403,
    )
    .await;
    problem(
        s.post(
            &format!("/api/v1/missions/{id}/plan"),
            &json!({}),
            Some(&read),
        )
        .await,
        403,
    )
    .await;
    let r = s
        .client
        .delete(s.url(&format!("/api/v1/missions/{id}")))
        .bearer_auth(&write)
        .send()
        .await
        .unwrap();
    problem(r, 403).await;
    // Nothing was stored by the refused requests.
    let listed: Value = s
        .get_json(&format!("/api/v1/missions/{id}/observations"), Some(&read))
        .await;
    assert_eq!(listed.as_array().unwrap().len(), 0, "{listed}");
    let listed: Value = s
        .get_json(&format!("/api/v1/missions/{id}/telemetry"), Some(&read))
        .await;
    assert_eq!(listed.as_array().unwrap().len(), 0, "{listed}");
    // The write token may post; what it stored names it.
    assert_eq!(s.post(&obs, &body, Some(&write)).await.status(), 202);
    assert_eq!(
        s.post(
            &format!("/api/v1/missions/{id}/telemetry"),
            &tel,
            Some(&write)
        )
        .await
        .status(),
        202
    );
    let listed: Value = s
        .get_json(&format!("/api/v1/missions/{id}/observations"), Some(&read))
        .await;
    assert_eq!(listed.as_array().unwrap().len(), 1, "{listed}");
    assert_eq!(listed[0]["written_by"], "gcs-1", "{listed}");
    let listed: Value = s
        .get_json(&format!("/api/v1/missions/{id}/telemetry"), Some(&read))
        .await;
    assert_eq!(listed[0]["written_by"], "gcs-1", "{listed}");
    let mission: Value = s
        .get_json(&format!("/api/v1/missions/{id}"), Some(&read))
        .await;
    assert_eq!(mission["written_by"], "ops", "{mission}");
    // A plan names its writer in the answer, when read back and when replayed.
    let r = s
        .post(
            &format!("/api/v1/missions/{id}/plan"),
            &json!({"seed": 1}),
            Some(&write),
        )
        .await;
    assert_eq!(r.status(), 201);
    let plan: Value = r.json().await.unwrap();
    assert_eq!(plan["written_by"], "gcs-1", "{plan}");
    let pid = plan["plan_id"].as_str().unwrap();
    let stored: Value = s
        .get_json(&format!("/api/v1/missions/{id}/plans/{pid}"), Some(&read))
        .await;
    assert_eq!(stored["written_by"], "gcs-1", "{stored}");
    let r = s
        .post(
            &format!("/api/v1/missions/{id}/plans/{pid}/replay"),
            &json!({}),
            Some(&write),
        )
        .await;
    assert_eq!(r.status(), 200);
    let replay: Value = r.json().await.unwrap();
    assert_eq!(replay["replayed"]["written_by"], "gcs-1", "{replay}");
    assert_eq!(replay["identical"], true, "{replay}");
}

#[tokio::test]
async fn without_a_token_on_loopback_the_writer_is_local() {
    let db = Db::sqlite();
    let s = Server::start(&db, &["--bind", "127.0.0.1:0"]);
    let id = s.webster(None).await;
    let body = json!({"observations": [observation("0", 1_700_000_000.0)]});
    assert_eq!(
        s.post(&format!("/api/v1/missions/{id}/obstacles"), &body, None)
            .await
            .status(),
        202
    );
    let listed: Value = s
        .get_json(&format!("/api/v1/missions/{id}/observations"), None)
        .await;
    assert_eq!(listed[0]["written_by"], "local", "{listed}");
    let mission: Value = s.get_json(&format!("/api/v1/missions/{id}"), None).await;
    assert_eq!(mission["written_by"], "local", "{mission}");
    let r = s
        .post(&format!("/api/v1/missions/{id}/plan"), &json!({}), None)
        .await;
    assert_eq!(r.status(), 201);
    let plan: Value = r.json().await.unwrap();
    assert_eq!(plan["written_by"], "local", "{plan}");
}

#[tokio::test]
async fn a_revoked_token_stops_working_on_both_replicas_of_a_postgres_pair() {
    let Some(db) = Db::postgres().await else {
        return;
    };
    let admin = db.create_token("ops", "admin");
    let gcs = db.create_token("gcs-1", "write");
    let args = [
        "--bind",
        "127.0.0.1:0",
        "--auth",
        "on",
        "--token-cache-s",
        "0.5",
    ];
    let a = Server::start(&db, &args);
    let b = Server::start(&db, &args);
    let id = a.webster(Some(&admin)).await;
    let obs = format!("/api/v1/missions/{id}/obstacles");
    for (i, s) in [&a, &b].into_iter().enumerate() {
        let body = json!({"observations": [observation("0", 1_700_000_000.0 + i as f64)]});
        assert_eq!(s.post(&obs, &body, Some(&gcs)).await.status(), 202);
    }
    let out = db.jink_token(&["revoke", "gcs-1"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let listed = String::from_utf8(db.jink_token(&["list"]).stdout).unwrap();
    assert!(
        listed
            .lines()
            .any(|l| l.starts_with("gcs-1") && !l.trim_end().ends_with('-')),
        "{listed}"
    );
    for s in [&a, &b] {
        let start = Instant::now();
        loop {
            let body = json!({"observations": [observation("0", 1_700_000_100.0)]});
            let r = s.post(&obs, &body, Some(&gcs)).await;
            if r.status() == 401 {
                problem(r, 401).await;
                break;
            }
            assert!(
                start.elapsed() < Duration::from_secs(5),
                "still {} after 5 s",
                r.status()
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        // The other tokens keep working.
        assert_eq!(s.get("/api/v1/missions", Some(&admin)).await.status(), 200);
    }
}
