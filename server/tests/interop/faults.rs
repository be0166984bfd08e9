//! A judges' server that misbehaves (malformed JSON, 500s, 503 with Retry-After, answers
//! slower than the link waits, a sample refused for good): jink never crashes, reports
//! each failure, keeps its mission, and still delivers every good sample once, in order.

use std::collections::{BTreeSet, HashMap};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

use crate::support::{Jink, Session, fixture};

/// A sample whose latitude is this is refused with 422 every time.
const REFUSED_LAT: f64 = 38.15;

#[derive(Default)]
struct Seen {
    mission_requests: usize,
    obstacle_requests: usize,
    telemetry_requests: usize,
    /// Latitudes of the samples the fake stored (acknowledged fast with 200).
    stored: Vec<f64>,
}

struct Reply {
    status: u16,
    body: String,
    delay: Duration,
    extra: &'static str,
}

fn reply(status: u16, body: impl Into<String>) -> Reply {
    Reply {
        status,
        body: body.into(),
        delay: Duration::ZERO,
        extra: "",
    }
}

/// What the fake answers to request `path` with `body`.
fn answer(seen: &mut Seen, path: &str, body: &str) -> Reply {
    match path {
        "/api/login" => Reply {
            extra: "Set-Cookie: sessionid=fake; Path=/\r\n",
            ..reply(200, "Login Successful.")
        },
        "/api/missions/1" => {
            seen.mission_requests += 1;
            let mut bad_values = fixture("mission_2018.json");
            bad_values["mission_waypoints"][0]["latitude"] = json!(95.0);
            match seen.mission_requests {
                1 => reply(200, fixture("mission_2018.json").to_string()),
                n => match n % 4 {
                    0 => reply(200, "{\"fly_zones\": [{"),
                    1 => reply(500, "<h1>Server Error</h1>"),
                    2 => reply(200, "[1, 2]"),
                    _ => reply(200, bad_values.to_string()),
                },
            }
        }
        "/api/obstacles" => {
            seen.obstacle_requests += 1;
            match seen.obstacle_requests % 5 {
                0 => reply(200, fixture("obstacles_2018.json").to_string()),
                1 => reply(200, "not json at all"),
                2 => reply(500, "boom"),
                3 => Reply {
                    delay: Duration::from_secs(3),
                    ..reply(200, fixture("obstacles_2018.json").to_string())
                },
                _ => reply(
                    200,
                    json!({"moving_obstacles": [{"latitude": "north"}]}).to_string(),
                ),
            }
        }
        "/api/telemetry" => {
            seen.telemetry_requests += 1;
            let form: HashMap<String, String> =
                serde_urlencoded::from_str(body).unwrap_or_default();
            let lat: f64 = form
                .get("latitude")
                .and_then(|v| v.parse().ok())
                .unwrap_or(f64::NAN);
            if lat == REFUSED_LAT {
                return reply(422, "Invalid telemetry");
            }
            match seen.telemetry_requests {
                1 => reply(500, "boom"),
                2 => Reply {
                    extra: "Retry-After: 1\r\n",
                    ..reply(503, "busy")
                },
                // Slower than the link waits: not stored (the judges' request died).
                3 => Reply {
                    delay: Duration::from_secs(3),
                    ..reply(500, "too late")
                },
                _ => {
                    seen.stored.push(lat);
                    reply(200, "UAS Telemetry Successfully Posted.")
                }
            }
        }
        _ => reply(404, "no such path"),
    }
}

/// Serves `answer` on a free port; its base URL.
async fn fake_upstream(seen: Arc<Mutex<Seen>>) -> String {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move {
        loop {
            let Ok((mut sock, _)) = listener.accept().await else {
                return;
            };
            let seen = seen.clone();
            tokio::spawn(async move {
                let mut buf = Vec::new();
                let mut chunk = [0u8; 4096];
                let (head_end, length) = loop {
                    let Ok(n) = sock.read(&mut chunk).await else {
                        return;
                    };
                    if n == 0 {
                        return;
                    }
                    buf.extend_from_slice(&chunk[..n]);
                    if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
                        let head = String::from_utf8_lossy(&buf[..i]).to_lowercase();
                        let length = head
                            .lines()
                            .find_map(|l| l.strip_prefix("content-length:"))
                            .and_then(|v| v.trim().parse::<usize>().ok())
                            .unwrap_or(0);
                        break (i + 4, length);
                    }
                };
                while buf.len() < head_end + length {
                    let Ok(n) = sock.read(&mut chunk).await else {
                        return;
                    };
                    if n == 0 {
                        return;
                    }
                    buf.extend_from_slice(&chunk[..n]);
                }
                let head = String::from_utf8_lossy(&buf[..head_end]).to_string();
                let path = head.split_whitespace().nth(1).unwrap_or("").to_string();
                let body = String::from_utf8_lossy(&buf[head_end..head_end + length]).to_string();
                let r = answer(&mut seen.lock().unwrap(), &path, &body);
                tokio::time::sleep(r.delay).await;
                let text = format!(
                    "HTTP/1.1 {} X\r\nContent-Type: application/json\r\nContent-Length: {}\r\n{}Connection: close\r\n\r\n{}",
                    r.status,
                    r.body.len(),
                    r.extra,
                    r.body
                );
                let _ = sock.write_all(text.as_bytes()).await;
                let _ = sock.shutdown().await;
            });
        }
    });
    base
}

#[tokio::test]
async fn a_misbehaving_upstream_never_crashes_jink_and_every_failure_is_reported() {
    let seen = Arc::new(Mutex::new(Seen::default()));
    let upstream = fake_upstream(seen.clone()).await;
    let mut a = Jink::start(&[
        "--interop-url",
        &upstream,
        "--interop-username",
        "team",
        "--interop-password",
        "pw",
        "--interop-mission",
        "1",
        "--interop-mission-poll-s",
        "0.3",
        "--interop-obstacle-hz",
        "4",
        "--interop-timeout-s",
        "1",
    ]);
    let first = a
        .wait_link(Duration::from_secs(30), "the mission pulled", |l| {
            l["mission_id"].is_string()
        })
        .await;
    assert_eq!(first["api"], "2018");
    let mission = first["mission_id"].as_str().unwrap().to_string();

    // Samples to forward: one the upstream refuses for good among good ones.
    let lats = [38.1445, 38.1446, REFUSED_LAT, 38.1447, 38.1448];
    let s = Session::new(&a.base);
    for lat in lats {
        let body =
            json!({"latitude": lat, "longitude": -76.4283, "altitude": 150.0, "heading": 90.0});
        assert_eq!(s.post_json("/api/telemetry", &body).await.status(), 200);
    }

    // Watch the reported errors while the link works through everything.
    let mut errors = BTreeSet::new();
    let start = Instant::now();
    loop {
        assert!(a.running(), "jink exited; log:\n{}", a.log());
        let h = a.get_json("/healthz").await;
        assert_eq!(h["status"], "ok");
        let l = &h["interop"];
        for e in l["recent_errors"].as_array().unwrap() {
            // Without its time stamp.
            let e = e.as_str().unwrap();
            errors.insert(e.split_once(' ').map_or(e, |(_, rest)| rest).to_string());
        }
        let saw = |needle: &str| errors.iter().any(|e| e.contains(needle));
        let drained = l["queue_depth"] == 0 && l["rejected"] == 1;
        if drained
            && saw("mission pull")
            && saw("obstacle poll")
            && saw("not JSON")
            && saw("answered 500")
            && saw("no answer within")
            && saw("refused, not sent again")
            && l["obstacle_polls"].as_u64() > Some(0)
        {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "not every failure was seen within 60 s; seen {errors:#?}\nstatus {l:#}\nlog:\n{}",
            a.log()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // The mission stayed what the one good answer said.
    let l = a.link().await;
    assert_eq!(l["mission_id"], mission.as_str());
    assert_eq!(l["mission_changes"], 0);
    assert!(l["errors"].as_u64().unwrap() >= 5, "{l}");
    // Every good sample reached the upstream once, in order; the refused one never again.
    let want: Vec<f64> = lats.iter().copied().filter(|&l| l != REFUSED_LAT).collect();
    assert_eq!(seen.lock().unwrap().stored, want);
    // Only well-formed snapshots became observations.
    let obs = a
        .get_json(&format!("/api/v1/missions/{mission}/observations"))
        .await;
    let obs = obs.as_array().unwrap();
    assert!(!obs.is_empty());
    assert_eq!(
        obs.len() % 2,
        0,
        "two obstacles per good snapshot: {}",
        obs.len()
    );
    let metrics = a.get_text("/metrics").await;
    assert!(
        metrics.contains("jink_interop_rejected_total 1"),
        "{metrics}"
    );
    assert!(
        !metrics.contains("jink_interop_errors_total 0\n"),
        "{metrics}"
    );
    assert!(a.running());
    let _: Value = a.get_json("/api/obstacles").await;
}
