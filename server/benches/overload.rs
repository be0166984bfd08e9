//! Overload benchmark (issue 12): many ground stations on loopback at once against a real
//! `jink serve`, with and without tokens.
//!
//! Run: `cargo bench -p server --bench overload` (release build). Each of
//! `JINK_OVERLOAD_CLIENTS` (default 200) clients posts aircraft telemetry at 5 Hz and a
//! native obstacle snapshot (3 observations) at 1 Hz to one of `JINK_OVERLOAD_MISSIONS`
//! (default 10) missions, and requests plans (`deadline_ms` 200) one after another as fast
//! as they are answered, waiting `Retry-After` after a 503 or 429 as a client should. A
//! probe GETs `/healthz` every second. Before the clock starts, the clients' connections
//! are opened (two each, by concurrent `GET /healthz`; `JINK_OVERLOAD_WARMUP=0` leaves that
//! to the first requests, so second 0 then includes opening ~400 connections on the load
//! generator's one thread). The run lasts `JINK_OVERLOAD_SECONDS` (default 60,
//! or `--duration SECONDS`) and is done twice: without tokens (loopback, `local`), then
//! with one write token per client (`--auth on`), unless `JINK_OVERLOAD_AUTH` is `off` or
//! `on` (one run).
//!
//! Reported per run: statuses by kind (any 5xx other than 503 with `Retry-After` fails the
//! run), ingest latency p50/p99/max overall, the worst per-second p99 and the seconds whose
//! p99 is over 50 ms (`second:p99`, with that second's p99 inside the server's handlers),
//! the time ingest requests spent in the server's handlers (their `Server-Timing` phases),
//! plans computed
//! and refused, `/healthz` latency (worst, and seconds over 100 ms), the server's resident
//! memory (peak and at the end), the SQLite WAL file's size (peak, at the end, and every
//! 10 s), ingest throughput, and the observations acknowledged
//! against those counted in the database afterwards (must be equal).

#[allow(dead_code)]
mod support;

use std::collections::BTreeMap;
use std::process::Command;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use support::{env_or, rss_mb, spawn_jink_with as spawn};

fn jink_token(db_url: &str, name: &str, role: &str) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_jink"))
        .args([
            "token",
            "create",
            "--name",
            name,
            "--role",
            role,
            "--database-url",
            db_url,
        ])
        .output()
        .expect("jink token create");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap().trim().to_string()
}

#[derive(Default)]
struct Tally {
    /// (second of the run, latency ms) of each ingest request.
    ingest: Vec<(u64, f64)>,
    /// `Server-Timing` phases of the ingest answers, by "what phase" (e.g. "obstacles
    /// store"), ms; "what total" is their sum.
    ingest_phases: BTreeMap<String, Vec<f64>>,
    /// (second of the run, the handler's own total ms) of each ingest answer, to tell time
    /// spent in the server's handlers from time spent before them (connections, HTTP,
    /// scheduling, the load generator itself).
    ingest_server: Vec<(u64, f64)>,
    statuses: BTreeMap<String, u64>,
    bad: Vec<String>,
    plans_ok: u64,
    plans_refused: u64,
    acknowledged: u64,
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 - 1.0) * p).round() as usize]
}

/// The size of `path` in MB (0 when it does not exist).
fn file_mb(path: &std::path::Path) -> f64 {
    std::fs::metadata(path).map_or(0.0, |m| m.len() as f64 / 1e6)
}

fn run(auth: bool, seconds: u64, clients: usize, missions: usize) {
    let dir = tempfile::tempdir().unwrap();
    let db_url = format!("sqlite://{}", dir.path().join("overload.sqlite").display());
    let wal = dir.path().join("overload.sqlite-wal");
    let mut tokens = Vec::new();
    let admin = if auth {
        let admin = jink_token(&db_url, "bench-admin", "admin");
        for c in 0..clients {
            tokens.push(Some(jink_token(&db_url, &format!("gcs-{c}"), "write")));
        }
        Some(admin)
    } else {
        tokens.resize(clients, None);
        None
    };
    let extra: &[&str] = if auth { &["--auth", "on"] } else { &[] };
    let (mut child, base) = spawn(&db_url, extra);
    let pid = child.id();

    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let tally = Arc::new(Mutex::new(Tally::default()));
    let warm = env_or("JINK_OVERLOAD_WARMUP", 1u32) != 0;
    let (health, memory, stored, elapsed, warmup, wal_metrics) = rt.block_on({
        let tally = tally.clone();
        let wal = wal.clone();
        async move {
            let client = reqwest::Client::builder()
                .pool_max_idle_per_host(4 * clients)
                // Below the server's 10 s idle limit (`--header-read-timeout-s`): a client
                // that keeps an idle connection longer races the server closing it, and a
                // request sent at that moment fails with a connection error.
                .pool_idle_timeout(Duration::from_secs(5))
                .timeout(Duration::from_secs(120))
                .build()
                .unwrap();
            let mission_text = std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../tests/fixtures/interop/mission_2021_webster_field.json"
            ))
            .unwrap();
            let mut ids = Vec::new();
            for _ in 0..missions {
                let mut r = client
                    .post(format!("{base}/api/v1/missions"))
                    .header("content-type", "application/json")
                    .body(mission_text.clone());
                if let Some(a) = &admin {
                    r = r.bearer_auth(a);
                }
                let v: Value = r.send().await.unwrap().json().await.unwrap();
                ids.push(v["id"].as_str().unwrap().to_string());
            }
            // Before the clock, as every ground station holds its connection open: all
            // the clients' connections (two each, ingest and plans) opened at once by as
            // many concurrent `GET /healthz`. With `JINK_OVERLOAD_WARMUP=0` they are opened
            // by the first requests instead, all in the first millisecond, on this load
            // generator's one thread, and second 0's latency is mostly that.
            let warmup = if warm {
                let t0 = Instant::now();
                let probes: Vec<_> = (0..2 * clients)
                    .map(|_| {
                        let (client, url) = (client.clone(), format!("{base}/healthz"));
                        tokio::spawn(async move {
                            let sent = Instant::now();
                            let ok = client.get(url).send().await.is_ok_and(|r| r.status() == 200);
                            (ok, sent.elapsed().as_secs_f64() * 1e3)
                        })
                    })
                    .collect();
                let (mut ok, mut worst) = (0usize, 0.0f64);
                for p in probes {
                    let (good, ms) = p.await.unwrap();
                    ok += usize::from(good);
                    worst = worst.max(ms);
                }
                Some((ok, worst, t0.elapsed().as_secs_f64() * 1e3))
            } else {
                None
            };
            let start = Instant::now();
            let deadline = start + Duration::from_secs(seconds);
            let mut tasks = Vec::new();
            for (c, token) in tokens.into_iter().enumerate() {
                let m = &ids[c % missions];
                let base_m = format!("{base}/api/v1/missions/{m}");
                // Ingest: telemetry at 5 Hz, an obstacle snapshot every fifth tick.
                {
                    let (client, token, tally, base_m) =
                        (client.clone(), token.clone(), tally.clone(), base_m.clone());
                    tasks.push(tokio::spawn(async move {
                        let mut tick = tokio::time::interval(Duration::from_millis(200));
                        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
                        let mut k = 0u64;
                        while Instant::now() < deadline {
                            tick.tick().await;
                            k += 1;
                            // Distinct times per client: nothing is a duplicate.
                            let t = 1_700_000_000.0 + k as f64 * 0.2 + c as f64 * 1e-4;
                            let mut reqs = vec![(
                                "telemetry",
                                json!({"t": t, "lat": 38.1447, "lon": -76.428, "alt_msl_m": 61.0, "heading_deg": 60.0, "speed_mps": 20.0}),
                            )];
                            if k.is_multiple_of(5) {
                                let obs: Vec<Value> = (0..3)
                                    .map(|o| json!({"obstacle_id": format!("{}", o + 3 * (c % 3)), "t": t,
                                        "lat": 38.1455 + o as f64 * 1e-4, "lon": -76.4245 + (k as f64) * 1e-5,
                                        "alt_msl_m": 60.0, "radius_m": 20.0}))
                                    .collect();
                                reqs.push(("obstacles", json!({"observations": obs})));
                            }
                            for (what, body) in reqs {
                                let mut r = client.post(format!("{base_m}/{what}")).json(&body);
                                if let Some(t) = &token {
                                    r = r.bearer_auth(t);
                                }
                                let sent = Instant::now();
                                let resp = r.send().await;
                                let ms = sent.elapsed().as_secs_f64() * 1e3;
                                let sec = sent.duration_since(start).as_secs();
                                // Read the answer before taking the tally's lock.
                                let answer = match resp {
                                    Ok(resp) => {
                                        let st = resp.status().as_u16();
                                        let server_ms: Vec<(String, f64)> = resp
                                            .headers()
                                            .get("server-timing")
                                            .and_then(|h| h.to_str().ok())
                                            .unwrap_or_default()
                                            .split(", ")
                                            .filter_map(|p| {
                                                let (name, dur) = p.split_once(";dur=")?;
                                                Some((name.to_string(), dur.parse::<f64>().ok()?))
                                            })
                                            .collect();
                                        let accepted = if st == 202 && what == "obstacles" {
                                            let v: Value = resp.json().await.unwrap_or_default();
                                            v["accepted"].as_u64().unwrap_or(0)
                                        } else {
                                            0
                                        };
                                        Ok((st, accepted, server_ms))
                                    }
                                    Err(e) => Err(e.to_string()),
                                };
                                let mut t = tally.lock().unwrap();
                                match answer {
                                    Ok((st, accepted, server_ms)) => {
                                        *t.statuses.entry(format!("{what} {st}")).or_default() += 1;
                                        if st == 202 {
                                            t.ingest.push((sec, ms));
                                            if !server_ms.is_empty() {
                                                let total = server_ms.iter().map(|p| p.1).sum();
                                                t.ingest_phases.entry(format!("{what} total")).or_default().push(total);
                                                t.ingest_server.push((sec, total));
                                            }
                                            for (name, ms) in server_ms {
                                                t.ingest_phases.entry(format!("{what} {name}")).or_default().push(ms);
                                            }
                                            t.acknowledged += accepted;
                                        } else {
                                            t.bad.push(format!("{what} {st}"));
                                        }
                                    }
                                    Err(e) => t.bad.push(format!("{what}: {e}")),
                                }
                            }
                        }
                    }));
                }
                // Plans, one after another.
                {
                    let (client, token, tally) = (client.clone(), token.clone(), tally.clone());
                    tasks.push(tokio::spawn(async move {
                        while Instant::now() < deadline {
                            let mut r = client
                                .post(format!("{base_m}/plan"))
                                .json(&json!({"deadline_ms": 200}));
                            if let Some(t) = &token {
                                r = r.bearer_auth(t);
                            }
                            let resp = r.send().await;
                            let mut wait = Duration::ZERO;
                            {
                                let mut t = tally.lock().unwrap();
                                match resp {
                                    Ok(resp) => {
                                        let st = resp.status().as_u16();
                                        let retry = resp
                                            .headers()
                                            .get("retry-after")
                                            .and_then(|v| v.to_str().ok()?.parse::<u64>().ok());
                                        *t.statuses.entry(format!("plan {st}")).or_default() += 1;
                                        match (st, retry) {
                                            (201, _) => t.plans_ok += 1,
                                            // A stale revision raced by another client of the mission.
                                            (409, _) => {}
                                            (503 | 429, Some(s)) => {
                                                t.plans_refused += 1;
                                                wait = Duration::from_secs(s);
                                            }
                                            _ => t.bad.push(format!("plan {st} (Retry-After {retry:?})")),
                                        }
                                    }
                                    Err(e) => t.bad.push(format!("plan: {e}")),
                                }
                            }
                            if !wait.is_zero() {
                                tokio::time::sleep(wait.min(deadline.saturating_duration_since(Instant::now()))).await;
                            }
                        }
                    }));
                }
            }
            // The probe: /healthz, the server's memory and the SQLite WAL's size every
            // second.
            let probe = {
                let client = client.clone();
                let base = base.clone();
                tokio::spawn(async move {
                    let mut health = Vec::new();
                    let mut memory = Vec::new();
                    let mut tick = tokio::time::interval(Duration::from_secs(1));
                    while Instant::now() < deadline {
                        tick.tick().await;
                        let sent = Instant::now();
                        let ok = client
                            .get(format!("{base}/healthz"))
                            .send()
                            .await
                            .is_ok_and(|r| r.status() == 200);
                        health.push((ok, sent.elapsed().as_secs_f64() * 1e3));
                        memory.push((rss_mb(pid), file_mb(&wal)));
                    }
                    (health, memory)
                })
            };
            for t in tasks {
                t.await.unwrap();
            }
            let elapsed = start.elapsed().as_secs_f64();
            let (health, memory) = probe.await.unwrap();
            let mut stored = 0u64;
            for m in &ids {
                let mut r = client.get(format!("{base}/api/v1/missions/{m}/observations"));
                if let Some(a) = &admin {
                    r = r.bearer_auth(a);
                }
                stored += r.send().await.unwrap().json::<Vec<Value>>().await.unwrap().len() as u64;
            }
            // What the server says of its SQLite WAL's checkpoints.
            let mut r = client.get(format!("{base}/metrics"));
            if let Some(a) = &admin {
                r = r.bearer_auth(a);
            }
            let wal_metrics: Vec<String> = r
                .send()
                .await
                .unwrap()
                .text()
                .await
                .unwrap()
                .lines()
                .filter(|l| l.starts_with("jink_sqlite_"))
                .map(str::to_string)
                .collect();
            (health, memory, stored, elapsed, warmup, wal_metrics)
        }
    });
    let (final_rss, final_wal) = (rss_mb(pid), file_mb(&wal));
    let _ = child.kill();
    let _ = child.wait();

    let mut t = tally.lock().unwrap();
    let mut all: Vec<f64> = t.ingest.iter().map(|(_, ms)| *ms).collect();
    let n_ingest = all.len();
    let mut by_sec: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for (s, ms) in &t.ingest {
        by_sec.entry(*s).or_default().push(*ms);
    }
    let sec_p99: Vec<(u64, f64)> = by_sec.iter_mut().map(|(s, v)| (*s, pct(v, 0.99))).collect();
    let worst_sec_p99 = sec_p99.iter().map(|x| x.1).fold(0.0, f64::max);
    let mut server_by_sec: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for (s, ms) in &t.ingest_server {
        server_by_sec.entry(*s).or_default().push(*ms);
    }
    // The seconds whose ingest p99 is over the 50 ms, as `second:p99`, followed by
    // that second's p99 inside the server's handlers (`Server-Timing`).
    let over_50: Vec<String> = sec_p99
        .iter()
        .filter(|x| x.1 > 50.0)
        .map(|(s, p)| {
            let inside = server_by_sec.get_mut(s).map_or(0.0, |v| pct(v, 0.99));
            format!("{s}:{p:.0} (handlers {inside:.0})")
        })
        .collect();
    let health_worst = health.iter().map(|h| h.1).fold(0.0, f64::max);
    let health_slow = health.iter().filter(|h| !h.0 || h.1 > 100.0).count();
    let rss_peak = memory.iter().map(|x| x.0).fold(0.0, f64::max);
    let wal_peak = memory.iter().map(|x| x.1).fold(0.0, f64::max);
    println!(
        "overload: auth={} clients={clients} missions={missions} seconds={seconds}",
        if auth {
            "on (one write token per client)"
        } else {
            "off (loopback, local)"
        }
    );
    match warmup {
        Some((ok, worst, all)) => println!(
            "  connections opened before the clock: {} concurrent GET /healthz, {ok} answered 200, all in {all:.1} ms (slowest {worst:.1} ms)",
            2 * clients
        ),
        None => println!(
            "  connections opened by the first requests (JINK_OVERLOAD_WARMUP=0): second 0 includes opening them"
        ),
    }
    println!("  statuses: {:?}", t.statuses);
    println!(
        "  ingest: {n_ingest} requests acknowledged ({:.0}/s); latency ms p50 {:.1}  p99 {:.1}  max {:.1}; worst per-second p99 {:.1}; {} of {} seconds over 50 ms [{}]",
        n_ingest as f64 / elapsed,
        pct(&mut all, 0.5),
        pct(&mut all, 0.99),
        pct(&mut all, 1.0),
        worst_sec_p99,
        over_50.len(),
        sec_p99.len(),
        over_50.join(" ")
    );
    let phases: Vec<String> = t
        .ingest_phases
        .iter_mut()
        .map(|(k, v)| {
            format!(
                "{k} {:.2}/{:.2}/{:.2}",
                pct(v, 0.5),
                pct(v, 0.99),
                pct(v, 1.0)
            )
        })
        .collect();
    println!(
        "  ingest in the server's handlers (Server-Timing), ms p50/p99/max: {}",
        phases.join(", ")
    );
    println!(
        "  plans: {} computed, {} refused with Retry-After (503/429)",
        t.plans_ok, t.plans_refused
    );
    println!(
        "  /healthz: {} probes, worst {:.1} ms, {} over 100 ms or failed",
        health.len(),
        health_worst,
        health_slow
    );
    println!("  server memory (VmRSS): peak {rss_peak:.0} MB, at the end {final_rss:.0} MB");
    println!(
        "  SQLite WAL file: peak {wal_peak:.1} MB, at the end {final_wal:.1} MB (every 10 s: {})",
        memory
            .iter()
            .step_by(10)
            .map(|x| format!("{:.0}", x.1))
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "  SQLite checkpoints (GET /metrics): {}",
        wal_metrics.join("; ")
    );
    println!(
        "  observations: {} acknowledged, {} stored",
        t.acknowledged, stored
    );
    t.bad.sort();
    t.bad.dedup();
    if !t.bad.is_empty() {
        println!("  unexpected answers: {:?}", &t.bad[..t.bad.len().min(10)]);
    }
    assert!(
        t.bad.is_empty(),
        "answers other than 2xx, 409, 503/429 with Retry-After"
    );
    assert_eq!(t.acknowledged, stored, "acknowledged observations lost");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let from_flag = args
        .iter()
        .position(|a| a == "--duration")
        .and_then(|i| args.get(i + 1)?.parse().ok());
    let seconds: u64 = from_flag.unwrap_or_else(|| env_or("JINK_OVERLOAD_SECONDS", 60));
    let clients: usize = env_or("JINK_OVERLOAD_CLIENTS", 200);
    let missions: usize = env_or("JINK_OVERLOAD_MISSIONS", 10).max(1);
    let which = std::env::var("JINK_OVERLOAD_AUTH").unwrap_or_default();
    if which != "on" {
        run(false, seconds, clients, missions);
    }
    if which != "off" {
        run(true, seconds, clients, missions);
    }
}
