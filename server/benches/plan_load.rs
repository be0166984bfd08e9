//! Plan-load benchmark (issue 9): replays a judge-style flight against a real `jink serve`
//! on loopback, in real time, and reports plan and ingest latencies, server CPU per
//! flight-second, and the resident memory of many live missions.
//!
//! Run: `cargo bench -p server --bench plan_load` (release build). Flight: the Webster Field
//! fixture, 10 spheres flying circles over the field posting an interop-2018 obstacle
//! snapshot (with its `time`) at 5 Hz, aircraft telemetry at 5 Hz, and `POST .../plan`
//! (seeded, default options) at 1 Hz for `JINK_PLAN_SECONDS` (default 20), then at 5 Hz
//! for as long (`JINK_PLAN_RATES`, default `1,5`: the plan rates of the phases, in order;
//! `5,1` flies the 1 Hz phase second, past the flight's first seconds of young tracks). Then `JINK_PLAN_MISSIONS` (default 100) missions each get 30 s of 10
//! obstacles at 5 Hz (posted as fast as accepted) and one read of their obstacles, which
//! makes them live (predictor, no risk map), and the server's resident memory (VmRSS) is
//! reported; then each gets one plan (which builds its risk map; the server keeps at most
//! `--live-max-maps` of them) and VmRSS is reported again.
//! `JINK_PLAN_DATABASE_URL` overrides the store (default: a fresh SQLite file).
//! The aircraft flies its plans: it follows the stack of each plan answer (18 m/s, 35 m
//! turn radius, the next item within 20 m or once past it), its telemetry is where it is,
//! and each plan names the revision it flies (`base_revision`) and the item of that stack
//! it flies to (`current_index`), as a team's ground station does (before 2026-11-29 it
//! sent no `base_revision`, so its index into a revised stack was read as a mission
//! waypoint's). `JINK_PLAN_FLY=0` holds it at the first waypoint instead (the benchmark
//! before 2026-11-28): the spheres then circle past an aircraft that never gets away, so
//! half the plans find no clear route and run the safety net, which takes several times as
//! long. Each phase prints its plans by outcome with their `compute_ms`, its slowest plan
//! (which is its p99 at 20 plans: number, outcome, round trip and `Server-Timing`),
//! where the aircraft is, the telemetry posts' round trips, and a floor: `GET /healthz`
//! (one database read) asked halfway between ticks, from the same idle state each tick's
//! first post starts from, so an ingest tail the floor shares is the machine's, not the
//! ingest's.

mod support;

use std::time::{Duration, Instant};
use support::{create_webster, database_url, env_or, expect, rss_mb, spawn_jink};

use serde_json::{Value, json};

/// (utime + stime) of a process, seconds.
fn cpu_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    // Fields 14 and 15 of stat; after the ")" they are the 12th and 13th.
    (ticks(11) + ticks(12)) / 100.0
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    v[((v.len() as f64 - 1.0) * p).round() as usize]
}

/// The aircraft of `JINK_PLAN_FLY=1`: it flies the stack of the latest plan at 18 m/s,
/// turning at most at the rate a 35 m radius allows, and goes on to the next item within
/// 20 m of it or once past it (as an autopilot does), at 4 m/s of climb. Positions are
/// metres east and north of where it starts (the project's ENU frame anchored there).
struct Flier {
    frame: wire::geodesy::LocalFrame,
    p_m: [f64; 2],
    alt_m: f64,
    heading_rad: f64,
    /// The latest plan's stack, metres and altitude.
    stack: Vec<[f64; 3]>,
    current: usize,
    leg_start_m: [f64; 2],
    /// The revision of the latest plan (0 before the first).
    revision: i64,
}

impl Flier {
    const SPEED_MPS: f64 = 18.0;
    const TURN_RADIUS_M: f64 = 35.0;

    fn new(lat: f64, lon: f64, alt_m: f64, heading_deg: f64) -> Self {
        Self {
            frame: wire::geodesy::LocalFrame::new(lat, lon),
            p_m: [0.0, 0.0],
            alt_m,
            heading_rad: (90.0 - heading_deg).to_radians(),
            stack: Vec::new(),
            current: 1,
            leg_start_m: [0.0, 0.0],
            revision: 0,
        }
    }

    /// Takes the stack of a plan answer (`waypoints`, `current_index`).
    fn follow(&mut self, plan: &Value) {
        let Some(items) = plan["waypoints"].as_array() else {
            return;
        };
        let stack: Vec<[f64; 3]> = items
            .iter()
            .map(|w| {
                let p = self
                    .frame
                    .to_enu(w["lat"].as_f64().unwrap(), w["lon"].as_f64().unwrap());
                [p[0], p[1], w["alt_msl_m"].as_f64().unwrap()]
            })
            .collect();
        let current = plan["current_index"].as_u64().unwrap_or(1) as usize;
        let old = self.stack.get(self.current).copied();
        if stack.get(current).copied() != old {
            self.leg_start_m = self.p_m;
        }
        self.stack = stack;
        self.current = current;
        self.revision = plan["revision"].as_i64().unwrap_or(self.revision);
    }

    /// Flies `dt_s` seconds.
    fn step(&mut self, dt_s: f64) {
        if let Some(t) = self.stack.get(self.current).copied() {
            let want = (t[1] - self.p_m[1]).atan2(t[0] - self.p_m[0]);
            let err = (want - self.heading_rad + std::f64::consts::PI)
                .rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            let max = Self::SPEED_MPS / Self::TURN_RADIUS_M * dt_s;
            self.heading_rad += err.clamp(-max, max);
            self.alt_m += (t[2] - self.alt_m).clamp(-4.0 * dt_s, 4.0 * dt_s);
        }
        let d = Self::SPEED_MPS * dt_s;
        self.p_m[0] += d * self.heading_rad.cos();
        self.p_m[1] += d * self.heading_rad.sin();
        while let Some(t) = self.stack.get(self.current).copied() {
            let (dx, dy) = (self.p_m[0] - t[0], self.p_m[1] - t[1]);
            let (lx, ly) = (t[0] - self.leg_start_m[0], t[1] - self.leg_start_m[1]);
            let passed = lx.hypot(ly) > 1e-6 && dx * lx + dy * ly > 0.0;
            if dx.hypot(dy) > 20.0 && !passed {
                break;
            }
            self.leg_start_m = [t[0], t[1]];
            self.current += 1;
        }
    }

    /// Its telemetry sample at flight time `t`.
    fn sample(&self, t: f64) -> Value {
        let (lat, lon) = self.frame.to_geodetic(self.p_m);
        let heading_deg = (90.0 - self.heading_rad.to_degrees()).rem_euclid(360.0);
        json!({"t": t, "lat": lat, "lon": lon, "alt_msl_m": self.alt_m,
               "heading_deg": heading_deg, "speed_mps": Self::SPEED_MPS})
    }

    /// The index to ask a plan for: the item flown to, within the stack.
    fn current_index(&self) -> usize {
        if self.stack.is_empty() {
            1
        } else {
            self.current.min(self.stack.len() - 1)
        }
    }
}

/// An interop-2018 snapshot of 10 spheres on circles over the field at flight time `t`.
fn snapshot(t: f64) -> Value {
    let moving: Vec<Value> = (0..10)
        .map(|k| {
            let k = f64::from(k);
            let w = 0.02 + 0.004 * k; // rad/s
            let a = w * t + k;
            json!({"latitude": 38.1446 + 0.0020 * a.sin() + 0.0003 * k, "longitude": -76.4290 + 0.0025 * a.cos(),
                   "altitude_msl": 200.0, "sphere_radius": 60.0 + 10.0 * k})
        })
        .collect();
    json!({"time": t, "moving_obstacles": moving, "stationary_obstacles": []})
}

/// The `Server-Timing` header of `r` (empty when absent).
fn server_timing(r: &reqwest::Response) -> String {
    r.headers()
        .get("server-timing")
        .and_then(|h| h.to_str().ok())
        .unwrap_or_default()
        .to_string()
}

/// Adds each `name;dur=ms` of a `Server-Timing` value to `phases`.
fn add_phases(phases: &mut std::collections::BTreeMap<String, Vec<f64>>, timing: &str) {
    for part in timing.split(", ") {
        if let Some((name, dur)) = part.split_once(";dur=")
            && let Ok(ms) = dur.parse::<f64>()
        {
            phases.entry(name.to_string()).or_default().push(ms);
        }
    }
}

/// `name p50/p99` of each phase.
fn phase_pcts(phases: &mut std::collections::BTreeMap<String, Vec<f64>>) -> String {
    phases
        .iter_mut()
        .map(|(k, v)| format!("{k} {:.2}/{:.2}", pct(v, 0.5), pct(v, 0.99)))
        .collect::<Vec<_>>()
        .join(", ")
}

struct Phase {
    plan_rt_ms: Vec<f64>,
    plan_compute_ms: Vec<f64>,
    /// The server's `Server-Timing` phases of each plan, by name.
    plan_phases: std::collections::BTreeMap<String, Vec<f64>>,
    /// Plans whose map lacked the batch posted just before (`map_lag_batches` > 0).
    plans_lagging: usize,
    /// Each plan's `compute_ms` by its outcome (`exact`, `no_safe_path`, ...): a plan that
    /// finds no clear route tries the safety net's detours and escapes too, so it computes
    /// longer.
    plan_outcomes: std::collections::BTreeMap<String, Vec<f64>>,
    /// The slowest plan's round trip (ms), its number in the phase (from 1), outcome,
    /// `compute_ms` and `Server-Timing`: what the phase's p99 is, with 20 plans a phase.
    slowest: Option<(f64, usize, String, f64, String)>,
    ingest_ms: Vec<f64>,
    /// The server's `Server-Timing` phases of each ingest, by name.
    ingest_phases: std::collections::BTreeMap<String, Vec<f64>>,
    /// Round trips of the aircraft's telemetry posts (one sample each).
    telemetry_ms: Vec<f64>,
    /// Each ingest and telemetry post: (round trip ms, tick, what, `Server-Timing`), for
    /// the slowest few.
    posts: Vec<(f64, u32, &'static str, String)>,
    /// Round trips of `GET /healthz` asked halfway between ticks (the server idle since
    /// the tick's requests, as before each tick's first post): one database read and
    /// nothing else, the floor the ingest's round trip stands on.
    floor_ms: Vec<f64>,
    cpu_s: f64,
    seconds: f64,
}

#[allow(clippy::too_many_arguments)]
async fn fly(
    client: &reqwest::Client,
    base: &str,
    id: &str,
    pid: u32,
    t0: f64,
    seconds: u32,
    plan_hz: u32,
    mut flier: Option<&mut Flier>,
) -> Phase {
    let mut ph = Phase {
        plan_rt_ms: Vec::new(),
        plan_compute_ms: Vec::new(),
        plan_phases: std::collections::BTreeMap::new(),
        plans_lagging: 0,
        plan_outcomes: std::collections::BTreeMap::new(),
        slowest: None,
        ingest_ms: Vec::new(),
        ingest_phases: std::collections::BTreeMap::new(),
        telemetry_ms: Vec::new(),
        posts: Vec::new(),
        floor_ms: Vec::new(),
        cpu_s: 0.0,
        seconds: f64::from(seconds),
    };
    let cpu0 = cpu_s(pid);
    let start = Instant::now();
    let ticks = seconds * 5;
    for i in 0..ticks {
        let t = t0 + f64::from(i) * 0.2;
        let s = Instant::now();
        let r = expect(
            client
                .post(format!("{base}/api/v1/missions/{id}/obstacles"))
                .json(&snapshot(t)),
            202,
        )
        .await;
        ph.ingest_ms.push(s.elapsed().as_secs_f64() * 1e3);
        let timing = server_timing(&r);
        add_phases(&mut ph.ingest_phases, &timing);
        ph.posts
            .push((*ph.ingest_ms.last().unwrap(), i, "obstacles", timing));
        let sample = match flier.as_deref_mut() {
            Some(f) => {
                f.step(0.2);
                f.sample(t)
            }
            None => {
                json!({"t": t, "lat": 38.1446916666667 + 0.00001 * f64::from(i % 50), "lon": -76.4279944444445,
                           "alt_msl_m": 60.96, "heading_deg": 60.0, "speed_mps": 20.0})
            }
        };
        let s = Instant::now();
        let r = expect(
            client
                .post(format!("{base}/api/v1/missions/{id}/telemetry"))
                .json(&sample),
            202,
        )
        .await;
        ph.telemetry_ms.push(s.elapsed().as_secs_f64() * 1e3);
        ph.posts.push((
            *ph.telemetry_ms.last().unwrap(),
            i,
            "telemetry",
            server_timing(&r),
        ));
        if i % (5 / plan_hz) == 0 {
            let s = Instant::now();
            let plan = client.post(format!("{base}/api/v1/missions/{id}/plan"));
            // The flying aircraft's ground station names the revision it flies and the
            // item of that stack it flies to.
            let body = match flier.as_deref() {
                Some(f) => {
                    json!({"seed": 7, "current_index": f.current_index(), "base_revision": f.revision})
                }
                None => json!({"seed": 7, "current_index": 1}),
            };
            let r = expect(plan.json(&body), 201).await;
            let timing = server_timing(&r);
            let v: Value = r.json().await.unwrap();
            ph.plan_rt_ms.push(s.elapsed().as_secs_f64() * 1e3);
            if let Some(f) = flier.as_deref_mut() {
                f.follow(&v);
            }
            let compute_ms = v["compute_ms"].as_f64().unwrap();
            let rt = *ph.plan_rt_ms.last().unwrap();
            if ph.slowest.as_ref().is_none_or(|w| rt > w.0) {
                ph.slowest = Some((
                    rt,
                    ph.plan_rt_ms.len(),
                    v["outcome"].as_str().unwrap_or("?").to_string(),
                    compute_ms,
                    timing.clone(),
                ));
            }
            ph.plan_compute_ms.push(compute_ms);
            ph.plan_outcomes
                .entry(v["outcome"].as_str().unwrap_or("?").to_string())
                .or_default()
                .push(compute_ms);
            if v["map_lag_batches"].as_i64().unwrap_or(0) > 0 {
                ph.plans_lagging += 1;
            }
            add_phases(&mut ph.plan_phases, &timing);
        }
        // Halfway to the next tick, the floor: a request that reads the database once.
        let half = start + Duration::from_millis(200 * u64::from(i) + 100);
        tokio::time::sleep_until(half.into()).await;
        let s = Instant::now();
        expect(client.get(format!("{base}/healthz")), 200).await;
        ph.floor_ms.push(s.elapsed().as_secs_f64() * 1e3);
        // Real time: the next tick 0.2 s after this one.
        let next = start + Duration::from_millis(200 * u64::from(i + 1));
        tokio::time::sleep_until(next.into()).await;
    }
    ph.cpu_s = cpu_s(pid) - cpu0;
    ph
}

fn main() {
    let seconds: u32 = env_or("JINK_PLAN_SECONDS", 20);
    let missions: u32 = env_or("JINK_PLAN_MISSIONS", 100);
    let (_dir, db_url) = database_url("JINK_PLAN_DATABASE_URL", "plan.sqlite");
    let (mut child, base) = spawn_jink(&db_url);
    let pid = child.id();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let client = reqwest::Client::new();
        let id = create_webster(&client, &base).await;
        let t0 = 1_700_000_000.0;
        let flying = env_or("JINK_PLAN_FLY", 1u8) == 1;
        let mut flier = flying.then(|| Flier::new(38.1446916666667, -76.4279944444445, 60.96, 60.0));
        println!(
            "plan_load: backend={} flight={seconds} s per phase, aircraft {}",
            db_url.split(':').next().unwrap_or("?"),
            if flying { "flying its plans" } else { "holding its position" }
        );
        let rates: Vec<u32> = std::env::var("JINK_PLAN_RATES")
            .unwrap_or_else(|_| "1,5".into())
            .split(',')
            .map(|r| match r.trim().parse::<u32>() {
                Ok(hz @ (1 | 5)) => hz,
                _ => panic!("JINK_PLAN_RATES: {r:?} is not 1 or 5 (plans per second)"),
            })
            .collect();
        for (k, hz) in rates.into_iter().enumerate() {
            let t = t0 + f64::from(k as u32 * seconds);
            let mut ph = fly(&client, &base, &id, pid, t, seconds, hz, flier.as_mut()).await;
            println!(
                "  plans at {hz} Hz: {} plans; round trip ms p50 {:.2} p99 {:.2}; compute_ms p50 {:.2} p99 {:.2}; \
                 ingest (10-obstacle snapshot) ms p50 {:.2} p99 {:.2}; server CPU {:.1} ms per flight-second",
                ph.plan_rt_ms.len(),
                pct(&mut ph.plan_rt_ms, 0.5),
                pct(&mut ph.plan_rt_ms, 0.99),
                pct(&mut ph.plan_compute_ms, 0.5),
                pct(&mut ph.plan_compute_ms, 0.99),
                pct(&mut ph.ingest_ms, 0.5),
                pct(&mut ph.ingest_ms, 0.99),
                ph.cpu_s / ph.seconds * 1e3,
            );
            println!(
                "    telemetry (one sample) ms p50 {:.2} p99 {:.2}; floor (GET /healthz between ticks, one database read) ms p50 {:.2} p99 {:.2}",
                pct(&mut ph.telemetry_ms, 0.5),
                pct(&mut ph.telemetry_ms, 0.99),
                pct(&mut ph.floor_ms, 0.5),
                pct(&mut ph.floor_ms, 0.99),
            );
            ph.posts.sort_by(|a, b| b.0.total_cmp(&a.0));
            println!(
                "    slowest posts: {}",
                ph.posts
                    .iter()
                    .take(3)
                    .map(|(ms, tick, what, timing)| format!(
                        "{what} of tick {tick} {ms:.2} ms ({timing})"
                    ))
                    .collect::<Vec<_>>()
                    .join("; ")
            );
            if let Some(f) = &flier {
                println!(
                    "    aircraft {:.0} m east, {:.0} m north of its start, flying to item {} of {}",
                    f.p_m[0],
                    f.p_m[1],
                    f.current,
                    f.stack.len()
                );
            }
            if !ph.plan_phases.is_empty() {
                println!(
                    "    server-side phases (Server-Timing), ms p50/p99: plan {}; ingest {}; {} of {} plans used the map published before the batch just posted",
                    phase_pcts(&mut ph.plan_phases),
                    phase_pcts(&mut ph.ingest_phases),
                    ph.plans_lagging,
                    ph.plan_rt_ms.len()
                );
                if let Some((rt, k, outcome, compute_ms, timing)) = &ph.slowest {
                    println!(
                        "    slowest plan: number {k} of {}, {outcome}, round trip {rt:.2} ms, compute_ms {compute_ms:.2}; Server-Timing {timing}",
                        ph.plan_rt_ms.len()
                    );
                }
                println!(
                    "    plan outcomes (compute_ms p50/p99): {}",
                    ph.plan_outcomes
                        .iter_mut()
                        .map(|(k, ms)| format!(
                            "{k} {} ({:.2}/{:.2})",
                            ms.len(),
                            pct(ms, 0.5),
                            pct(ms, 0.99)
                        ))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
        let rss0 = rss_mb(pid);
        for _ in 0..missions {
            let id = create_webster(&client, &base).await;
            for i in 0..150 {
                let url = format!("{base}/api/v1/missions/{id}/obstacles");
                expect(client.post(url).json(&snapshot(t0 + f64::from(i) * 0.2)), 202).await;
            }
            expect(client.get(format!("{base}/api/v1/missions/{id}/obstacles")), 200).await;
        }
        println!(
            "  {} live missions x 10 obstacles (150 snapshots each): server VmRSS {:.0} MB (before them {rss0:.0} MB)",
            missions + 1,
            rss_mb(pid)
        );
        let r = client.get(format!("{base}/api/v1/missions")).send().await.unwrap();
        let all: Vec<Value> = r.json().await.unwrap();
        for m in &all {
            let url = format!("{base}/api/v1/missions/{}/plan", m["id"].as_str().unwrap());
            expect(client.post(url).json(&json!({"seed": 7, "current_index": 1})), 201).await;
        }
        println!(
            "  the same after one plan each (risk maps built; at most --live-max-maps kept): server VmRSS {:.0} MB",
            rss_mb(pid)
        );
    });
    let _ = child.kill();
    let _ = child.wait();
}
