//! The interop-compatible surface over HTTP: what the judges' clients send, what they read
//! back, compared with the judges' own documents (the fixtures) and jink's native API.

use serde_json::{Value, json};

use crate::support::{Jink, M_PER_FT, Session, close, f, fixture};

#[tokio::test]
async fn a_2019_client_reads_the_mission_in_feet_and_its_telemetry_lands_in_order() {
    let jink = Jink::start(&[]);
    let doc = fixture("mission_2021_webster_field.json");
    let id = jink.create_mission(&doc).await;
    let mut s = Session::new(&jink.base);
    assert_eq!(s.login_json("team", "anything").await, 200);
    assert!(s.cookie.as_deref().unwrap().starts_with("sessionid="));

    let r = s.get("/api/missions/1").await;
    assert_eq!(r.status(), 200);
    let m: Value = r.json().await.unwrap();
    assert_eq!(m["id"], 1);
    // Every number the judges sent comes back as they sent it (feet).
    let wps = doc["waypoints"].as_array().unwrap();
    assert_eq!(m["waypoints"].as_array().unwrap().len(), wps.len());
    for (i, w) in wps.iter().enumerate() {
        for k in ["latitude", "longitude", "altitude"] {
            assert!(
                close(
                    f(w, &format!("/{k}")),
                    f(&m, &format!("/waypoints/{i}/{k}"))
                ),
                "waypoint {i} {k}: {} vs {}",
                w[k],
                m["waypoints"][i][k]
            );
        }
    }
    for k in ["altitudeMin", "altitudeMax"] {
        assert!(close(
            f(&doc, &format!("/flyZones/0/{k}")),
            f(&m, &format!("/flyZones/0/{k}"))
        ));
    }
    for (i, o) in doc["stationaryObstacles"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        for k in ["latitude", "longitude", "radius", "height"] {
            assert!(close(
                f(o, &format!("/{k}")),
                f(&m, &format!("/stationaryObstacles/{i}/{k}"))
            ));
        }
    }
    assert_eq!(m["lostCommsPos"], doc["lostCommsPos"]);
    // ... and by its jink id too, and in the list.
    assert_eq!(
        s.get(&format!("/api/missions/{id}"))
            .await
            .json::<Value>()
            .await
            .unwrap(),
        m
    );
    let list: Value = s.get("/api/missions").await.json().await.unwrap();
    assert_eq!(list.as_array().unwrap(), &vec![m.clone()]);

    // Telemetry, 2019 JSON in feet, reads back from the native API in metres, in order.
    let sent: Vec<(f64, f64, f64, f64)> = (0..6)
        .map(|i| {
            let i = f64::from(i);
            (
                38.1445 + i * 1e-4,
                -76.4283 - i * 1e-4,
                150.0 + 10.0 * i,
                (i * 70.0) % 360.0,
            )
        })
        .collect();
    for (lat, lon, alt, hdg) in &sent {
        let r = s
            .post_json(
                "/api/telemetry",
                &json!({"latitude": lat, "longitude": lon, "altitude": alt, "heading": hdg}),
            )
            .await;
        assert_eq!(r.status(), 200, "{}", r.text().await.unwrap());
    }
    let got = jink
        .get_json(&format!("/api/v1/missions/{id}/telemetry"))
        .await;
    let got = got.as_array().unwrap();
    assert_eq!(got.len(), sent.len());
    for (g, (lat, lon, alt, hdg)) in got.iter().zip(&sent) {
        assert_eq!(f(g, "/lat"), *lat);
        assert_eq!(f(g, "/lon"), *lon);
        assert!(close(f(g, "/alt_msl_m"), alt * M_PER_FT), "{g}");
        assert!(close(f(g, "/heading_deg"), *hdg));
    }

    // The team status shows the newest sample in feet.
    let teams: Value = s.get("/api/teams").await.json().await.unwrap();
    assert_eq!(teams[0]["team"]["username"], "team");
    assert!(close(f(&teams, "/0/telemetry/altitude"), sent[5].2));
    assert_eq!(teams[0]["inAir"], true);
}

#[tokio::test]
async fn a_2018_client_logs_in_with_a_form_and_posts_form_telemetry() {
    let jink = Jink::start(&[]);
    let doc = fixture("mission_2018.json");
    let id = jink.create_mission(&doc).await;
    let mut s = Session::new(&jink.base);
    assert_eq!(s.login_form("team", "pw").await, 200);
    let m: Value = s.get("/api/missions/1").await.json().await.unwrap();
    // A 2017/2018 mission is served as 2017/2018 (feet, `order` fields).
    assert_eq!(m["id"], 1);
    assert!(close(
        f(&m, "/fly_zones/0/altitude_msl_max"),
        f(&doc, "/fly_zones/0/altitude_msl_max")
    ));
    assert!(close(
        f(&m, "/mission_waypoints/0/altitude_msl"),
        f(&doc, "/mission_waypoints/0/altitude_msl")
    ));
    let orders: Vec<i64> = m["fly_zones"][0]["boundary_pts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["order"].as_i64().unwrap())
        .collect();
    assert_eq!(orders, vec![1, 2, 3]);
    assert_eq!(m["home_pos"], doc["home_pos"]);
    // `?format=` asks for the other generation.
    let m19: Value = s
        .get("/api/missions/1?format=interop-2019")
        .await
        .json()
        .await
        .unwrap();
    assert!(close(
        f(&m19, "/waypoints/0/altitude"),
        f(&doc, "/mission_waypoints/0/altitude_msl")
    ));

    for i in 0..3 {
        let r = s
            .post_form(
                "/api/telemetry",
                &[
                    ("latitude", format!("{}", 38.145 + f64::from(i) * 1e-4)),
                    ("longitude", "-76.428".into()),
                    ("altitude_msl", format!("{}", 120 + i)),
                    ("uas_heading", "271.5".into()),
                ],
            )
            .await;
        assert_eq!(r.status(), 200, "{}", r.text().await.unwrap());
    }
    let got = jink
        .get_json(&format!("/api/v1/missions/{id}/telemetry"))
        .await;
    let alts: Vec<f64> = got
        .as_array()
        .unwrap()
        .iter()
        .map(|g| f(g, "/alt_msl_m"))
        .collect();
    assert_eq!(alts.len(), 3);
    for (i, a) in alts.iter().enumerate() {
        assert!(close(*a, (120.0 + i as f64) * M_PER_FT));
    }
}

#[tokio::test]
async fn obstacles_come_back_as_the_judges_snapshot_from_the_live_state() {
    let jink = Jink::start(&[]);
    let mut doc = fixture("mission_2018.json");
    doc["stationary_obstacles"] = json!([
        {"latitude": 38.1431, "longitude": -76.4301, "cylinder_radius": 150.0, "cylinder_height": 300.0}
    ]);
    // A fly zone that holds the snapshot's obstacles.
    doc["fly_zones"][0]["boundary_pts"] = json!([
        {"latitude": 38.135, "longitude": -76.44, "order": 1},
        {"latitude": 38.155, "longitude": -76.44, "order": 2},
        {"latitude": 38.155, "longitude": -76.415, "order": 3},
        {"latitude": 38.135, "longitude": -76.415, "order": 4}
    ]);
    let id = jink.create_mission(&doc).await;
    let snap = fixture("obstacles_2018.json");
    let r = jink
        .client
        .post(jink.url(&format!("/api/v1/missions/{id}/obstacles")))
        .json(&snap)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 202, "{}", r.text().await.unwrap());

    let got = jink.get_json("/api/obstacles").await;
    let want = snap["moving_obstacles"].as_array().unwrap();
    assert_eq!(
        got["moving_obstacles"].as_array().unwrap().len(),
        want.len()
    );
    for (i, w) in want.iter().enumerate() {
        let g = &got["moving_obstacles"][i];
        // Through the mission's ENU frame and back: equal to far below a millimetre.
        assert!(
            (f(g, "/latitude") - f(w, "/latitude")).abs() < 1e-9,
            "{g} {w}"
        );
        assert!(
            (f(g, "/longitude") - f(w, "/longitude")).abs() < 1e-9,
            "{g} {w}"
        );
        assert!(close(f(g, "/altitude_msl"), f(w, "/altitude_msl")));
        assert!(close(f(g, "/sphere_radius"), f(w, "/sphere_radius")));
    }
    assert!(close(
        f(&got, "/stationary_obstacles/0/cylinder_height"),
        300.0
    ));
    assert!(close(
        f(&got, "/stationary_obstacles/0/cylinder_radius"),
        150.0
    ));
}

async fn post(s: &Session) -> u16 {
    let body =
        json!({"latitude": 38.1445, "longitude": -76.4283, "altitude": 150.0, "heading": 0.0});
    s.post_json("/api/telemetry", &body).await.status().as_u16()
}

#[tokio::test]
async fn telemetry_goes_to_the_mission_the_session_read_else_the_newest() {
    let jink = Jink::start(&[]);
    let mut one = fixture("mission_2019.json");
    one["id"] = json!(1);
    let mut two = one.clone();
    two["id"] = json!(2);
    let id1 = jink.create_mission(&one).await;
    let id2 = jink.create_mission(&two).await;
    let mut reader = Session::new(&jink.base);
    reader.login_json("a", "b").await;
    assert_eq!(reader.get("/api/missions/1").await.status(), 200);
    assert_eq!(post(&reader).await, 200);
    let mut other = Session::new(&jink.base);
    other.login_json("c", "d").await;
    assert_eq!(post(&other).await, 200);
    let n = |id: &str| {
        let path = format!("/api/v1/missions/{id}/telemetry");
        let j = &jink;
        async move { j.get_json(&path).await.as_array().unwrap().len() }
    };
    assert_eq!((n(&id1).await, n(&id2).await), (1, 1));
    // A mission without an interop id of its own gets a number from 1000001 on.
    let mut native = one.clone();
    native.as_object_mut().unwrap().remove("id");
    let id3 = jink.create_mission(&native).await;
    let list: Value = reader.get("/api/missions").await.json().await.unwrap();
    assert_eq!(list[2]["id"], 1_000_001);
    let m: Value = reader
        .get("/api/missions/1000001")
        .await
        .json()
        .await
        .unwrap();
    assert_eq!(m, list[2]);
    assert_eq!(post(&reader).await, 200);
    assert_eq!(n(&id3).await, 1);
}

#[tokio::test]
async fn on_a_guarded_bind_the_username_names_a_token_and_the_password_is_the_token() {
    let mut jink = Jink::new(&["--auth", "on"]);
    let team = jink.create_token("team", "write");
    let viewer = jink.create_token("viewer", "read");
    jink.run();
    jink.create_mission_as(
        &fixture("mission_2019.json"),
        &jink.create_token("ops", "admin"),
    )
    .await;

    let anonymous = Session::new(&jink.base);
    assert_eq!(anonymous.get("/api/missions/1").await.status(), 401);
    let mut s = Session::new(&jink.base);
    assert_eq!(s.login_json("team", "not the token").await, 401);
    assert_eq!(s.login_json("viewer", &team).await, 401);
    assert_eq!(s.login_json("team", &team).await, 200);
    assert_eq!(s.get("/api/missions/1").await.status(), 200);
    let body =
        json!({"latitude": 38.1445, "longitude": -76.4283, "altitude": 150.0, "heading": 0.0});
    assert_eq!(s.post_json("/api/telemetry", &body).await.status(), 200);
    // The telemetry is recorded as written by the token.
    let id = s
        .get("/api/missions/1?format=native")
        .await
        .json::<Value>()
        .await
        .unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let rows: Value = s
        .get(&format!("/api/v1/missions/{id}/telemetry"))
        .await
        .json()
        .await
        .unwrap();
    assert_eq!(rows[0]["written_by"], "team");
    // A read token's session reads but cannot post.
    let mut v = Session::new(&jink.base);
    assert_eq!(v.login_form("viewer", &viewer).await, 200);
    assert_eq!(v.get("/api/missions/1").await.status(), 200);
    assert_eq!(v.post_json("/api/telemetry", &body).await.status(), 403);
}

#[tokio::test]
async fn bad_interop_input_is_a_4xx_naming_the_field() {
    let jink = Jink::start(&[]);
    let s = Session::new(&jink.base);
    let ok = json!({"latitude": 38.1445, "longitude": -76.4283, "altitude": 150.0, "heading": 0.0});
    // No mission yet: nowhere to store telemetry.
    assert_eq!(s.post_json("/api/telemetry", &ok).await.status(), 404);
    assert_eq!(s.get("/api/missions/1").await.status(), 404);
    jink.create_mission(&fixture("mission_2019.json")).await;

    let mut bad = ok.clone();
    bad["latitude"] = json!(95.0);
    let r = s.post_json("/api/telemetry", &bad).await;
    assert_eq!(r.status(), 422);
    assert_eq!(r.headers()["content-type"], "application/problem+json");
    let p: Value = r.json().await.unwrap();
    assert_eq!(p["errors"][0]["pointer"], "/latitude", "{p}");

    let mut missing = ok.clone();
    missing.as_object_mut().unwrap().remove("heading");
    let r = s.post_json("/api/telemetry", &missing).await;
    assert_eq!(r.status(), 400);
    assert!(r.text().await.unwrap().contains("heading"));

    let r = jink
        .client
        .post(jink.url("/api/telemetry"))
        .header("content-type", "text/plain")
        .body("latitude=1")
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 415);

    let r = jink
        .client
        .post(jink.url("/api/login"))
        .form(&[("username", "team")])
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 422);
    let p: Value = r.json().await.unwrap();
    assert_eq!(p["errors"][0]["pointer"], "/password", "{p}");
    let r = jink
        .client
        .post(jink.url("/api/login"))
        .header("content-type", "application/json")
        .body("{\"username\": ")
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 400);
    assert_eq!(s.get("/api/missions/999").await.status(), 404);
    assert_eq!(
        s.get("/api/missions/1?format=interop-2020").await.status(),
        400
    );
}
