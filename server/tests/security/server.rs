//! A `jink serve` process with chosen flags, and `jink token` against its database.

use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use serde_json::{Value, json};

use crate::support::{fixture, spawn_jink};

/// A database for the tests of one case: a SQLite file in `dir`, or a fresh PostgreSQL
/// database (dropped at the end).
pub struct Db {
    pub url: String,
    pub dir: tempfile::TempDir,
    pg_name: Option<String>,
}

impl Db {
    pub fn sqlite() -> Db {
        let dir = tempfile::tempdir().unwrap();
        Db {
            url: format!("sqlite://{}", dir.path().join("jink.sqlite").display()),
            dir,
            pg_name: None,
        }
    }

    /// A fresh PostgreSQL database; `None` with a printed reason when the server is not
    /// reachable, unless `JINK_REQUIRE_POSTGRES=1` (then it panics).
    pub async fn postgres() -> Option<Db> {
        let name = format!("jink_sec_{:016x}", rand::random::<u64>());
        if let Err(e) = crate::support::admin_sql(&format!("CREATE DATABASE {name}")).await {
            if std::env::var("JINK_REQUIRE_POSTGRES").is_ok_and(|v| v == "1") {
                panic!(
                    "PostgreSQL is required (JINK_REQUIRE_POSTGRES=1) but {} is not usable: {e}",
                    crate::support::postgres_admin_url()
                );
            }
            eprintln!(
                "SKIPPED: PostgreSQL test: no server at {} ({e})",
                crate::support::postgres_admin_url()
            );
            return None;
        }
        let mut url = crate::support::postgres_admin_url();
        let cut = url.rfind('/').unwrap();
        url.truncate(cut + 1);
        url.push_str(&name);
        Some(Db {
            url,
            dir: tempfile::tempdir().unwrap(),
            pg_name: Some(name),
        })
    }

    /// `jink token create --name NAME --role ROLE`: the token printed.
    pub fn create_token(&self, name: &str, role: &str) -> String {
        let out = self.jink_token(&["create", "--name", name, "--role", role]);
        assert!(
            out.status.success(),
            "token create: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let token = String::from_utf8(out.stdout).unwrap().trim().to_string();
        assert!(token.starts_with("jink_"), "{token}");
        token
    }

    pub fn jink_token(&self, args: &[&str]) -> std::process::Output {
        Command::new(env!("CARGO_BIN_EXE_jink"))
            .arg("token")
            .args(args)
            .args(["--database-url", &self.url])
            .current_dir(self.dir.path())
            .output()
            .unwrap()
    }
}

impl Drop for Db {
    fn drop(&mut self) {
        if let Some(name) = self.pg_name.take() {
            crate::support::drop_database(name);
        }
    }
}

/// A running `jink serve`.
pub struct Server {
    pub base: String,
    pub client: reqwest::Client,
    pub child: Child,
    log: std::path::PathBuf,
}

impl Server {
    /// `jink serve --database-url DB.url ARGS` (ARGS should include `--bind`).
    pub fn start(db: &Db, args: &[&str]) -> Server {
        Self::try_start(db, args)
            .unwrap_or_else(|log| panic!("jink did not start; its log:\n{log}"))
    }

    /// As [`Self::start`], or the log when it exits without listening.
    pub fn try_start(db: &Db, args: &[&str]) -> Result<Server, String> {
        let log_name = format!("jink-{:08x}.log", rand::random::<u32>());
        let mut all = vec!["serve", "--database-url", &db.url];
        all.extend_from_slice(args);
        let (mut child, lines) = spawn_jink(&all, db.dir.path(), &log_name);
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in lines {
                if let Some(addr) = line.strip_prefix("jink listening on ") {
                    let _ = tx.send(addr.to_string());
                }
            }
        });
        let log = db.dir.path().join(&log_name);
        match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(base) => Ok(Server {
                base: base.replace("0.0.0.0", "127.0.0.1"),
                client: reqwest::Client::builder()
                    .timeout(Duration::from_secs(60))
                    .build()
                    .unwrap(),
                child,
                log,
            }),
            Err(_) => {
                let _ = child.kill();
                let _ = child.wait();
                Err(std::fs::read_to_string(&log).unwrap_or_default())
            }
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// GET with an optional bearer token.
    pub async fn get(&self, path: &str, token: Option<&str>) -> reqwest::Response {
        let mut r = self.client.get(self.url(path));
        if let Some(t) = token {
            r = r.bearer_auth(t);
        }
        r.send().await.unwrap()
    }

    /// GET with an optional bearer token, the body as JSON.
    pub async fn get_json(&self, path: &str, token: Option<&str>) -> Value {
        self.get(path, token).await.json().await.unwrap()
    }

    /// POST JSON with an optional bearer token.
    pub async fn post(&self, path: &str, body: &Value, token: Option<&str>) -> reqwest::Response {
        let mut r = self.client.post(self.url(path)).json(body);
        if let Some(t) = token {
            r = r.bearer_auth(t);
        }
        r.send().await.unwrap()
    }

    /// Uploads the Webster Field mission with `token`; its id.
    pub async fn webster(&self, token: Option<&str>) -> String {
        let r = self
            .post(
                "/api/v1/missions",
                &fixture("mission_2021_webster_field.json"),
                token,
            )
            .await;
        assert_eq!(r.status(), 201);
        r.json::<Value>().await.unwrap()["id"]
            .as_str()
            .unwrap()
            .to_string()
    }

    /// Sends SIGTERM (through the `kill` command: the crate forbids `unsafe`).
    pub fn sigterm(&self) {
        let ok = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .stdout(Stdio::null())
            .status()
            .unwrap()
            .success();
        assert!(ok, "kill -TERM failed");
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One native observation of obstacle `id` at Unix time `t`.
pub fn observation(id: &str, t: f64) -> Value {
    json!({"obstacle_id": id, "t": t, "lat": 38.1455, "lon": -76.4245, "alt_msl_m": 60.0, "radius_m": 20.0})
}
