//! No input reaches a panic or a 5xx: arbitrary bytes, mutated documents and arbitrary
//! query strings go through the real router (`server::router`, with every layer) with
//! tower's `oneshot`, against a fresh SQLite store holding one mission.
//!
//! Parsers covered: mission upload in the three formats (native, interop 2018, interop
//! 2019+) and auto-detected, obstacle observations (with the `time=` parameter), aircraft
//! telemetry, and the query parameters of every GET that takes one. Every answer must be
//! below 500, and every 4xx must be `application/problem+json`.

use std::path::PathBuf;
use std::sync::OnceLock;

use axum::Router;
use axum::body::Body;
use axum::http::{Method, Request, header};
use proptest::prelude::*;
use serde_json::{Value, json};
use server::{AppState, Settings, Store, router};
use tower::ServiceExt;

/// One router over one store, shared by every case (building a store per case would make
/// the test slow without testing more).
struct Fixture {
    rt: tokio::runtime::Runtime,
    app: Router,
    mission_id: String,
    _dir: tempfile::TempDir,
}

fn fixture_json(name: &str) -> Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/interop")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let url = format!("sqlite://{}", dir.path().join("fuzz.sqlite").display());
        let app = rt.block_on(async {
            let store = Store::open(&url).await.unwrap();
            router(AppState::new(store, Settings::default()))
        });
        let (status, body) = rt.block_on(send(
            &app,
            Method::POST,
            "/api/v1/missions",
            Some("application/json"),
            serde_json::to_vec(&fixture_json("mission_2021_webster_field.json")).unwrap(),
        ));
        assert_eq!(status, 201, "{}", String::from_utf8_lossy(&body));
        let mission: Value = serde_json::from_slice(&body).unwrap();
        let mission_id = mission["id"].as_str().unwrap().to_string();
        Fixture {
            rt,
            app,
            mission_id,
            _dir: dir,
        }
    })
}

async fn send(
    app: &Router,
    method: Method,
    uri: &str,
    content_type: Option<&str>,
    body: Vec<u8>,
) -> (u16, Vec<u8>) {
    let mut req = Request::builder().method(method).uri(uri);
    if let Some(ct) = content_type {
        req = req.header(header::CONTENT_TYPE, ct);
    }
    let resp = app
        .clone()
        .oneshot(req.body(Body::from(body)).unwrap())
        .await
        .unwrap();
    let status = resp.status().as_u16();
    let ct = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    let bytes = axum::body::to_bytes(resp.into_body(), usize::MAX)
        .await
        .unwrap()
        .to_vec();
    if (400..600).contains(&status) {
        assert_eq!(
            ct,
            "application/problem+json",
            "{uri} answered {status} without a problem document: {}",
            String::from_utf8_lossy(&bytes)
        );
    }
    (status, bytes)
}

/// Sends one request and fails the property on any 5xx (a caught panic is a 500).
fn check(method: Method, uri: &str, body: Vec<u8>) -> Result<u16, TestCaseError> {
    let f = fixture();
    // A request that never ends is as bad as a panic (a gap of years in an obstacle's
    // track once walked hundreds of millions of 1 s intervals): fail it after a bound far
    // above any legitimate answer.
    let answer = f.rt.block_on(async {
        tokio::time::timeout(
            std::time::Duration::from_secs(60),
            send(&f.app, method.clone(), uri, Some("application/json"), body),
        )
        .await
    });
    prop_assert!(answer.is_ok(), "{method} {uri} did not answer within 60 s");
    let (status, bytes) = answer.unwrap_or_default();
    prop_assert!(
        status < 500,
        "{method} {uri} answered {status}: {}",
        String::from_utf8_lossy(&bytes)
    );
    Ok(status)
}

/// Any byte string, percent-encoded so that it survives as a URI (decoded bytes may be
/// any, including invalid UTF-8 and cut multi-byte characters).
fn encoded_bytes() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::collection::vec(any::<u8>(), 0..24),
        // Plausible values: numbers, times, format names, with noise.
        prop::sample::select(vec![
            "0",
            "-1",
            "1e309",
            "NaN",
            "inf",
            "4294967296",
            "18446744073709551616",
            "1.5",
            "2021-06-01T12:00:00Z",
            "2021-06-01T12:00:00.123+02:00",
            "2021-13-45T99:99:99Z",
            "1622548800",
            "json",
            "png",
            "qgc-wpl",
            "qgc-plan",
            "native",
            "interop-2018",
            "interop-2019",
            "",
        ])
        .prop_map(|s| s.as_bytes().to_vec()),
    ]
    .prop_map(|bytes| bytes.iter().map(|b| format!("%{b:02X}")).collect())
}

/// A query string of known and unknown names with arbitrary values.
fn query() -> impl Strategy<Value = String> {
    let name = prop_oneof![
        prop::sample::select(vec![
            "after",
            "last",
            "time",
            "t",
            "format",
            "obstacle_id",
            "id"
        ])
        .prop_map(str::to_string),
        encoded_bytes(),
    ];
    prop::collection::vec((name, encoded_bytes()), 0..4).prop_map(|pairs| {
        pairs
            .into_iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join("&")
    })
}

/// Arbitrary JSON, nested a little.
fn json_value() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::from),
        any::<i64>().prop_map(Value::from),
        any::<f64>().prop_map(|x| json!(x)),
        prop::sample::select(vec![-1e300, -181.0, -91.0, -0.0, 0.0, 90.0, 180.0, 1e300])
            .prop_map(|x| json!(x)),
        ".{0,12}".prop_map(Value::from),
        Just(Value::from("2021-06-01T12:00:00Z")),
    ];
    leaf.prop_recursive(3, 24, 4, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..4).prop_map(Value::from),
            prop::collection::btree_map(
                prop::sample::select(vec![
                    "lat",
                    "lon",
                    "latitude",
                    "longitude",
                    "t",
                    "id",
                    "alt_msl_m",
                    "radius_m",
                    "boundary",
                    "waypoints",
                    "fly_zones",
                    "heading",
                    "x",
                ])
                .prop_map(str::to_string),
                inner,
                0..4
            )
            .prop_map(|m| Value::Object(m.into_iter().collect())),
        ]
    })
}

/// `doc` with the value at one pseudo-randomly chosen place (walking `path` choices down
/// from the root) replaced by `new`.
fn mutate(mut doc: Value, path: &[usize], new: Value) -> Value {
    let mut cur = &mut doc;
    for &choice in path {
        let n = match &*cur {
            Value::Object(m) => m.len(),
            Value::Array(a) => a.len(),
            _ => 0,
        };
        if n == 0 {
            break;
        }
        cur = match cur {
            Value::Object(m) => m.values_mut().nth(choice % n).unwrap(),
            Value::Array(a) => &mut a[choice % n],
            _ => unreachable!("only containers have children"),
        };
    }
    *cur = new;
    doc
}

/// A request body: raw bytes, arbitrary JSON, or one of `bases` with one place mutated.
fn body(bases: Vec<Value>) -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        prop::collection::vec(any::<u8>(), 0..64),
        json_value().prop_map(|v| serde_json::to_vec(&v).unwrap()),
        (
            prop::sample::select(bases),
            prop::collection::vec(any::<usize>(), 0..5),
            json_value()
        )
            .prop_map(|(base, path, new)| serde_json::to_vec(&mutate(base, &path, new)).unwrap()),
    ]
}

fn mission_bases() -> Vec<Value> {
    vec![
        fixture_json("mission_2018.json"),
        fixture_json("mission_2019.json"),
        fixture_json("mission_2021_webster_field.json"),
        fixture_json("missions_list_2018_fixture.json"),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mission_upload_never_fails_inside(
        format in prop::sample::select(vec!["", "native", "interop-2018", "interop-2019"]),
        q in query(),
        body in body(mission_bases()),
    ) {
        let uri = if format.is_empty() {
            format!("/api/v1/missions?{q}")
        } else {
            format!("/api/v1/missions?format={format}&{q}")
        };
        check(Method::POST, &uri, body)?;
    }

    #[test]
    fn observation_upload_never_fails_inside(
        time in encoded_bytes(),
        body in body(vec![fixture_json("obstacles_2018.json")]),
    ) {
        let id = &fixture().mission_id;
        check(Method::POST, &format!("/api/v1/missions/{id}/obstacles?time={time}"), body)?;
    }

    #[test]
    fn telemetry_upload_never_fails_inside(
        q in query(),
        body in body(vec![
            fixture_json("telemetry_2019.json"),
            json!({"t": "2021-06-01T12:00:00Z", "lat": 38.145, "lon": -76.428, "alt_msl_m": 100.0, "heading_deg": 90.0}),
        ]),
    ) {
        let id = &fixture().mission_id;
        check(Method::POST, &format!("/api/v1/missions/{id}/telemetry?{q}"), body)?;
    }

    #[test]
    fn query_parameters_never_fail_inside(
        route in prop::sample::select(vec![
            "missions", "missions/{id}", "missions/{id}/observations", "missions/{id}/obstacles",
            "missions/{id}/telemetry", "missions/{id}/plans/1", "missions/{id}/risk",
        ]),
        q in query(),
    ) {
        let id = &fixture().mission_id;
        let uri = format!("/api/v1/{}?{q}", route.replace("{id}", id));
        check(Method::GET, &uri, Vec::new())?;
    }
}

/// The case issue 11 reported (`split_at` inside a multi-byte character in the time
/// parser): answered with a 4xx, not a dropped connection.
#[test]
fn a_time_cut_inside_a_multibyte_character_is_a_client_error() {
    let id = &fixture().mission_id;
    let status = check(
        Method::POST,
        &format!("/api/v1/missions/{id}/obstacles?time=%ED%95%BC%F3%81%89%97"),
        serde_json::to_vec(&fixture_json("obstacles_2018.json")).unwrap(),
    )
    .unwrap();
    assert!((400..500).contains(&status), "answered {status}");
}
