//! Shared by the load benchmarks: environment knobs, the store, starting the real `jink
//! serve` and the requests every benchmark makes.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

/// Resident memory of process `pid`, MB (0 when it cannot be read).
pub fn rss_mb(pid: u32) -> f64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1024.0)
}

/// The value of environment variable `k`, else `d`.
pub fn env_or<T: std::str::FromStr>(k: &str, d: T) -> T {
    std::env::var(k)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

/// Starts `jink serve` on a free loopback port over `db_url`; returns the process and its
/// base URL (`http://127.0.0.1:PORT`).
pub fn spawn_jink(db_url: &str) -> (Child, String) {
    spawn_jink_with(db_url, &[])
}

/// [`spawn_jink`] with more `serve` arguments. `JINK_BENCH_BIN` names another `jink`
/// binary to measure (e.g. one built from an older commit), else this build's.
pub fn spawn_jink_with(db_url: &str, extra: &[&str]) -> (Child, String) {
    let bin = std::env::var("JINK_BENCH_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_jink").into());
    let mut child = Command::new(bin)
        .args(["serve", "--bind", "127.0.0.1:0", "--database-url", db_url])
        .args(extra)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start jink");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let base = line
        .trim()
        .strip_prefix("jink listening on ")
        .expect("listening line")
        .to_string();
    (child, base)
}

/// The store URL: environment variable `k`, else a fresh SQLite file `file` in a temporary
/// directory (returned with it: the directory lives as long as it does).
pub fn database_url(k: &str, file: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let url = std::env::var(k)
        .unwrap_or_else(|_| format!("sqlite://{}", dir.path().join(file).display()));
    (dir, url)
}

/// Uploads the Webster Field interop fixture; returns the new mission's id.
pub async fn create_webster(client: &reqwest::Client, base: &str) -> String {
    let mission = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/fixtures/interop/mission_2021_webster_field.json"
    ))
    .unwrap();
    let r = expect(
        client
            .post(format!("{base}/api/v1/missions"))
            .header("content-type", "application/json")
            .body(mission),
        201,
    )
    .await;
    r.json::<serde_json::Value>().await.unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string()
}

/// Sends `req` and checks the answer's status.
///
/// # Panics
/// When the request fails or the status is another.
pub async fn expect(req: reqwest::RequestBuilder, status: u16) -> reqwest::Response {
    let r = req.send().await.unwrap();
    assert_eq!(r.status(), status);
    r
}
