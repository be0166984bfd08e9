//! An acknowledged write survives kill -9.

use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, ingest_counts};

both_stores!(acknowledged_writes_survive_kill_9);

async fn acknowledged_writes_survive_kill_9(mut app: App) {
    let id = app.create_webster_mission().await;
    let path = format!("/api/v1/missions/{id}/obstacles");
    // 50 acknowledged batches in quick succession, then SIGKILL with no pause.
    for i in 0..50 {
        let t = 1_700_000_000.0 + f64::from(i) * 0.1;
        let body = json!({"observations": [{"obstacle_id": "0", "t": t, "lat": 38.145, "lon": -76.43, "alt_msl_m": 80.0, "radius_m": 15.0}]});
        let r = app.post_json(&path, &body).await;
        assert_eq!(r.status(), 202);
    }
    let r = app.post_json(&format!("/api/v1/missions/{id}/telemetry"), &json!({"t": 5.0, "lat": 38.145, "lon": -76.43, "alt_msl_m": 90.0, "heading_deg": 45.0})).await;
    assert_eq!(r.status(), 202);
    app.kill9_and_restart();

    let m = app.get_json(&format!("/api/v1/missions/{id}")).await;
    assert_eq!(m["waypoints"].as_array().unwrap().len(), 14);
    let all: Value = app
        .get_json(&format!("/api/v1/missions/{id}/observations"))
        .await;
    assert_eq!(all.as_array().unwrap().len(), 50);
    assert_eq!(
        app.get_json(&format!("/api/v1/missions/{id}/telemetry"))
            .await
            .as_array()
            .unwrap()
            .len(),
        1
    );
    // And the restarted service keeps accepting.
    let r = app.post_json(&path, &json!({"observations": [{"obstacle_id": "0", "t": 1_700_000_100.0, "lat": 38.145, "lon": -76.43, "alt_msl_m": 80.0, "radius_m": 15.0}]})).await;
    assert_eq!(ingest_counts(r).await, (1, 0));
}
