//! The chain: jink A linked upstream to jink B's interop surface (B stands in for the
//! judges' server). The mission created in B appears in A; telemetry posted to A arrives
//! in B in order and exactly once, through B's absence for 10 s and A's own restart.

use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::support::{Jink, M_PER_FT, Session, assert_close_json, close, f, fixture};

/// The i-th sample posted to A: a distinct latitude names it.
fn sample(i: usize) -> Value {
    json!({
        "latitude": 38.1445 + i as f64 * 1e-5,
        "longitude": -76.4283,
        "altitude": 150.0 + i as f64,
        "heading": (i * 7 % 360) as f64,
    })
}

async fn post_all(a: &Jink, range: std::ops::Range<usize>, gap: Duration) {
    let s = Session::new(&a.base);
    for i in range {
        let r = s.post_json("/api/telemetry", &sample(i)).await;
        assert_eq!(r.status(), 200, "sample {i}: {}", r.text().await.unwrap());
        tokio::time::sleep(gap).await;
    }
}

#[tokio::test]
async fn a_linked_jink_mirrors_the_mission_and_forwards_telemetry_exactly_once_through_an_outage() {
    let mut b = Jink::start(&[]);
    let doc = fixture("mission_2021_webster_field.json");
    let b_mission = b.create_mission(&doc).await;

    let mut a = Jink::start(&[
        "--interop-url",
        &b.base,
        "--interop-username",
        "team",
        "--interop-password",
        "secret",
        "--interop-mission",
        "1",
        "--interop-mission-poll-s",
        "1",
        "--interop-telemetry-hz",
        "100",
    ]);
    // The mission appears in A, as B has it.
    let link = a
        .wait_link(Duration::from_secs(30), "the mission pulled", |l| {
            l["mission_id"].is_string() && l["connected"] == true
        })
        .await;
    assert_eq!(link["api"], "2019");
    let a_mission = link["mission_id"].as_str().unwrap().to_string();
    let in_a = a.get_json(&format!("/api/v1/missions/{a_mission}")).await;
    let in_b = b.get_json(&format!("/api/v1/missions/{b_mission}")).await;
    assert_eq!(in_a["interop_id"], 1);
    for key in [
        "home",
        "fly_zones",
        "waypoints",
        "search_grid",
        "stationary_obstacles",
    ] {
        assert_close_json(&in_b[key], &in_a[key], key);
    }
    // A's own interop surface serves it under the judges' id, in feet as B does.
    let from_a = a.get_json("/api/missions/1").await;
    let from_b = b.get_json("/api/missions/1").await;
    assert_close_json(&from_b, &from_a, "");

    // Telemetry before, during and after B's absence (and A restarted during it).
    post_all(&a, 0..30, Duration::from_millis(20)).await;
    // B goes away with nothing in flight (a sample B stored but could not acknowledge
    // would be sent again: the interop API cannot tell, see the link's docs).
    a.wait_link(
        Duration::from_secs(30),
        "the first samples forwarded",
        |l| l["queue_depth"] == 0 && l["forwarded"] == 30,
    )
    .await;
    b.kill();
    let down = Instant::now();
    post_all(&a, 30..45, Duration::from_millis(100)).await;
    let l = a
        .wait_link(Duration::from_secs(20), "the outage noticed", |l| {
            l["connected"] == false && l["errors"].as_u64() > Some(0)
        })
        .await;
    assert!(
        l["last_error"].as_str().unwrap().contains("cannot reach"),
        "{l}"
    );
    assert!(l["queue_depth"].as_u64().unwrap() > 0, "{l}");
    a.kill();
    a.start_again();
    post_all(&a, 45..60, Duration::from_millis(100)).await;
    let wait = Duration::from_secs(10).saturating_sub(down.elapsed());
    tokio::time::sleep(wait).await;
    b.start_again();
    post_all(&a, 60..90, Duration::from_millis(20)).await;

    let l = a
        .wait_link(Duration::from_secs(60), "the queue drained", |l| {
            l["queue_depth"] == 0 && l["connected"] == true
        })
        .await;
    assert_eq!(l["rejected"], 0, "{l}");
    // B holds every sample once, in the order A accepted them.
    let got = b
        .get_json(&format!("/api/v1/missions/{b_mission}/telemetry"))
        .await;
    let got = got.as_array().unwrap();
    let lats: Vec<f64> = got.iter().map(|g| f(g, "/lat")).collect();
    let want: Vec<f64> = (0..90).map(|i| f(&sample(i), "/latitude")).collect();
    assert_eq!(
        lats.len(),
        want.len(),
        "B has {} samples, A sent {}",
        lats.len(),
        want.len()
    );
    assert_eq!(lats, want);
    for (i, g) in got.iter().enumerate() {
        assert!(
            close(f(g, "/alt_msl_m"), (150.0 + i as f64) * M_PER_FT),
            "{g}"
        );
    }
    // Nothing more arrives later (no duplicate still under way).
    tokio::time::sleep(Duration::from_secs(1)).await;
    let again = b
        .get_json(&format!("/api/v1/missions/{b_mission}/telemetry"))
        .await;
    assert_eq!(again.as_array().unwrap().len(), 90);
    // A's telemetry is intact too, and written by the interop client (`local` here).
    let in_a = a
        .get_json(&format!("/api/v1/missions/{a_mission}/telemetry"))
        .await;
    assert_eq!(in_a.as_array().unwrap().len(), 90);
    let metrics = a.get_text("/metrics").await;
    assert!(metrics.contains("jink_interop_queue_depth 0"), "{metrics}");
    assert!(metrics.contains("jink_interop_connected 1"), "{metrics}");
}

#[tokio::test]
async fn a_changed_upstream_mission_becomes_a_new_jink_mission() {
    let b = Jink::start(&[]);
    let doc = fixture("mission_2019.json");
    b.create_mission(&doc).await;
    let a = Jink::start(&[
        "--interop-url",
        &b.base,
        "--interop-username",
        "u",
        "--interop-password",
        "p",
        "--interop-mission",
        "1",
        "--interop-mission-poll-s",
        "0.5",
    ]);
    let first = a
        .wait_link(Duration::from_secs(30), "the mission pulled", |l| {
            l["mission_id"].is_string()
        })
        .await["mission_id"]
        .clone();
    // Unchanged pulls keep the mission.
    tokio::time::sleep(Duration::from_millis(1500)).await;
    assert_eq!(a.link().await["mission_id"], first);
    assert_eq!(a.link().await["mission_changes"], 0);
    // The judges move a waypoint: B's newest mission 1 is the changed one.
    let mut moved = doc.clone();
    moved["waypoints"][0]["altitude"] = json!(321.0);
    b.create_mission(&moved).await;
    let l = a
        .wait_link(Duration::from_secs(30), "the change noticed", |l| {
            l["mission_id"] != first
        })
        .await;
    assert_eq!(l["mission_changes"], 1);
    let m = a
        .get_json(&format!(
            "/api/v1/missions/{}",
            l["mission_id"].as_str().unwrap()
        ))
        .await;
    assert!(close(f(&m, "/waypoints/0/alt_msl_m"), 321.0 * M_PER_FT));
    assert_eq!(
        a.get_json("/api/v1/missions")
            .await
            .as_array()
            .unwrap()
            .len(),
        2
    );
}
