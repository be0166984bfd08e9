//! Arbitrary bodies at the interop paths (the real router in-process, with every layer)
//! never reach a panic or a 5xx, and every 4xx is problem+json.

use axum::body::Body;
use axum::http::{Request, header};
use proptest::prelude::*;
use server::{AppState, Settings, Store, router};
use tower::ServiceExt;

fn check(app: &axum::Router, rt: &tokio::runtime::Runtime, path: &str, media: &str, body: Vec<u8>) {
    let req = Request::post(path)
        .header(header::CONTENT_TYPE, media)
        .body(Body::from(body))
        .unwrap();
    let resp = rt.block_on(app.clone().oneshot(req)).unwrap();
    let status = resp.status().as_u16();
    assert!(status < 500, "{path} ({media}) answered {status}");
    if status >= 400 {
        assert_eq!(
            resp.headers()[header::CONTENT_TYPE],
            "application/problem+json"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn no_interop_body_reaches_a_5xx(
        body in proptest::collection::vec(any::<u8>(), 0..200),
        lat in proptest::num::f64::ANY,
        alt in proptest::num::f64::ANY,
        path in prop::sample::select(vec!["/api/login", "/api/telemetry"]),
        media in prop::sample::select(vec!["application/json", "application/x-www-form-urlencoded", "text/plain"]),
    ) {
        static APP: std::sync::OnceLock<(tokio::runtime::Runtime, axum::Router, tempfile::TempDir)> = std::sync::OnceLock::new();
        let (rt, app, _dir) = APP.get_or_init(|| {
            let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build().unwrap();
            let dir = tempfile::tempdir().unwrap();
            let url = format!("sqlite://{}", dir.path().join("t.sqlite").display());
            let app = rt.block_on(async {
                let store = Store::open(&url).await.unwrap();
                let app = router(AppState::new(store, Settings::default()));
                let mission = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/fixtures/interop/mission_2019.json")).unwrap();
                let req = Request::post("/api/v1/missions")
                    .header(header::CONTENT_TYPE, "application/json")
                    .body(Body::from(mission))
                    .unwrap();
                assert_eq!(app.clone().oneshot(req).await.unwrap().status(), 201);
                app
            });
            (rt, app, dir)
        });
        check(app, rt, path, media, body);
        // Well-formed documents with arbitrary numbers (NaN and infinities as text).
        let json = format!("{{\"latitude\": {lat:?}, \"longitude\": -76.0, \"altitude\": {alt:?}, \"heading\": 1}}");
        check(app, rt, "/api/telemetry", "application/json", json.into_bytes());
        let form = format!("latitude={lat}&longitude=-76&altitude_msl={alt}&uas_heading=1");
        check(app, rt, "/api/telemetry", "application/x-www-form-urlencoded", form.into_bytes());
    }
}
