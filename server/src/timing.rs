//! The `Server-Timing` response header (W3C Server Timing: `name;dur=MILLISECONDS`,
//! comma-separated) of the plan and ingest handlers, so that a benchmark (or an operator's
//! browser tools) sees where a request's time went on the server. Phases:
//! - `POST .../plan`: `read` (mission, latest revision and telemetry, read at once; from
//!   memory on SQLite),
//!   `snapshot` (the live snapshot), `pool` (waiting for a plan worker, and the hop to it
//!   and back), `compute` (the plan itself, its `compute_ms`), `store` (answer and record
//!   built, plan row written);
//! - `POST .../obstacles`: `parse` (JSON to observations), `store` (the batch committed),
//!   `live` (the batch fed to the mission's live state);
//! - `POST .../telemetry`: `parse` (body to samples), `store` (the samples committed);
//! - every response: `total` (the request inside the service's middleware, from the request
//!   log's start to the response: [`add_total`]), last.
//!
//! It reveals nothing a client could not time itself.

use axum::http::HeaderValue;
use axum::response::Response;

/// Where a request's time went, phase by phase, for its `Server-Timing` header.
#[derive(Debug)]
pub struct ServerTiming {
    last: std::time::Instant,
    laps: Vec<(&'static str, f64)>,
}

impl ServerTiming {
    /// Starts timing now.
    pub fn start() -> Self {
        Self {
            last: std::time::Instant::now(),
            laps: Vec::with_capacity(6),
        }
    }

    /// Ends the phase `name` now.
    pub fn lap(&mut self, name: &'static str) {
        let now = std::time::Instant::now();
        self.laps
            .push((name, now.duration_since(self.last).as_secs_f64() * 1e3));
        self.last = now;
    }

    /// Ends a phase of which `inner_ms` were `inner` and the rest `outer`.
    pub fn lap_split(&mut self, outer: &'static str, inner: &'static str, inner_ms: f64) {
        self.lap(outer);
        if let Some((_, ms)) = self.laps.last_mut() {
            let inner_ms = inner_ms.min(*ms);
            *ms -= inner_ms;
            self.laps.push((inner, inner_ms));
        }
    }

    /// The header value.
    pub fn header(&self) -> String {
        self.laps
            .iter()
            .map(|(n, ms)| format!("{n};dur={ms:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Adds `timing` to `resp` as its `Server-Timing` header.
pub fn insert(resp: &mut Response, timing: &ServerTiming) {
    if let Ok(v) = HeaderValue::from_str(&timing.header()) {
        resp.headers_mut().insert("server-timing", v);
    }
}

/// Adds `total;dur=` (the whole request inside the service's middleware, handler and
/// every layer under it) to the `Server-Timing` of `resp`, after its handler's phases if
/// it has them: what a client's round trip has beyond it is HTTP, loopback and the client.
pub fn add_total(resp: &mut Response, elapsed: std::time::Duration) {
    let total = format!("total;dur={:.3}", elapsed.as_secs_f64() * 1e3);
    let value = match resp.headers().get("server-timing").map(HeaderValue::to_str) {
        Some(Ok(phases)) if !phases.is_empty() => format!("{phases}, {total}"),
        _ => total,
    };
    if let Ok(v) = HeaderValue::from_str(&value) {
        resp.headers_mut().insert("server-timing", v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_split_phase_gives_its_inner_part_and_the_rest() {
        let mut t = ServerTiming::start();
        std::thread::sleep(std::time::Duration::from_millis(3));
        t.lap("read");
        std::thread::sleep(std::time::Duration::from_millis(4));
        t.lap_split("pool", "compute", 2.5);
        let h = t.header();
        let laps: Vec<(&str, f64)> = h
            .split(", ")
            .map(|p| {
                let (n, d) = p.split_once(";dur=").expect("name;dur=ms");
                (n, d.parse().expect("ms"))
            })
            .collect();
        let names: Vec<&str> = laps.iter().map(|l| l.0).collect();
        assert_eq!(names, ["read", "pool", "compute"]);
        assert!(laps[0].1 >= 3.0, "{h}");
        assert_eq!(laps[2].1, 2.5);
        assert!(laps[1].1 >= 4.0 - 2.5, "{h}");
    }

    #[test]
    fn the_total_follows_the_handlers_phases_or_stands_alone() {
        let ms = std::time::Duration::from_micros(1500);
        let mut with = Response::new(axum::body::Body::empty());
        let mut t = ServerTiming::start();
        t.lap("parse");
        insert(&mut with, &t);
        add_total(&mut with, ms);
        let h = with.headers()["server-timing"].to_str().expect("ascii");
        assert!(h.starts_with("parse;dur="), "{h}");
        assert!(h.ends_with(", total;dur=1.500"), "{h}");
        let mut bare = Response::new(axum::body::Body::empty());
        add_total(&mut bare, ms);
        assert_eq!(bare.headers()["server-timing"], "total;dur=1.500");
    }
}
