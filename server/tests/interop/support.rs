//! A real `jink serve` on its own SQLite database, which can be stopped and started again
//! at the same address (a judges' server that goes away and comes back).

use std::path::PathBuf;
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::e2e_support::serve_jink;

pub fn fixture(name: &str) -> Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/interop")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

pub struct Jink {
    /// `http://127.0.0.1:PORT`.
    pub base: String,
    pub db_url: String,
    pub client: reqwest::Client,
    pub dir: tempfile::TempDir,
    args: Vec<String>,
    child: Option<Child>,
}

impl Jink {
    /// `jink serve --bind 127.0.0.1:0 --database-url (fresh SQLite) ARGS`, started.
    pub fn start(args: &[&str]) -> Jink {
        let mut j = Self::new(args);
        j.launch("127.0.0.1:0");
        j
    }

    /// The same, not started yet (its database can be prepared with [`Self::jink`]).
    pub fn new(args: &[&str]) -> Jink {
        let dir = tempfile::tempdir().unwrap();
        let db_url = format!("sqlite://{}", dir.path().join("jink.sqlite").display());
        Jink {
            base: String::new(),
            db_url,
            client: reqwest::Client::builder()
                .timeout(Duration::from_secs(30))
                .build()
                .unwrap(),
            dir,
            args: args.iter().map(|s| s.to_string()).collect(),
            child: None,
        }
    }

    /// Starts a prepared [`Self::new`] on any free port.
    pub fn run(&mut self) {
        self.launch("127.0.0.1:0");
    }

    fn launch(&mut self, bind: &str) {
        let mut args = vec!["serve", "--bind", bind, "--database-url", &self.db_url];
        args.extend(self.args.iter().map(String::as_str));
        let (child, base) = serve_jink(&args, self.dir.path());
        self.base = base;
        self.child = Some(child);
    }

    /// Kills the process (SIGKILL: no shutdown handling at all).
    pub fn kill(&mut self) {
        if let Some(mut c) = self.child.take() {
            c.kill().unwrap();
            c.wait().unwrap();
        }
    }

    /// Starts again on the same database and the same address.
    pub fn start_again(&mut self) {
        assert!(self.child.is_none(), "still running");
        let bind = self.base.trim_start_matches("http://").to_string();
        self.launch(&bind);
    }

    /// True while the process runs.
    pub fn running(&mut self) -> bool {
        self.child
            .as_mut()
            .is_some_and(|c| c.try_wait().unwrap().is_none())
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.path().join("jink.log")).unwrap_or_default()
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    pub async fn get_json(&self, path: &str) -> Value {
        let r = self.client.get(self.url(path)).send().await.unwrap();
        assert!(r.status().is_success(), "GET {path}: {}", r.status());
        r.json().await.unwrap()
    }

    /// `GET path`'s body as text (the Prometheus `/metrics`, say).
    pub async fn get_text(&self, path: &str) -> String {
        let r = self.client.get(self.url(path)).send().await.unwrap();
        assert!(r.status().is_success(), "GET {path}: {}", r.status());
        r.text().await.unwrap()
    }

    /// Stores a mission through the native API; its jink id.
    pub async fn create_mission(&self, body: &Value) -> String {
        let r = self
            .client
            .post(self.url("/api/v1/missions"))
            .json(body)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 201, "{}", r.text().await.unwrap());
        let v: Value = r.json().await.unwrap();
        v["id"].as_str().unwrap().to_string()
    }

    /// Stores a mission through the native API with a bearer token; its jink id.
    pub async fn create_mission_as(&self, body: &Value, token: &str) -> String {
        let r = self
            .client
            .post(self.url("/api/v1/missions"))
            .bearer_auth(token)
            .json(body)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 201, "{}", r.text().await.unwrap());
        let v: Value = r.json().await.unwrap();
        v["id"].as_str().unwrap().to_string()
    }

    /// `jink token create --name NAME --role ROLE` on this database: the token.
    pub fn create_token(&self, name: &str, role: &str) -> String {
        let out = self.jink(&["token", "create", "--name", name, "--role", role]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap().trim().to_string()
    }

    /// Runs `jink ARGS --database-url (this database)`.
    pub fn jink(&self, args: &[&str]) -> std::process::Output {
        Command::new(env!("CARGO_BIN_EXE_jink"))
            .args(args)
            .args(["--database-url", &self.db_url])
            .current_dir(self.dir.path())
            .output()
            .unwrap()
    }

    /// The upstream link's status from `/healthz`.
    pub async fn link(&self) -> Value {
        self.get_json("/healthz").await["interop"].clone()
    }

    /// Polls the link's status until `ok` holds (panics with the status after `timeout`).
    pub async fn wait_link(
        &self,
        timeout: Duration,
        what: &str,
        ok: impl Fn(&Value) -> bool,
    ) -> Value {
        let start = Instant::now();
        loop {
            let l = self.link().await;
            if ok(&l) {
                return l;
            }
            if start.elapsed() > timeout {
                panic!(
                    "{what}: not within {timeout:?}; link status {l:#}\nlog:\n{}",
                    self.log()
                );
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }
}

impl Drop for Jink {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A reqwest client that keeps cookies by hand (the interop session), like
/// `requests.Session`.
pub struct Session {
    pub client: reqwest::Client,
    pub base: String,
    pub cookie: Option<String>,
}

impl Session {
    pub fn new(base: &str) -> Session {
        Session {
            client: reqwest::Client::new(),
            base: base.to_string(),
            cookie: None,
        }
    }

    fn with_cookie(&self, r: reqwest::RequestBuilder) -> reqwest::RequestBuilder {
        match &self.cookie {
            Some(c) => r.header("cookie", c),
            None => r,
        }
    }

    /// Logs in with a JSON body; keeps the cookie; the status.
    pub async fn login_json(&mut self, user: &str, pass: &str) -> u16 {
        let r = self
            .client
            .post(format!("{}/api/login", self.base))
            .json(&serde_json::json!({"username": user, "password": pass}))
            .send()
            .await
            .unwrap();
        self.keep_cookie(&r);
        r.status().as_u16()
    }

    /// Logs in with a form body (2017/2018); keeps the cookie; the status.
    pub async fn login_form(&mut self, user: &str, pass: &str) -> u16 {
        let r = self
            .client
            .post(format!("{}/api/login", self.base))
            .form(&[("username", user), ("password", pass)])
            .send()
            .await
            .unwrap();
        self.keep_cookie(&r);
        r.status().as_u16()
    }

    fn keep_cookie(&mut self, r: &reqwest::Response) {
        if let Some(c) = r.headers().get("set-cookie") {
            self.cookie = Some(c.to_str().unwrap().split(';').next().unwrap().to_string());
        }
    }

    pub async fn get(&self, path: &str) -> reqwest::Response {
        self.with_cookie(self.client.get(format!("{}{path}", self.base)))
            .send()
            .await
            .unwrap()
    }

    pub async fn post_json(&self, path: &str, body: &Value) -> reqwest::Response {
        self.with_cookie(self.client.post(format!("{}{path}", self.base)).json(body))
            .send()
            .await
            .unwrap()
    }

    pub async fn post_form(&self, path: &str, form: &[(&str, String)]) -> reqwest::Response {
        self.with_cookie(self.client.post(format!("{}{path}", self.base)).form(form))
            .send()
            .await
            .unwrap()
    }
}

/// Floats equal to 1e-9 relative.
pub fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

pub fn f(v: &Value, pointer: &str) -> f64 {
    v.pointer(pointer)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("{pointer} is not a number in {v}"))
}

pub const M_PER_FT: f64 = 0.3048;

/// `got` has the shape of `want` and every number equal to 1e-9 relative (a value that
/// went through feet and back may differ in its last bit).
pub fn assert_close_json(want: &Value, got: &Value, at: &str) {
    match (want, got) {
        (Value::Object(w), Value::Object(g)) => {
            assert_eq!(
                w.keys().collect::<Vec<_>>(),
                g.keys().collect::<Vec<_>>(),
                "{at}: keys differ"
            );
            for (k, wv) in w {
                assert_close_json(wv, &g[k], &format!("{at}/{k}"));
            }
        }
        (Value::Array(w), Value::Array(g)) => {
            assert_eq!(w.len(), g.len(), "{at}: lengths differ");
            for (i, (wv, gv)) in w.iter().zip(g).enumerate() {
                assert_close_json(wv, gv, &format!("{at}/{i}"));
            }
        }
        (Value::Number(w), Value::Number(g)) => {
            let (w, g) = (w.as_f64().unwrap(), g.as_f64().unwrap());
            assert!(close(w, g), "{at}: {g} != {w}");
        }
        (w, g) => assert_eq!(w, g, "{at}"),
    }
}
