//! Overload: the plan pool's 503 while ingest goes on, per-token rates (429), items per
//! request (413), the header read timeout, CORS and the pages' security headers.

use std::time::{Duration, Instant};

use serde_json::{Value, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

use crate::server::{Db, Server, observation};
use crate::support::problem;

#[tokio::test]
async fn a_full_plan_pool_answers_503_with_retry_after_while_ingest_succeeds() {
    let db = Db::sqlite();
    let s = Server::start(
        &db,
        &[
            "--bind",
            "127.0.0.1:0",
            "--plan-workers",
            "1",
            "--plan-queue",
            "0",
        ],
    );
    let id = s.webster(None).await;
    let obs = format!("/api/v1/missions/{id}/obstacles");
    let batch: Vec<Value> = (0..10)
        .map(|k| observation(&k.to_string(), 1_700_000_000.0))
        .collect();
    assert_eq!(
        s.post(&obs, &json!({"observations": batch}), None)
            .await
            .status(),
        202
    );
    // A flood of plans for 3 s (one pool slot: all but one at a time are refused), and
    // ingest at 20 Hz meanwhile.
    let until = Instant::now() + Duration::from_secs(3);
    let plan_url = s.url(&format!("/api/v1/missions/{id}/plan"));
    let flood: Vec<_> = (0..6)
        .map(|_| {
            let (client, url) = (s.client.clone(), plan_url.clone());
            tokio::spawn(async move {
                let (mut ok, mut refused) = (0, 0);
                while Instant::now() < until {
                    let r = client
                        .post(&url)
                        .json(&json!({"deadline_ms": 300}))
                        .send()
                        .await
                        .unwrap();
                    match r.status().as_u16() {
                        201 => ok += 1,
                        503 => {
                            let retry: u64 = r.headers()["retry-after"]
                                .to_str()
                                .unwrap()
                                .parse()
                                .unwrap();
                            assert!(retry >= 1);
                            let p = problem(r, 503).await;
                            assert_eq!(p["type"], "urn:jink:problem:plan-pool-full");
                            refused += 1;
                        }
                        // Two plans of one mission computed at once: the later one's
                        // revision was taken (documented; the client plans again).
                        409 => {
                            let p = problem(r, 409).await;
                            assert_eq!(p["type"], "urn:jink:problem:conflict");
                        }
                        other => panic!("plan answered {other}: {}", r.text().await.unwrap()),
                    }
                }
                (ok, refused)
            })
        })
        .collect();
    let mut ingest_ms = Vec::new();
    let mut n = 0u32;
    while Instant::now() < until {
        n += 1;
        let start = Instant::now();
        let body =
            json!({"observations": [observation("0", 1_700_000_001.0 + f64::from(n) * 0.05)]});
        let r = s.post(&obs, &body, None).await;
        assert_eq!(r.status(), 202);
        let tel = json!({"t": 1_700_000_001.0 + f64::from(n) * 0.05, "lat": 38.1447, "lon": -76.428, "alt_msl_m": 61.0, "heading_deg": 60.0, "speed_mps": 20.0});
        assert_eq!(
            s.post(&format!("/api/v1/missions/{id}/telemetry"), &tel, None)
                .await
                .status(),
            202
        );
        ingest_ms.push(start.elapsed().as_secs_f64() * 1e3);
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let (mut ok, mut refused) = (0, 0);
    for t in flood {
        let (o, r) = t.await.unwrap();
        ok += o;
        refused += r;
    }
    assert!(ok >= 1, "no plan was computed");
    assert!(refused >= 1, "the pool never filled ({ok} plans computed)");
    // Everything acknowledged is stored.
    let stored: Value = s
        .get_json(&format!("/api/v1/missions/{id}/observations"), None)
        .await;
    assert_eq!(stored.as_array().unwrap().len(), 10 + n as usize);
    ingest_ms.sort_by(f64::total_cmp);
    eprintln!(
        "plans computed {ok}, refused {refused}; ingest pairs {n}, median {:.1} ms, max {:.1} ms",
        ingest_ms[ingest_ms.len() / 2],
        ingest_ms[ingest_ms.len() - 1]
    );
}

#[tokio::test]
async fn a_token_over_its_write_rate_gets_429_with_retry_after() {
    let db = Db::sqlite();
    let admin = db.create_token("ops", "admin");
    let a = db.create_token("gcs-a", "write");
    let b = db.create_token("gcs-b", "write");
    let s = Server::start(
        &db,
        &[
            "--bind",
            "127.0.0.1:0",
            "--auth",
            "on",
            "--rate-ingest-per-s",
            "0.5",
            "--rate-ingest-burst",
            "3",
        ],
    );
    let id = s.webster(Some(&admin)).await;
    let obs = format!("/api/v1/missions/{id}/obstacles");
    let mut acknowledged = 0;
    for i in 0..3 {
        let body = json!({"observations": [observation("0", 1_700_000_000.0 + f64::from(i))]});
        assert_eq!(s.post(&obs, &body, Some(&a)).await.status(), 202);
        acknowledged += 1;
    }
    let body = json!({"observations": [observation("0", 1_700_000_010.0)]});
    let r = s.post(&obs, &body, Some(&a)).await;
    let retry: u64 = r.headers()["retry-after"]
        .to_str()
        .unwrap()
        .parse()
        .unwrap();
    assert!((1..=2).contains(&retry), "Retry-After {retry}");
    let p = problem(r, 429).await;
    assert!(p["detail"].as_str().unwrap().contains("gcs-a"), "{p}");
    // The refused batch is not stored; another token has its own budget; reads are free.
    let body = json!({"observations": [observation("0", 1_700_000_020.0)]});
    assert_eq!(s.post(&obs, &body, Some(&b)).await.status(), 202);
    acknowledged += 1;
    for _ in 0..5 {
        assert_eq!(s.get(&obs, Some(&a)).await.status(), 200);
    }
    let stored: Value = s
        .get_json(&format!("/api/v1/missions/{id}/observations"), Some(&a))
        .await;
    assert_eq!(stored.as_array().unwrap().len(), acknowledged);
}

#[tokio::test]
async fn too_many_items_in_one_request_are_named_in_413() {
    let db = Db::sqlite();
    let s = Server::start(
        &db,
        &[
            "--bind",
            "127.0.0.1:0",
            "--max-observations",
            "5",
            "--max-waypoints",
            "3",
        ],
    );
    let small = json!({"name": "small", "fly_zones": [{"boundary": [{"lat": 38.0, "lon": -76.0},
        {"lat": 38.01, "lon": -76.0}, {"lat": 38.01, "lon": -75.99}], "alt_min_msl_m": 30, "alt_max_msl_m": 200}],
        "waypoints": [{"lat": 38.002, "lon": -75.998, "alt_msl_m": 100}]});
    let r = s.post("/api/v1/missions", &small, None).await;
    assert_eq!(r.status(), 201);
    let id = r.json::<Value>().await.unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let obs: Vec<Value> = (0..6)
        .map(|k| observation("0", 1_700_000_000.0 + f64::from(k)))
        .collect();
    let r = s
        .post(
            &format!("/api/v1/missions/{id}/obstacles"),
            &json!({"observations": obs}),
            None,
        )
        .await;
    let p = problem(r, 413).await;
    assert_eq!(p["errors"][0]["pointer"], "/observations", "{p}");
    assert!(p["detail"].as_str().unwrap().contains("at most 5"), "{p}");
    // The Webster Field mission has 14 waypoints.
    let r = s
        .post(
            "/api/v1/missions",
            &crate::support::fixture("mission_2021_webster_field.json"),
            None,
        )
        .await;
    let p = problem(r, 413).await;
    assert_eq!(p["errors"][0]["pointer"], "/waypoints", "{p}");
}

#[tokio::test]
async fn a_client_that_never_finishes_its_headers_is_disconnected() {
    let db = Db::sqlite();
    let s = Server::start(
        &db,
        &["--bind", "127.0.0.1:0", "--header-read-timeout-s", "1"],
    );
    let addr = s.base.trim_start_matches("http://").to_string();
    let mut tcp = tokio::net::TcpStream::connect(&addr).await.unwrap();
    tcp.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        .await
        .unwrap();
    let start = Instant::now();
    let mut buf = Vec::new();
    // The server closes the connection (possibly after a 408); it must not wait for us.
    let read = tokio::time::timeout(Duration::from_secs(10), tcp.read_to_end(&mut buf)).await;
    assert!(read.is_ok(), "the connection was still open after 10 s");
    assert!(
        start.elapsed() < Duration::from_secs(5),
        "closed only after {:?}",
        start.elapsed()
    );
    // Other clients were served meanwhile and still are.
    assert_eq!(s.get("/healthz", None).await.status(), 200);
}

#[tokio::test]
async fn cors_is_off_by_default_and_answers_a_named_origin() {
    let db = Db::sqlite();
    let off = Server::start(&db, &["--bind", "127.0.0.1:0"]);
    let r = off
        .client
        .get(off.url("/api/v1/missions"))
        .header("origin", "https://gcs.example")
        .send()
        .await
        .unwrap();
    assert!(r.headers().get("access-control-allow-origin").is_none());
    // HTML pages carry the security headers.
    let r = off.get("/", None).await;
    assert_eq!(r.status(), 200);
    let csp = r.headers()["content-security-policy"].to_str().unwrap();
    assert!(csp.contains("frame-ancestors 'none'"), "{csp}");
    assert_eq!(r.headers()["x-frame-options"], "DENY");
    assert_eq!(r.headers()["x-content-type-options"], "nosniff");
    drop(off);

    let db = Db::sqlite();
    let on = Server::start(
        &db,
        &[
            "--bind",
            "127.0.0.1:0",
            "--cors-origin",
            "https://gcs.example",
        ],
    );
    let r = on
        .client
        .request(reqwest::Method::OPTIONS, on.url("/api/v1/missions"))
        .header("origin", "https://gcs.example")
        .header("access-control-request-method", "POST")
        .header(
            "access-control-request-headers",
            "authorization, content-type",
        )
        .send()
        .await
        .unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    assert_eq!(
        r.headers()["access-control-allow-origin"],
        "https://gcs.example"
    );
    let r = on
        .client
        .get(on.url("/api/v1/missions"))
        .header("origin", "https://other.example")
        .send()
        .await
        .unwrap();
    assert!(r.headers().get("access-control-allow-origin").is_none());
}
