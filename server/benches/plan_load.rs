//! Plan-load benchmark (issue 9): replays a judge-style flight against a real `jink serve`
//! on loopback, in real time, and reports plan and ingest latencies, server CPU per
//! flight-second, and the resident memory of many live missions.
//!
//! Run: `cargo bench -p server --bench plan_load` (release build). Flight: the Webster Field
//! fixture, 10 spheres flying circles over the field posting an interop-2018 obstacle
//! snapshot (with its `time`) at 5 Hz, aircraft telemetry at 5 Hz, and `POST .../plan`
//! (seeded, default options) at 1 Hz for `JINK_PLAN_SECONDS` (default 20), then at 5 Hz
//! for as long. Then `JINK_PLAN_MISSIONS` (default 100) missions each get 30 s of 10
//! obstacles at 5 Hz (posted as fast as accepted) and one read of their obstacles, which
//! makes them live (predictor, no risk map), and the server's resident memory (VmRSS) is
//! reported; then each gets one plan (which builds its risk map; the server keeps at most
//! `--live-max-maps` of them) and VmRSS is reported again.
//! `JINK_PLAN_DATABASE_URL` overrides the store (default: a fresh SQLite file).
//! Each phase also prints its plans by outcome with their `compute_ms`: the aircraft holds
//! its position while the spheres circle past it, so some plans find no clear route and
//! run the safety net, which takes several times as long.

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
    ingest_ms: Vec<f64>,
    /// The server's `Server-Timing` phases of each ingest, by name.
    ingest_phases: std::collections::BTreeMap<String, Vec<f64>>,
    cpu_s: f64,
    seconds: f64,
}

async fn fly(
    client: &reqwest::Client,
    base: &str,
    id: &str,
    pid: u32,
    t0: f64,
    seconds: u32,
    plan_hz: u32,
) -> Phase {
    let mut ph = Phase {
        plan_rt_ms: Vec::new(),
        plan_compute_ms: Vec::new(),
        plan_phases: std::collections::BTreeMap::new(),
        plans_lagging: 0,
        plan_outcomes: std::collections::BTreeMap::new(),
        ingest_ms: Vec::new(),
        ingest_phases: std::collections::BTreeMap::new(),
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
        let sample = json!({"t": t, "lat": 38.1446916666667 + 0.00001 * f64::from(i % 50), "lon": -76.4279944444445,
                            "alt_msl_m": 60.96, "heading_deg": 60.0, "speed_mps": 20.0});
        expect(
            client
                .post(format!("{base}/api/v1/missions/{id}/telemetry"))
                .json(&sample),
            202,
        )
        .await;
        if i % (5 / plan_hz) == 0 {
            let s = Instant::now();
            let plan = client.post(format!("{base}/api/v1/missions/{id}/plan"));
            let r = expect(plan.json(&json!({"seed": 7, "current_index": 1})), 201).await;
            let timing = server_timing(&r);
            let v: Value = r.json().await.unwrap();
            ph.plan_rt_ms.push(s.elapsed().as_secs_f64() * 1e3);
            let compute_ms = v["compute_ms"].as_f64().unwrap();
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
        println!("plan_load: backend={} flight={seconds} s per phase", db_url.split(':').next().unwrap_or("?"));
        for (k, hz) in [1u32, 5].into_iter().enumerate() {
            let mut ph = fly(&client, &base, &id, pid, t0 + f64::from(k as u32 * seconds), seconds, hz).await;
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
            if !ph.plan_phases.is_empty() {
                println!(
                    "    server-side phases (Server-Timing), ms p50/p99: plan {}; ingest {}; {} of {} plans used the map published before the batch just posted",
                    phase_pcts(&mut ph.plan_phases),
                    phase_pcts(&mut ph.ingest_phases),
                    ph.plans_lagging,
                    ph.plan_rt_ms.len()
                );
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
