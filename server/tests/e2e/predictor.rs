//! Obstacle characterization and risk maps over HTTP: a straight track posted through the
//! API is promoted past Random, the risk map comes back as JSON and as a PNG, and the
//! characterization survives a restart (rebuilt from the stored telemetry).

use serde_json::{Value, json};

use crate::both_stores;
use crate::support::{App, by_id};

both_stores!(a_straight_track_is_characterized_mapped_and_survives_a_restart);

const T0: f64 = 1_700_000_000.0;

/// Obstacle "7" flying east at 12 m/s from (38.147, -76.432), 10 Hz, observations i0..i1.
fn straight(i0: u32, i1: u32) -> Value {
    let frame = wire::geodesy::LocalFrame::new(38.147, -76.432);
    let obs: Vec<Value> = (i0..i1)
        .map(|i| {
            let t = T0 + f64::from(i) * 0.1;
            let (lat, lon) = frame.to_geodetic([12.0 * f64::from(i) * 0.1, 0.0]);
            json!({"obstacle_id": "7", "t": t, "lat": lat, "lon": lon, "alt_msl_m": 80.0, "radius_m": 15.0})
        })
        .collect();
    json!({ "observations": obs })
}

/// Width, height and RGBA pixels of a PNG.
fn decode_png(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn pixel(img: &(u32, u32, Vec<u8>), x: u32, y: u32) -> [u8; 3] {
    let i = ((y * img.0 + x) * 4) as usize;
    [img.2[i], img.2[i + 1], img.2[i + 2]]
}

/// Obstacle 7 as `GET path` lists it now.
async fn obstacle_7(app: &App, path: &str) -> Value {
    by_id(&app.get_json(path).await, "7")
}

async fn a_straight_track_is_characterized_mapped_and_survives_a_restart(mut app: App) {
    let id = app.create_webster_mission().await;
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
    let moving = &by_id(&obstacles, "7");
    assert_eq!(moving["kind"], "moving");
    assert_eq!(moving["stage"], "advanced", "{moving}");
    assert_eq!(moving["observation_count"], 700);
    // Watched from its first observation to its newest (0.0 to 69.9 s); a straight track
    // retraces nothing, so no lap.
    assert!(
        (moving["watched_s"].as_f64().unwrap() - 69.9).abs() < 1e-6,
        "{moving}"
    );
    assert_eq!(moving["lap"], Value::Null, "{moving}");
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
    let moving = obstacle_7(&app, &path).await;
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
    assert_eq!(risk["cell_m"], 5.0);
    assert!(risk["max"].as_f64().unwrap() > 0.99, "max {}", risk["max"]);
    assert_eq!(risk["anchor_t"].as_f64().unwrap(), T0 + 70.9);
    let later = app
        .get_json(&format!("/api/v1/missions/{id}/risk?t=20"))
        .await;
    assert_eq!(later["t_ahead_s"], 20.0);
    assert!(later["max"].as_f64().unwrap() > 0.0);

    // Risk as PNG: the same slice drawn, the obstacle at its fitted position, the legend.
    let slice = app
        .get_json(&format!("/api/v1/missions/{id}/risk?t=10"))
        .await;
    let r = app
        .get(&format!("/api/v1/missions/{id}/risk/png?t=10"))
        .await;
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["content-type"], "image/png");
    let bytes = r.bytes().await.unwrap();
    if let Ok(dir) = std::env::var("JINK_E2E_PNG_DIR") {
        std::fs::write(format!("{dir}/risk_t10.png"), &bytes).unwrap();
    }
    let img = decode_png(&bytes);
    // The map is width x height cells at an integer scale; a 72 px legend panel on the right.
    let (cells_w, cells_h) = (
        slice["width"].as_u64().unwrap() as u32,
        slice["height"].as_u64().unwrap() as u32,
    );
    let map_w = img.0 - 72;
    let scale = map_w / cells_w;
    assert_eq!(map_w, scale * cells_w, "{}x{}", img.0, img.1);
    assert!(img.1 >= cells_h * scale && scale >= 1);
    let frame = wire::geodesy::LocalFrame::new(
        slice["frame_origin"]["lat"].as_f64().unwrap(),
        slice["frame_origin"]["lon"].as_f64().unwrap(),
    );
    let pos = &obstacle_7(&app, &path).await["estimates"]["position"];
    let p = frame.to_enu(pos["lat"].as_f64().unwrap(), pos["lon"].as_f64().unwrap());
    let px_per_m = f64::from(scale) / slice["cell_m"].as_f64().unwrap();
    let gx = (p[0] - slice["grid_origin_enu_m"][0].as_f64().unwrap()) * px_per_m;
    let gy = f64::from(cells_h * scale)
        - (p[1] - slice["grid_origin_enu_m"][1].as_f64().unwrap()) * px_per_m;
    // The obstacle's centre disc is magenta.
    assert_eq!(pixel(&img, gx as u32, gy as u32), [200, 0, 200]);
    // The slice's most likely cell (10 s ahead of the obstacle) is drawn in heat colours:
    // red at least 170, blue at most 170, never the white of no risk or an overlay.
    let values = slice["values"].as_array().unwrap();
    let peak = (0..values.len())
        .max_by(|&a, &b| {
            values[a]
                .as_f64()
                .unwrap()
                .total_cmp(&values[b].as_f64().unwrap())
        })
        .unwrap() as u32;
    let (row, col) = (peak / cells_w, peak % cells_w);
    let y0 = (cells_h - 1 - row) * scale;
    let heat_pixels = (0..scale * scale)
        .map(|k| pixel(&img, col * scale + k % scale, y0 + k / scale))
        .filter(|c| c[0] >= 170 && c[2] <= 170 && *c != [250, 250, 250] && *c != [200, 0, 200])
        .count();
    assert!(heat_pixels > 0, "cell {row},{col} is not drawn as risk");
    // The legend's colour bar (y 54 to 254, under the time labels): dark red
    // (probability 1) at the top, pale yellow near 0.
    let top = pixel(&img, map_w + 16, 56);
    assert!(
        (160..=180).contains(&top[0]) && top[1] < 20 && top[2] < 20,
        "{top:?}"
    );
    let bottom = pixel(&img, map_w + 16, 250);
    assert!(bottom[0] == 255 && bottom[1] > 200, "{bottom:?}");
    // The older `?format=png` answers 303 to the PNG (reqwest follows it).
    let old = app
        .get(&format!("/api/v1/missions/{id}/risk?t=10&format=png"))
        .await;
    assert_eq!(old.url().path(), format!("/api/v1/missions/{id}/risk/png"));
    assert_eq!(old.bytes().await.unwrap(), bytes);

    // Out-of-range t names the parameter.
    for path in ["risk", "risk/png"] {
        let r = app.get(&format!("/api/v1/missions/{id}/{path}?t=31")).await;
        assert_eq!(
            crate::support::pointers(&crate::support::problem(r, 422).await),
            ["/t"]
        );
    }

    // Restart: the characterization is rebuilt from the stored observations.
    app.kill9_and_restart();
    let restarted = obstacle_7(&app, &path).await;
    assert_eq!(restarted["stage"], moving["stage"]);
    assert_eq!(restarted["observation_count"], 710);
    assert_eq!(restarted["watched_s"], moving["watched_s"]);
    assert_eq!(restarted["stage_history"], moving["stage_history"]);
    assert_eq!(restarted["estimates"], moving["estimates"]);
}
