//! Load benchmark: posts batches of 10 obstacle observations to a real `jink serve` on
//! loopback and reports observations durably ingested per second and request latency.
//!
//! Run: `cargo bench -p server --bench ingest_load` (release build). Knobs (environment):
//! `JINK_LOAD_SECONDS` (default 10), `JINK_LOAD_CONCURRENCY` (in-flight requests,
//! default 32), `JINK_LOAD_DATABASE_URL` (default: a fresh SQLite file in a temp dir).
//!
//! "Durably ingested" means acknowledged with 202 and counted as `accepted`; the count is
//! checked against what the database holds at the end.

// Each bench uses part of the shared support.
#[allow(dead_code)]
mod support;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use support::{create_webster, database_url, env_or, expect, spawn_jink};

use serde_json::{Value, json};

fn main() {
    let seconds: u64 = env_or("JINK_LOAD_SECONDS", 10);
    let concurrency: usize = env_or("JINK_LOAD_CONCURRENCY", 32);
    let (_dir, db_url) = database_url("JINK_LOAD_DATABASE_URL", "load.sqlite");

    let (mut child, base) = spawn_jink(&db_url);

    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let (sent, accepted, lat_us, worst, stored) = rt.block_on(async move {
        let client = reqwest::Client::builder().pool_max_idle_per_host(concurrency).build().unwrap();
        let id = create_webster(&client, &base).await;
        let url = Arc::new(format!("{base}/api/v1/missions/{id}/obstacles"));
        let seq = Arc::new(AtomicU64::new(0));
        let accepted = Arc::new(AtomicU64::new(0));
        let began = Instant::now();
        let deadline = began + Duration::from_secs(seconds);
        let mut tasks = Vec::new();
        for _ in 0..concurrency {
            let (client, url, seq, accepted) = (client.clone(), url.clone(), seq.clone(), accepted.clone());
            tasks.push(tokio::spawn(async move {
                let mut lat = Vec::new();
                // The slowest request: (µs, seconds into the run when it was sent).
                let mut worst = (0u64, 0.0f64);
                let mut sent = 0u64;
                while Instant::now() < deadline {
                    let n = seq.fetch_add(1, Ordering::Relaxed);
                    // Ten obstacles, one observation each, at a fresh 0.1 s tick.
                    let t = 1_700_000_000.0 + n as f64 * 0.1;
                    let obs: Vec<Value> = (0..10)
                        .map(|k| {
                            json!({"obstacle_id": k.to_string(), "t": t, "lat": 38.145 + f64::from(k) * 1e-4,
                                "lon": -76.43, "alt_msl_m": 80.0, "radius_m": 15.0})
                        })
                        .collect();
                    let body = serde_json::to_vec(&json!({ "observations": obs })).unwrap();
                    let start = Instant::now();
                    let r = expect(
                        client.post(url.as_str()).header("content-type", "application/json").body(body),
                        202,
                    )
                    .await;
                    let v: Value = r.json().await.unwrap();
                    lat.push(start.elapsed().as_micros() as u64);
                    if *lat.last().unwrap() > worst.0 {
                        worst = (*lat.last().unwrap(), start.duration_since(began).as_secs_f64());
                    }
                    accepted.fetch_add(v["accepted"].as_u64().unwrap(), Ordering::Relaxed);
                    sent += 10;
                }
                (sent, lat, worst)
            }));
        }
        let mut sent = 0;
        let mut lat = Vec::new();
        let mut worst = (0u64, 0.0f64);
        for t in tasks {
            let (s, l, w) = t.await.unwrap();
            sent += s;
            lat.extend(l);
            if w.0 > worst.0 {
                worst = w;
            }
        }
        let stored = client
            .get(format!("{base}/api/v1/missions/{id}/observations"))
            .send()
            .await
            .unwrap()
            .json::<Vec<Value>>()
            .await
            .unwrap()
            .len() as u64;
        (sent, accepted.load(Ordering::Relaxed), lat, worst, stored)
    });
    let _ = child.kill();
    let _ = child.wait();

    let mut lat = lat_us;
    lat.sort_unstable();
    let pct = |p: f64| lat[((lat.len() as f64 - 1.0) * p).round() as usize] as f64 / 1000.0;
    let rate = accepted as f64 / seconds as f64;
    println!(
        "ingest_load: backend={} concurrency={concurrency} seconds={seconds}",
        db_url.split(':').next().unwrap_or("?")
    );
    println!(
        "  requests: {} (batches of 10), observations sent: {sent}, accepted: {accepted}, stored: {stored}",
        lat.len()
    );
    println!("  throughput: {rate:.0} observations/s durably ingested");
    println!(
        "  latency ms: p50 {:.2}  p90 {:.2}  p99 {:.2}  max {:.2} (sent {:.2} s into the run)",
        pct(0.5),
        pct(0.9),
        pct(0.99),
        pct(1.0),
        worst.1
    );
    assert_eq!(
        accepted, stored,
        "every acknowledged observation must be in the database"
    );
}
