//! Health, metrics, the OpenAPI document and the offline docs page, on the running binary.

use serde_json::Value;

use crate::both_stores;
use crate::support::{App, Db, fixture};

both_stores!(health_reports_the_database);

async fn health_reports_the_database(app: App) {
    let h = app.get_json("/healthz").await;
    assert_eq!(h["status"], "ok");
    let expected = if app.db_url.starts_with("sqlite") {
        "sqlite"
    } else {
        "postgres"
    };
    assert_eq!(h["database"], expected);
}

#[tokio::test]
async fn metrics_count_requests_per_route_in_prometheus_text() {
    let app = App::spawn(Db::Sqlite).await.unwrap();
    let id = app.create_mission(&fixture("mission_2019.json")).await;
    app.get_json(&format!("/api/v1/missions/{id}")).await;
    app.get_json(&format!("/api/v1/missions/{id}")).await;
    let text = app.get_text("/metrics", "text/plain").await;
    assert!(
        text.contains("# TYPE jink_http_requests_total counter"),
        "{text}"
    );
    assert!(
        text.contains("jink_http_requests_total{route=\"/api/v1/missions/{id}\",method=\"GET\",status=\"200\"} 2"),
        "{text}"
    );
    assert!(
        text.contains(
            "jink_http_request_duration_seconds_count{route=\"/api/v1/missions\",method=\"POST\"} 1"
        ),
        "{text}"
    );
}

#[tokio::test]
async fn every_documented_operation_is_routed_and_the_spec_is_served() {
    let app = App::spawn(Db::Sqlite).await.unwrap();
    let spec: Value = app.get_json("/openapi.json").await;
    assert_eq!(spec["openapi"], "3.1.0");
    let paths = spec["paths"].as_object().unwrap();
    assert!(paths.len() >= 8, "{}", paths.len());
    for (path, ops) in paths {
        let concrete = path
            .replace("{id}", "no-such-mission")
            .replace("{plan_id}", "no-such-plan");
        for method in ops
            .as_object()
            .unwrap()
            .keys()
            .filter(|m| ["get", "post", "put", "delete", "patch"].contains(&m.as_str()))
        {
            let m = reqwest::Method::from_bytes(method.to_uppercase().as_bytes()).unwrap();
            let r = app
                .client
                .request(m, app.url(&concrete))
                .header("content-type", "application/json")
                .body("{}")
                .send()
                .await
                .unwrap();
            let status = r.status().as_u16();
            let body = r.text().await.unwrap();
            assert!(
                !body.contains("urn:jink:problem:no-such-route")
                    && !body.contains("urn:jink:problem:method-not-allowed"),
                "{method} {path} is documented but not routed: {status} {body}"
            );
            assert!(
                status < 500,
                "{method} {path} answered {status} to a bad request: {body}"
            );
        }
    }
}

#[tokio::test]
async fn the_docs_page_needs_no_internet() {
    let app = App::spawn(Db::Sqlite).await.unwrap();
    let r = app.get("/docs/").await;
    assert_eq!(r.status(), 200);
    let html = r.text().await.unwrap();
    assert!(html.contains("swagger"), "{html}");
    // Every script and stylesheet is served by jink itself.
    for attr in ["src=\"http", "href=\"http", "src='http", "href='http"] {
        assert!(
            !html.contains(attr),
            "the docs page loads an external asset: {html}"
        );
    }
    let init = app
        .get("/docs/swagger-initializer.js")
        .await
        .text()
        .await
        .unwrap();
    assert!(init.contains("/docs/openapi.json"), "{init}");
    let bundle = app.get("/docs/swagger-ui-bundle.js").await;
    assert_eq!(bundle.status(), 200);
    assert!(bundle.text().await.unwrap().len() > 100_000);
    let landing = app.get("/").await.text().await.unwrap();
    assert!(landing.contains("/docs/"));
}

#[test]
fn logs_written_to_a_file_carry_no_colour_escapes() {
    use std::io::{BufRead, BufReader, Read, Write};
    let dir = tempfile::tempdir().unwrap();
    let log_path = dir.path().join("jink.log");
    let log = std::fs::File::create(&log_path).unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
        .args([
            "serve",
            "--bind",
            "127.0.0.1:0",
            "--database-url",
            "sqlite://jink.sqlite",
        ])
        .env("RUST_LOG", "info")
        .current_dir(dir.path())
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(log)
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let addr = lines
        .find_map(|l| {
            l.ok()?
                .strip_prefix("jink listening on ")
                .map(str::to_string)
        })
        .expect("listening line");
    let mut conn = std::net::TcpStream::connect(addr.trim_start_matches("http://")).unwrap();
    conn.write_all(b"GET /healthz HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n")
        .unwrap();
    let mut answer = String::new();
    conn.read_to_string(&mut answer).unwrap();
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let _ = child.kill();
    let _ = child.wait();
    let text = std::fs::read_to_string(&log_path).unwrap();
    assert!(text.contains("INFO"), "the log has info lines: {text}");
    assert!(
        !text.contains('\u{1b}'),
        "colour escape codes in a log file: {text:?}"
    );
}

/// The `GLIBC_TUNABLES` of process `pid` (empty when unset).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn glibc_tunables(pid: u32) -> String {
    let environ = std::fs::read(format!("/proc/{pid}/environ")).unwrap();
    environ
        .split(|b| *b == 0)
        .filter_map(|kv| std::str::from_utf8(kv).ok())
        .find_map(|kv| kv.strip_prefix("GLIBC_TUNABLES="))
        .unwrap_or_default()
        .to_string()
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[test]
fn serve_bounds_its_malloc_arenas_unless_told_not_to_or_the_environment_already_does() {
    use crate::support::serve_jink;
    let dir = tempfile::tempdir().unwrap();
    let serve = |extra: &[&str]| {
        let mut args = vec!["serve", "--bind", "127.0.0.1:0"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--database-url", "sqlite://jink.sqlite"]);
        let (mut child, _) = serve_jink(&args, dir.path());
        let tunables = glibc_tunables(child.id());
        let _ = child.kill();
        let _ = child.wait();
        tunables
    };
    // The default (2), after the re-execution that applied it: same process, same id.
    assert_eq!(serve(&[]), "glibc.malloc.arena_max=2");
    assert_eq!(
        serve(&["--malloc-arena-max", "3"]),
        "glibc.malloc.arena_max=3"
    );
    assert_eq!(serve(&["--malloc-arena-max", "0"]), "");
}
