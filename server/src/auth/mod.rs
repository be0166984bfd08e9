//! Access control (issue 12): bearer tokens with roles, who wrote what, and per-token write
//! rates.
//!
//! - **Tokens** are 256 random bits from the operating system's generator, written
//!   `jink_` + 64 hex digits ([`new_token`]). Only their SHA-256 digest is stored
//!   ([`digest`]); a fast hash is the right one for secrets of this entropy (there is
//!   nothing to stretch, and every request pays for the check). They are created, listed
//!   and revoked with `jink token ...` against the database, so every replica sees the
//!   same tokens.
//! - **Roles**: `read` (GET), `write` (telemetry, obstacles, plans), `admin` (missions,
//!   tokens); each includes the ones before it ([`required_role`] says what a request
//!   needs).
//! - **Mode** ([`AuthMode`]): `Required` (any non-loopback bind, or `--auth on`): every
//!   request but `GET /healthz` needs a valid token (401 otherwise, 403 for a role too
//!   low). `Optional` (loopback by default, or `--auth off`): a request without a token
//!   is the trusted `local` writer with every right; a token, when sent, is still checked
//!   and named as the writer.
//! - **Credentials**: `Authorization: Bearer TOKEN`, or `Authorization: Basic` with the
//!   token as the password (what a browser's own prompt sends, so the operator page works
//!   on a guarded bind: a 401 offers both schemes).
//! - **Revocation** reaches every replica within [`Settings::token_cache`]: the table of
//!   valid tokens is read whole (one small query) and kept that long, then read again
//!   ([`TokenCache`]).
//! - **Who wrote what**: the guard runs the rest of the request inside
//!   [`WRITER`], the name of the token (or `local`); the store records it with every
//!   mission, observation, telemetry sample and plan ([`writer`]).
//! - **Rate limits**: per token, two token buckets, one for ingest (telemetry and
//!   obstacles) and one for the other writes (plans, replays, missions), so a token's plan
//!   flood never costs it its ingest ([`RateLimits`]). `local` is not limited.
//!
//! [`Settings::token_cache`]: crate::app::Settings

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use axum::extract::{Request, State};
use axum::http::{HeaderMap, Method, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use sha2::{Digest, Sha256};

use crate::app::AppState;
use crate::error::ApiError;

pub mod limits;

pub use limits::{RateLimits, RateSettings};

/// The writer recorded for requests without a token.
pub const LOCAL: &str = "local";

tokio::task_local! {
    /// The name of the token the current request carries (or [`LOCAL`]).
    pub static WRITER: Arc<str>;
}

/// [`LOCAL`] as an owned string (a serde default).
pub fn local() -> String {
    LOCAL.to_string()
}

/// The writer of the request being handled: its token's name, or `local` outside a
/// request or without a token.
pub fn writer() -> String {
    WRITER
        .try_with(|w| w.to_string())
        .unwrap_or_else(|_| LOCAL.to_string())
}

/// `value` (an API object) with its writer's name added as `written_by`.
pub fn with_writer<T: serde::Serialize>(value: &T, writer: &str) -> serde_json::Value {
    let mut v = serde_json::to_value(value).unwrap_or_default();
    if let Some(o) = v.as_object_mut() {
        o.insert("written_by".into(), serde_json::Value::from(writer));
    }
    v
}

/// What a token may do; each role includes the ones before it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, clap::ValueEnum)]
pub enum Role {
    /// Reads (GET), and the stateless computations (`/api/v1/avoid`, `/api/v1/reactive`).
    Read,
    /// Also telemetry, obstacles and plans.
    Write,
    /// Also missions (upload, delete) and tokens.
    Admin,
}

impl Role {
    /// The stored name.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Read => "read",
            Self::Write => "write",
            Self::Admin => "admin",
        }
    }

    /// The role of a stored name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "read" => Some(Self::Read),
            "write" => Some(Self::Write),
            "admin" => Some(Self::Admin),
            _ => None,
        }
    }
}

/// Whether requests must carry a token.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AuthMode {
    /// Every request but `GET /healthz` needs a valid token.
    Required,
    /// A request without a token is `local` with every right; a token sent is checked.
    Optional,
}

/// Who sent a request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Principal {
    /// The token's name, or [`LOCAL`].
    pub name: Arc<str>,
    /// Its role.
    pub role: Role,
    /// False for `local` (no token).
    pub token: bool,
}

impl Principal {
    fn local() -> Self {
        Self {
            name: Arc::from(LOCAL),
            role: Role::Admin,
            token: false,
        }
    }
}

/// A new token's text: `jink_` and 64 hex digits of the operating system's generator.
pub fn new_token() -> String {
    use rand::TryRng;
    let mut bytes = [0u8; 32];
    rand::rngs::SysRng
        .try_fill_bytes(&mut bytes)
        .expect("the operating system's random generator works");
    let mut s = String::with_capacity(69);
    s.push_str("jink_");
    for b in bytes {
        s.push_str(&format!("{b:02x}"));
    }
    s
}

/// The stored form of a token: the SHA-256 digest of its text, hex.
pub fn digest(token: &str) -> String {
    let d = Sha256::digest(token.as_bytes());
    let mut s = String::with_capacity(64);
    for b in d {
        s.push_str(&format!("{b:02x}"));
    }
    s
}

/// The access class of a request: the role it needs and which rate bucket it draws from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Open to everyone (`GET /healthz`, CORS preflights).
    Open,
    /// Reads and stateless computations.
    Read,
    /// Telemetry and obstacle ingest (the ingest bucket).
    Ingest,
    /// Plans and replays (the other-writes bucket).
    Write,
    /// Missions and tokens (the other-writes bucket).
    Admin,
}

impl Access {
    /// The role the request needs.
    pub fn role(self) -> Option<Role> {
        match self {
            Self::Open => None,
            Self::Read => Some(Role::Read),
            Self::Ingest | Self::Write => Some(Role::Write),
            Self::Admin => Some(Role::Admin),
        }
    }
}

/// What `method path` needs.
pub fn required_role(method: &Method, path: &str) -> Access {
    if *method == Method::OPTIONS || (*method == Method::GET && path == "/healthz") {
        return Access::Open;
    }
    if *method == Method::GET || *method == Method::HEAD {
        return Access::Read;
    }
    let path = path.trim_end_matches('/');
    // The interop surface (issue 15): logging in is open (the login checks the token
    // itself); telemetry is ingest.
    if path == "/api/login" {
        return Access::Open;
    }
    if path == "/api/telemetry" {
        return Access::Ingest;
    }
    if path.starts_with("/api/v1/tokens") || path == "/api/v1/missions" {
        return Access::Admin;
    }
    if let Some(rest) = path.strip_prefix("/api/v1/missions/") {
        let mut parts = rest.split('/');
        let _id = parts.next();
        return match (parts.next(), method) {
            (None, _) => Access::Admin,
            (Some("obstacles" | "telemetry"), _) => Access::Ingest,
            _ => Access::Write,
        };
    }
    if path.starts_with("/api/v1/avoid") || path.starts_with("/api/v1/reactive") {
        return Access::Read;
    }
    // Anything else (unknown paths, other methods): the strictest, so that nothing new is
    // open by accident.
    Access::Admin
}

/// The token a request carries: `Bearer TOKEN`, or `Basic` with the token as the password
/// (or as the user name when the password is empty).
///
/// # Errors
/// 401 for another scheme or an undecodable `Basic` value.
pub fn credentials(headers: &HeaderMap) -> Result<Option<String>, ApiError> {
    let Some(v) = headers.get(header::AUTHORIZATION) else {
        return Ok(None);
    };
    let v = v
        .to_str()
        .map_err(|_| ApiError::Unauthorized("the Authorization header is not text".into()))?
        .trim();
    let (scheme, rest) = v.split_once(' ').unwrap_or((v, ""));
    let rest = rest.trim();
    if scheme.eq_ignore_ascii_case("bearer") && !rest.is_empty() {
        return Ok(Some(rest.to_string()));
    }
    if scheme.eq_ignore_ascii_case("basic") {
        use base64::Engine;
        let decoded = base64::engine::general_purpose::STANDARD
            .decode(rest)
            .ok()
            .and_then(|b| String::from_utf8(b).ok())
            .ok_or_else(|| {
                ApiError::Unauthorized("the Basic credentials are not valid base64 text".into())
            })?;
        let (user, pass) = decoded.split_once(':').unwrap_or((&decoded, ""));
        let token = if pass.is_empty() { user } else { pass };
        return Ok(Some(token.to_string()));
    }
    Err(ApiError::Unauthorized(
        "send Authorization: Bearer TOKEN (a token from `jink token create`)".into(),
    ))
}

/// The valid tokens by digest: name and role.
type Table = HashMap<String, (Arc<str>, Role)>;

/// The valid tokens, all read at once (one small query) and kept `ttl`, so that a request
/// costs no database read: with many tokens in use, per-token entries expired together and
/// were looked up again in a burst (200 clients at once every `ttl`); a made-up token costs
/// nothing either. One reload at a time: requests that find the table stale wait for the
/// reload in progress instead of starting their own.
#[derive(Debug)]
pub struct TokenCache {
    ttl: Duration,
    table: std::sync::RwLock<Option<(Arc<Table>, Instant)>>,
    reload: tokio::sync::Mutex<()>,
    reads: AtomicU64,
}

impl TokenCache {
    /// A cache whose table lives `ttl` (zero: every request reads the database).
    pub fn new(ttl: Duration) -> Self {
        Self {
            ttl,
            table: std::sync::RwLock::new(None),
            reload: tokio::sync::Mutex::new(()),
            reads: AtomicU64::new(0),
        }
    }

    /// How many times the table has been read from the database.
    #[cfg(test)]
    pub fn reads(&self) -> u64 {
        self.reads.load(Ordering::Relaxed)
    }

    /// The table, when it was read less than `ttl` ago.
    fn fresh(&self) -> Option<Arc<Table>> {
        let table = self
            .table
            .read()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let (t, at) = table.as_ref()?;
        (at.elapsed() < self.ttl).then(|| t.clone())
    }

    /// The principal of a token's text, `None` when no valid token matches.
    ///
    /// # Errors
    /// Database failures.
    pub async fn verify(
        &self,
        store: &crate::store::Store,
        token: &str,
    ) -> Result<Option<Principal>, ApiError> {
        let key = digest(token);
        let principal = |t: &Table| {
            t.get(&key).map(|(name, role)| Principal {
                name: name.clone(),
                role: *role,
                token: true,
            })
        };
        if let Some(t) = self.fresh() {
            return Ok(principal(&t));
        }
        let _one = self.reload.lock().await;
        if let Some(t) = self.fresh() {
            return Ok(principal(&t));
        }
        // Timed from before the read: a token revoked after it is refused within `ttl`.
        let at = Instant::now();
        self.reads.fetch_add(1, Ordering::Relaxed);
        let table: Table = store
            .valid_tokens()
            .await?
            .into_iter()
            .filter_map(|(digest, name, role)| {
                Some((digest, (Arc::from(name), Role::parse(&role)?)))
            })
            .collect();
        let answer = principal(&table);
        *self
            .table
            .write()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some((Arc::new(table), at));
        Ok(answer)
    }
}

/// The guard middleware: authenticates, authorises, applies the write rate limits, then
/// runs the request with its writer named in [`WRITER`].
pub async fn guard(State(state): State<AppState>, req: Request, next: Next) -> Response {
    // Read what is needed first: nothing of the request is held across an await (its body
    // is not `Sync`).
    let access = required_role(req.method(), req.uri().path());
    let presented = match credentials(req.headers()) {
        // An interop client's session cookie stands for the token it logged in with.
        Ok(None) => Ok(crate::interop::session_cookie(req.headers())
            .and_then(|id| state.interop.sessions.get(&id))
            .and_then(|s| s.token)),
        other => other,
    };
    let admitted = match (access.role(), presented) {
        (None, _) => Ok(Principal::local()),
        (Some(_), Err(e)) => Err(e),
        (Some(role), Ok(presented)) => {
            let what = format!("{} {}", req.method(), req.uri().path());
            authorise(&state, access, role, presented, &what).await
        }
    };
    match admitted {
        Ok(p) => WRITER.scope(p.name, next.run(req)).await,
        Err(e) => e.into_response(),
    }
}

async fn authorise(
    state: &AppState,
    access: Access,
    role: Role,
    presented: Option<String>,
    what: &str,
) -> Result<Principal, ApiError> {
    let principal = match presented {
        Some(token) => state
            .guard
            .tokens
            .verify(&state.store, &token)
            .await?
            .ok_or_else(|| {
                ApiError::Unauthorized(
                    "the token is not valid (unknown or revoked); `jink token list` shows the valid ones".into(),
                )
            })?,
        None if state.settings.access.auth == AuthMode::Optional => Principal::local(),
        None => {
            return Err(ApiError::Unauthorized(
                "this server requires a token: send Authorization: Bearer TOKEN (an admin creates one with `jink token create --name NAME --role read|write|admin`)".into(),
            ));
        }
    };
    if principal.role < role {
        return Err(ApiError::Forbidden(format!(
            "token '{}' has role {}; {what} needs role {}",
            principal.name,
            principal.role.as_str(),
            role.as_str()
        )));
    }
    if principal.token {
        state.guard.rates.check(&principal.name, access)?;
    }
    Ok(principal)
}

/// The guard's state: the token cache and the rate buckets.
#[derive(Debug)]
pub struct Guard {
    /// Verified tokens.
    pub tokens: TokenCache,
    /// Per-token write rates.
    pub rates: RateLimits,
}

impl Guard {
    /// A guard with a token cache of `ttl` and the rates `rates`.
    pub fn new(ttl: Duration, rates: RateSettings) -> Self {
        Self {
            tokens: TokenCache::new(ttl),
            rates: RateLimits::new(rates),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roles_follow_the_method_and_the_resource() {
        let a = |m: Method, p: &str| required_role(&m, p);
        assert_eq!(a(Method::GET, "/healthz"), Access::Open);
        assert_eq!(a(Method::GET, "/api/v1/missions/x/telemetry"), Access::Read);
        assert_eq!(a(Method::POST, "/api/v1/missions"), Access::Admin);
        assert_eq!(a(Method::DELETE, "/api/v1/missions/x"), Access::Admin);
        assert_eq!(
            a(Method::POST, "/api/v1/missions/x/obstacles"),
            Access::Ingest
        );
        assert_eq!(
            a(Method::POST, "/api/v1/missions/x/telemetry"),
            Access::Ingest
        );
        assert_eq!(a(Method::POST, "/api/v1/missions/x/plan"), Access::Write);
        assert_eq!(
            a(Method::POST, "/api/v1/missions/x/plans/p/replay"),
            Access::Write
        );
        assert_eq!(a(Method::POST, "/api/v1/reactive/offset"), Access::Read);
        assert_eq!(a(Method::PUT, "/anything"), Access::Admin);
        assert_eq!(a(Method::POST, "/api/login"), Access::Open);
        assert_eq!(a(Method::POST, "/api/telemetry"), Access::Ingest);
        assert_eq!(a(Method::GET, "/api/missions/1"), Access::Read);
    }

    async fn valid(cache: &TokenCache, store: &crate::store::Store, token: &str) -> bool {
        cache.verify(store, token).await.expect("verify").is_some()
    }

    #[tokio::test]
    async fn the_token_table_is_read_once_per_ttl_however_many_tokens_and_requests() {
        let dir = tempfile::tempdir().expect("tempdir");
        let url = format!("sqlite://{}", dir.path().join("t.sqlite").display());
        let store = crate::store::Store::open(&url).await.expect("open");
        let tokens: Vec<String> = (0..20).map(|_| new_token()).collect();
        for (i, t) in tokens.iter().enumerate() {
            let role = if i % 2 == 0 { "write" } else { "read" };
            store
                .create_token(&format!("gcs-{i}"), role, &digest(t), 0.0)
                .await
                .expect("create");
        }
        let cache = Arc::new(TokenCache::new(Duration::from_millis(300)));
        // Every token twice and a made-up one, all at once, on a cold cache.
        let mut asks: Vec<String> = tokens.iter().chain(&tokens).cloned().collect();
        asks.push(new_token());
        let tasks: Vec<_> = asks
            .into_iter()
            .map(|t| {
                let (cache, store) = (cache.clone(), store.clone());
                tokio::spawn(async move { cache.verify(&store, &t).await.expect("verify") })
            })
            .collect();
        let mut got = Vec::new();
        for t in tasks {
            got.push(t.await.expect("task").map(|p| (p.name.to_string(), p.role)));
        }
        for (i, g) in got.iter().take(40).enumerate() {
            let role = if i % 20 % 2 == 0 {
                Role::Write
            } else {
                Role::Read
            };
            assert_eq!(g, &Some((format!("gcs-{}", i % 20), role)));
        }
        assert_eq!(got[40], None, "a made-up token");
        assert_eq!(cache.reads(), 1, "41 requests, one read of the table");
        // Revoked: still valid until the table is older than the ttl, then refused.
        assert!(store.revoke_token("gcs-0", 1.0).await.expect("revoke"));
        assert!(valid(&cache, &store, &tokens[0]).await);
        tokio::time::sleep(Duration::from_millis(350)).await;
        assert!(!valid(&cache, &store, &tokens[0]).await);
        assert!(valid(&cache, &store, &tokens[1]).await);
        assert_eq!(cache.reads(), 2);
        // A ttl of zero reads the database for every request.
        let every = TokenCache::new(Duration::ZERO);
        for _ in 0..3 {
            assert!(valid(&every, &store, &tokens[1]).await);
        }
        assert_eq!(every.reads(), 3);
    }

    #[test]
    fn tokens_are_long_random_and_stored_as_their_digest() {
        let (a, b) = (new_token(), new_token());
        assert_ne!(a, b);
        assert_eq!(a.len(), 69);
        assert!(a.starts_with("jink_"));
        // SHA-256 of "abc" (FIPS 180-2, appendix B.1).
        assert_eq!(
            digest("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn bearer_and_basic_credentials_carry_the_token() {
        let mut h = HeaderMap::new();
        assert_eq!(credentials(&h).unwrap(), None);
        h.insert(header::AUTHORIZATION, "Bearer jink_abc".parse().unwrap());
        assert_eq!(credentials(&h).unwrap().as_deref(), Some("jink_abc"));
        // "op:jink_abc"
        h.insert(
            header::AUTHORIZATION,
            "Basic b3A6amlua19hYmM=".parse().unwrap(),
        );
        assert_eq!(credentials(&h).unwrap().as_deref(), Some("jink_abc"));
        h.insert(header::AUTHORIZATION, "Digest x".parse().unwrap());
        assert!(credentials(&h).is_err());
    }
}
