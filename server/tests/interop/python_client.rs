//! The third-party interop client from PyPI (`suas-interop-clients` 0.1.2, its
//! `InteropClient` class), unchanged, against a running jink: login, `get_mission`,
//! `post_telemetry` x N, `get_teams`; the telemetry reads back from jink's native API in
//! order.
//!
//! The client runs in the Python named by `JINK_INTEROP_PYTHON` (default `python3`), which
//! must import `interop_clients`. `.ci/run` installs it into a virtual environment and sets
//! `JINK_REQUIRE_INTEROP_CLIENT=1`, which turns a missing client into a failure; elsewhere
//! the tests are skipped with the reason printed.

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;

use crate::support::{Jink, M_PER_FT, close, f, fixture};

/// The Python that has the client, or `None` (skipped, with the reason printed).
fn python() -> Option<String> {
    let py = std::env::var("JINK_INTEROP_PYTHON").unwrap_or_else(|_| "python3".into());
    let probe = Command::new(&py)
        .args(["-c", "import interop_clients.client"])
        .output();
    let why = match probe {
        Ok(o) if o.status.success() => return Some(py),
        Ok(o) => String::from_utf8_lossy(&o.stderr).trim().to_string(),
        Err(e) => e.to_string(),
    };
    if std::env::var("JINK_REQUIRE_INTEROP_CLIENT").is_ok_and(|v| v == "1") {
        panic!(
            "the PyPI interop client is required (JINK_REQUIRE_INTEROP_CLIENT=1) but {py} cannot import it: {why}"
        );
    }
    eprintln!(
        "SKIPPED: the PyPI interop client is not importable by {py} ({why}); install it with\n    python3 -m venv /tmp/interop && /tmp/interop/bin/pip install suas-interop-clients==0.1.2\nand set JINK_INTEROP_PYTHON=/tmp/interop/bin/python"
    );
    None
}

/// Runs `client.py` against `base`: what it printed.
fn run_client(py: &str, base: &str, user: &str, password: &str, n: usize) -> Value {
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/interop/client.py");
    let out = Command::new(py)
        .arg(script)
        .args([base, user, password, "1", &n.to_string()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "the interop client failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The client's samples arrived in `mission`, in order, in metres.
async fn assert_telemetry(jink: &Jink, mission: &str, n: usize) {
    let got = jink
        .get_json(&format!("/api/v1/missions/{mission}/telemetry"))
        .await;
    let got = got.as_array().unwrap();
    assert_eq!(got.len(), n);
    for (i, g) in got.iter().enumerate() {
        assert_eq!(f(g, "/lat"), 38.1445 + i as f64 * 1e-5, "sample {i}: {g}");
        assert!(
            close(f(g, "/alt_msl_m"), (150.0 + i as f64) * M_PER_FT),
            "sample {i}: {g}"
        );
        assert!(
            close(f(g, "/heading_deg"), (i * 13 % 360) as f64),
            "sample {i}: {g}"
        );
    }
}

#[tokio::test]
async fn the_pypi_interop_client_flies_a_mission_against_jink_unchanged() {
    let Some(py) = python() else { return };
    let jink = Jink::start(&[]);
    let doc = fixture("mission_2021_webster_field.json");
    let id = jink.create_mission(&doc).await;
    let seen = run_client(&py, &jink.base, "testuser", "testpass", 40);
    // On an open (loopback) bind any credentials log in.
    assert_eq!(seen["wrong_password"], "accepted");
    let m = &seen["mission"];
    assert_eq!(m["id"], 1);
    for (i, w) in doc["waypoints"].as_array().unwrap().iter().enumerate() {
        for k in ["latitude", "longitude", "altitude"] {
            assert!(close(
                f(w, &format!("/{k}")),
                f(m, &format!("/waypoints/{i}/{k}"))
            ));
        }
    }
    assert_eq!(m["stationaryObstacles"].as_array().unwrap().len(), 6);
    assert_telemetry(&jink, &id, 40).await;
    assert_eq!(seen["teams"][0]["team"]["username"], "testuser");
    assert!(close(f(&seen["teams"], "/0/telemetry/altitude"), 189.0));
}

#[tokio::test]
async fn the_pypi_interop_client_logs_in_with_a_token_on_a_guarded_bind() {
    let Some(py) = python() else { return };
    let mut jink = Jink::new(&["--auth", "on"]);
    let token = jink.create_token("team", "write");
    let admin = jink.create_token("ops", "admin");
    jink.run();
    let id = jink
        .create_mission_as(&fixture("mission_2021_webster_field.json"), &admin)
        .await;
    let seen = run_client(&py, &jink.base, "team", &token, 5);
    assert_eq!(seen["wrong_password"], "InteropError");
    assert_eq!(seen["mission"]["id"], 1);
    let got: Value = jink
        .client
        .get(jink.url(&format!("/api/v1/missions/{id}/telemetry")))
        .bearer_auth(&admin)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let got = got.as_array().unwrap();
    assert_eq!(got.len(), 5);
    assert!(got.iter().all(|g| g["written_by"] == "team"));
    for (i, g) in got.iter().enumerate() {
        assert_eq!(f(g, "/lat"), 38.1445 + i as f64 * 1e-5);
    }
}
