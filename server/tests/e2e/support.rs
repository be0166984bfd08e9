//! Starts the real `jink` binary on a free port against a fresh database and talks HTTP
//! to it.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use serde_json::Value;

/// Which store a test runs against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Db {
    Sqlite,
    Postgres,
}

/// The PostgreSQL server the suite uses (trust auth). Override with `JINK_TEST_POSTGRES_URL`.
pub fn postgres_admin_url() -> String {
    std::env::var("JINK_TEST_POSTGRES_URL")
        .unwrap_or_else(|_| "postgres://postgres@127.0.0.1:5432/test".into())
}

/// A running jink and the database it owns.
pub struct App {
    pub base: String,
    pub client: reqwest::Client,
    pub db_url: String,
    child: Option<Child>,
    pg_db: Option<String>,
    dir: tempfile::TempDir,
    extra_args: Vec<String>,
    /// `--bind` of the next start (None: any free port).
    bind: Option<String>,
}

pub fn fixture(name: &str) -> Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/interop")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

pub fn fixture_text(name: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/interop")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

impl App {
    /// Starts jink on a fresh database; `None` (with a printed reason) when the
    /// PostgreSQL server is not reachable and the run does not require it
    /// (`JINK_REQUIRE_POSTGRES=1` turns the skip into a failure, as CI sets it).
    pub async fn spawn(db: Db) -> Option<App> {
        Self::spawn_with(db, &[]).await
    }

    pub async fn spawn_with(db: Db, extra_args: &[&str]) -> Option<App> {
        let dir = tempfile::tempdir().unwrap();
        let (db_url, pg_db) = match db {
            Db::Sqlite => (
                format!("sqlite://{}", dir.path().join("jink.sqlite").display()),
                None,
            ),
            Db::Postgres => {
                let name = format!("jink_e2e_{:016x}", rand::random::<u64>());
                if let Err(e) = admin_sql(&format!("CREATE DATABASE {name}")).await {
                    if std::env::var("JINK_REQUIRE_POSTGRES").is_ok_and(|v| v == "1") {
                        panic!(
                            "PostgreSQL is required (JINK_REQUIRE_POSTGRES=1) but {} is not usable: {e}",
                            postgres_admin_url()
                        );
                    }
                    eprintln!(
                        "SKIPPED: PostgreSQL store test: no server at {} ({e})",
                        postgres_admin_url()
                    );
                    return None;
                }
                let mut url = postgres_admin_url();
                let cut = url.rfind('/').unwrap();
                url.truncate(cut + 1);
                url.push_str(&name);
                (url, Some(name))
            }
        };
        let mut app = App {
            base: String::new(),
            client: reqwest::Client::builder()
                .timeout(Duration::from_secs(60))
                .build()
                .unwrap(),
            db_url,
            child: None,
            pg_db,
            dir,
            extra_args: extra_args.iter().map(|s| s.to_string()).collect(),
            bind: None,
        };
        app.start();
        Some(app)
    }

    fn start(&mut self) {
        let bind = self.bind.clone().unwrap_or_else(|| "127.0.0.1:0".into());
        let mut args = vec!["serve", "--bind", &bind, "--database-url", &self.db_url];
        // Plans see every batch posted before them (read your writes), so that what a test
        // asserts never depends on how fast a map was built; a test of the default says so.
        if !self.extra_args.iter().any(|a| a == "--plan-map-max-age-ms") {
            args.extend(["--plan-map-max-age-ms", "0"]);
        }
        args.extend(self.extra_args.iter().map(String::as_str));
        let (child, base) = serve_jink(&args, self.dir.path());
        self.base = base;
        self.child = Some(child);
    }

    /// A second `jink serve` on the same database (a replica); it does not own the
    /// database, so drop it before `self`.
    pub fn replica(&self) -> App {
        let mut app = App {
            base: String::new(),
            client: self.client.clone(),
            db_url: self.db_url.clone(),
            child: None,
            pg_db: None,
            dir: tempfile::tempdir().unwrap(),
            extra_args: self.extra_args.clone(),
            bind: None,
        };
        app.start();
        app
    }

    /// Kills the process with SIGKILL (no shutdown handling at all) and starts a new one
    /// on the same database.
    pub fn kill9_and_restart(&mut self) {
        if let Some(mut c) = self.child.take() {
            c.kill().unwrap(); // SIGKILL on Unix
            c.wait().unwrap();
        }
        self.start();
    }

    /// [`Self::kill9_and_restart`] on the same address, so that clients (a browser page)
    /// find the service where it was.
    #[allow(dead_code)] // tests/browser.rs
    pub fn kill9_and_restart_at_the_same_address(&mut self) {
        self.bind = Some(self.base.trim_start_matches("http://").to_string());
        self.kill9_and_restart();
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    pub async fn post_json(&self, path: &str, body: &Value) -> reqwest::Response {
        self.client
            .post(self.url(path))
            .json(body)
            .send()
            .await
            .unwrap()
    }

    pub async fn post_raw(
        &self,
        path: &str,
        content_type: &str,
        body: impl Into<reqwest::Body>,
    ) -> reqwest::Response {
        self.client
            .post(self.url(path))
            .header("content-type", content_type)
            .body(body)
            .send()
            .await
            .unwrap()
    }

    pub async fn get(&self, path: &str) -> reqwest::Response {
        self.client.get(self.url(path)).send().await.unwrap()
    }

    pub async fn get_json(&self, path: &str) -> Value {
        let r = self.get(path).await;
        assert_eq!(r.status(), 200, "GET {path}");
        r.json().await.unwrap()
    }

    /// GETs `path`: asserts 200 and a media type starting with `media`; returns the body.
    pub async fn get_text(&self, path: &str, media: &str) -> String {
        let r = self.get(path).await;
        assert_eq!(r.status(), 200, "GET {path}");
        let ct = r.headers()["content-type"].to_str().unwrap().to_string();
        assert!(ct.starts_with(media), "GET {path}: {ct}");
        r.text().await.unwrap()
    }

    /// Posts a native observation batch `{"observations": observations}` to mission `id`;
    /// asserts 202 and returns the counts.
    pub async fn post_observations(&self, id: &str, observations: Value) -> Value {
        let path = format!("/api/v1/missions/{id}/obstacles");
        let r = self
            .post_json(&path, &serde_json::json!({ "observations": observations }))
            .await;
        assert_eq!(r.status(), 202, "POST {path}");
        r.json().await.unwrap()
    }

    /// Posts interop 2018 form-encoded aircraft telemetry (no time: stamped on receipt) to
    /// mission `id`; asserts 202.
    pub async fn post_telemetry_form(&self, id: &str, form: &'static str) {
        let path = format!("/api/v1/missions/{id}/telemetry");
        let r = self
            .post_raw(&path, "application/x-www-form-urlencoded", form)
            .await;
        assert_eq!(r.status(), 202, "POST {path}");
    }

    /// POSTs JSON `body` to `path`: asserts 200 and returns the answer.
    pub async fn post_ok(&self, path: &str, body: &Value) -> Value {
        let r = self.post_json(path, body).await;
        assert_eq!(r.status(), 200, "POST {path}");
        r.json().await.unwrap()
    }

    /// Uploads the Webster Field mission (interop 2019+ fixture) and returns its id.
    pub async fn create_webster_mission(&self) -> String {
        self.create_mission(&fixture("mission_2021_webster_field.json"))
            .await
    }

    /// Uploads a mission and returns its id.
    pub async fn create_mission(&self, body: &Value) -> String {
        let r = self.post_json("/api/v1/missions", body).await;
        let status = r.status();
        let v: Value = r.json().await.unwrap();
        assert_eq!(status, 201, "{v}");
        v["id"].as_str().unwrap().to_string()
    }
}

impl Drop for App {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
        if let Some(name) = self.pg_db.take() {
            drop_database(name);
        }
    }
}

/// Starts `jink serve ...` (`args` from `serve` on) in `dir` with its stderr appended to
/// `dir/jink.log`, and waits for its address (`http://...`); panics with the log when it
/// has not printed one within 60 s.
pub fn serve_jink(args: &[&str], dir: &Path) -> (Child, String) {
    let (mut child, lines) = spawn_jink(args, dir, "jink.log");
    // The address line, read on a thread so that a jink that never prints it times out.
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in lines {
            if let Some(addr) = line.strip_prefix("jink listening on ") {
                let _ = tx.send(addr.to_string());
            }
        }
    });
    match rx.recv_timeout(Duration::from_secs(60)) {
        Ok(addr) => (child, addr),
        Err(_) => {
            let _ = child.kill();
            let log = std::fs::read_to_string(dir.join("jink.log")).unwrap_or_default();
            panic!("jink did not start within 60 s; its log:\n{log}");
        }
    }
}

/// Starts `jink ARGS` in `dir` with its stderr appended to `dir/LOG`; the iterator yields
/// its stdout lines.
pub fn spawn_jink(args: &[&str], dir: &Path, log: &str) -> (Child, mpsc::IntoIter<String>) {
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join(log))
        .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_jink"))
        .args(args)
        .env("RUST_LOG", "warn")
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("start jink");
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx.into_iter())
}

/// Drops PostgreSQL database `name`, from a thread with its own runtime (drops run inside
/// a test's runtime, which cannot block on another future).
pub fn drop_database(name: String) {
    let _ = std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let _ = rt.block_on(admin_sql(&format!(
            "DROP DATABASE IF EXISTS {name} WITH (FORCE)"
        )));
    })
    .join();
}

/// Runs `sql` as the PostgreSQL administrator (10 s at most).
pub async fn admin_sql(sql: &str) -> Result<(), String> {
    use sqlx::Connection;
    let fut = async {
        let mut c = sqlx::PgConnection::connect(&postgres_admin_url())
            .await
            .map_err(|e| e.to_string())?;
        sqlx::raw_sql(sqlx::AssertSqlSafe(sql.to_string()))
            .execute(&mut c)
            .await
            .map_err(|e| e.to_string())?;
        c.close().await.map_err(|e| e.to_string())
    };
    tokio::time::timeout(Duration::from_secs(10), fut)
        .await
        .map_err(|_| "timed out".to_string())?
}

/// A problem+json answer: checks the media type and returns the document.
pub async fn problem(r: reqwest::Response, status: u16) -> Value {
    assert_eq!(r.status().as_u16(), status, "status");
    let ct = r
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    let body = r.text().await.unwrap();
    assert_eq!(ct, "application/problem+json", "content type of {body}");
    let v: Value = serde_json::from_str(&body).unwrap();
    assert_eq!(v["status"].as_u64(), Some(u64::from(status)), "{v}");
    v
}

/// The `(accepted, duplicate)` counts of an ingest answer, which must be a 202.
pub async fn ingest_counts(r: reqwest::Response) -> (u64, u64) {
    assert_eq!(r.status(), 202);
    let v: Value = r.json().await.unwrap();
    let count = |k: &str| v[k].as_u64().unwrap_or_else(|| panic!("no {k} in {v}"));
    (count("accepted"), count("duplicate"))
}

/// The number at JSON `pointer` in `v` (e.g. `/waypoints/0/alt_msl_m`).
pub fn num(v: &Value, pointer: &str) -> f64 {
    v.pointer(pointer)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("no number at {pointer} in {v}"))
}

/// The `code` of each warning of a plan, in order.
pub fn warning_codes(plan: &Value) -> Vec<String> {
    plan["warnings"]
        .as_array()
        .unwrap_or_else(|| panic!("no warnings in {plan}"))
        .iter()
        .map(|w| w["code"].as_str().unwrap().to_string())
        .collect()
}

/// The number `key` of each element of a JSON list, in order.
pub fn nums(list: &Value, key: &str) -> Vec<f64> {
    list.as_array()
        .unwrap_or_else(|| panic!("not a list: {list}"))
        .iter()
        .map(|o| {
            o[key]
                .as_f64()
                .unwrap_or_else(|| panic!("no number {key} in {o}"))
        })
        .collect()
}

/// The element of a JSON list whose `id` is `id`.
pub fn by_id(list: &Value, id: &str) -> Value {
    list.as_array()
        .unwrap()
        .iter()
        .find(|o| o["id"] == id)
        .unwrap_or_else(|| panic!("no id {id} in {list}"))
        .clone()
}

/// A problem+json answer (as [`problem`]) whose detail mentions `mention`.
pub async fn problem_about(r: reqwest::Response, status: u16, mention: &str) -> Value {
    let p = problem(r, status).await;
    let detail = p["detail"].as_str().unwrap_or_default();
    assert!(detail.contains(mention), "{mention:?} not in {p}");
    p
}

/// The pointers named by a problem document.
pub fn pointers(p: &Value) -> Vec<String> {
    p["errors"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|e| e["pointer"].as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default()
}

/// Runs each named async test body `async fn name(app: App)` against SQLite and
/// PostgreSQL, as `name::sqlite` and `name::postgres`.
#[macro_export]
macro_rules! both_stores {
    ($($name:ident),* $(,)?) => {$(
        mod $name {
            #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
            async fn sqlite() {
                if let Some(app) = $crate::support::App::spawn($crate::support::Db::Sqlite).await {
                    super::$name(app).await;
                }
            }
            #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
            async fn postgres() {
                if let Some(app) = $crate::support::App::spawn($crate::support::Db::Postgres).await {
                    super::$name(app).await;
                }
            }
        }
    )*};
}
