//! Obstacle characterization and risk maps over HTTP: a straight track posted through the
//! API is promoted past Random, the risk map comes back as JSON and as a PNG, and the
//! characterization survives a restart (rebuilt from the stored telemetry).

use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, fixture};

both_stores!(a_straight_track_is_characterized_mapped_and_survives_a_restart);

const T0: f64 = 1_700_000_000.0;

/// Obstacle "7" flying east at 12 m/s from (38.147, -76.432), 10 Hz, observations i0..i1.
fn straight(i0: u32, i1: u32) -> Value {
    let lat0: f64 = 38.147;
    let m_per_deg_lon = 111_320.0 * lat0.to_radians().cos();
    let obs: Vec<Value> = (i0..i1)
        .map(|i| {
            let t = T0 + f64::from(i) * 0.1;
            let x = 12.0 * f64::from(i) * 0.1;
            json!({"obstacle_id": "7", "t": t, "lat": lat0, "lon": -76.432 + x / m_per_deg_lon, "alt_msl_m": 80.0, "radius_m": 15.0})
        })
        .collect();
    json!({ "observations": obs })
}

fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR");
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    (w, h)
}

async fn a_straight_track_is_characterized_mapped_and_survives_a_restart(mut app: App) {
    let id = app
        .create_mission(&fixture("mission_2021_webster_field.json"))
        .await;
    let path = format!("/api/v1/missions/{id}/obstacles");
    // 70 s of telemetry in 7 batches.
    for b in 0..7 {
        let r = app
            .post_json(&path, &straight(b * 100, (b + 1) * 100))
            .await;
        assert_eq!(r.status(), 202);
    }
    let obstacles = app.get_json(&path).await;
    let list = obstacles.as_array().unwrap();
    let moving = list
        .iter()
        .find(|o| o["id"] == "7")
        .expect("obstacle 7 listed");
    assert_eq!(moving["kind"], "moving");
    assert_eq!(moving["stage"], "advanced", "{moving}");
    assert_eq!(moving["observation_count"], 700);
    let est = &moving["estimates"];
    assert!(
        (est["speed_mps"].as_f64().unwrap() - 12.0).abs() < 0.1,
        "{est}"
    );
    assert!(
        (est["heading_deg"].as_f64().unwrap() - 90.0).abs() < 1.0,
        "{est}"
    );
    let history = moving["stage_history"].as_array().unwrap();
    assert_eq!(history[0]["to"], "random");
    assert_eq!(history[1]["from"], "random");
    assert_eq!(history[1]["to"], "advanced");
    assert_eq!(history[1]["test"], "chi_square_uniform");
    assert!(history[1]["p_value"].as_f64().unwrap() < 0.001);
    // The mission's cylinders are listed as stationary.
    assert!(
        list.iter()
            .any(|o| o["kind"] == "stationary" && o["cylinder"]["radius_m"].as_f64().is_some())
    );

    // New observations reach the cached predictor.
    let r = app.post_json(&path, &straight(700, 710)).await;
    assert_eq!(r.status(), 202);
    let after = app.get_json(&path).await;
    let moving = after
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["id"] == "7")
        .unwrap()
        .clone();
    assert_eq!(moving["observation_count"], 710);

    // Risk as JSON: certain at the obstacle now, spread ahead of it later.
    let risk = app
        .get_json(&format!("/api/v1/missions/{id}/risk?t=0"))
        .await;
    let (w, h) = (
        risk["width"].as_u64().unwrap(),
        risk["height"].as_u64().unwrap(),
    );
    assert_eq!(risk["values"].as_array().unwrap().len() as u64, w * h);
    assert_eq!(risk["cell_m"], 10.0);
    assert!(risk["max"].as_f64().unwrap() > 0.99, "max {}", risk["max"]);
    assert_eq!(risk["anchor_t"].as_f64().unwrap(), T0 + 70.9);
    let later = app
        .get_json(&format!("/api/v1/missions/{id}/risk?t=20"))
        .await;
    assert_eq!(later["t_ahead_s"], 20.0);
    assert!(later["max"].as_f64().unwrap() > 0.0);

    // Risk as PNG.
    let r = app
        .get(&format!("/api/v1/missions/{id}/risk?t=10&format=png"))
        .await;
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["content-type"], "image/png");
    let bytes = r.bytes().await.unwrap();
    let (pw, ph) = png_size(&bytes);
    assert!(pw >= w as u32 && ph >= h as u32 && pw <= 2000, "{pw}x{ph}");
    if let Ok(dir) = std::env::var("JINK_E2E_PNG_DIR") {
        std::fs::write(format!("{dir}/risk_t10.png"), &bytes).unwrap();
    }

    // Out-of-range t names the parameter.
    let r = app.get(&format!("/api/v1/missions/{id}/risk?t=61")).await;
    assert_eq!(r.status(), 422);

    // Restart: the characterization is rebuilt from the stored observations.
    app.kill9_and_restart();
    let again = app.get_json(&path).await;
    let restarted = again
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["id"] == "7")
        .unwrap()
        .clone();
    assert_eq!(restarted["stage"], moving["stage"]);
    assert_eq!(restarted["observation_count"], 710);
    assert_eq!(restarted["stage_history"], moving["stage_history"]);
    assert_eq!(restarted["estimates"], moving["estimates"]);
}
