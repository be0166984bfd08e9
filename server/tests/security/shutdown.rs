//! SIGTERM during ingest: the service finishes what is in flight, exits 0, and every
//! acknowledged observation is in the database.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::server::{Db, Server, observation};

#[tokio::test]
async fn sigterm_during_ingest_exits_0_and_loses_nothing_acknowledged() {
    let db = Db::sqlite();
    let mut s = Server::start(&db, &["--bind", "127.0.0.1:0"]);
    let id = s.webster(None).await;
    let url = s.url(&format!("/api/v1/missions/{id}/obstacles"));
    let stop = Arc::new(AtomicBool::new(false));
    let writers: Vec<_> = (0..8)
        .map(|w| {
            let (client, url, stop) = (s.client.clone(), url.clone(), stop.clone());
            tokio::spawn(async move {
                let mut acknowledged = 0u64;
                let mut i = 0u32;
                while !stop.load(Ordering::Relaxed) {
                    i += 1;
                    let t = 1_700_000_000.0 + f64::from(i) * 0.01;
                    let rows: Vec<Value> = (0..5)
                        .map(|k| observation(&format!("{w}-{k}"), t))
                        .collect();
                    match client
                        .post(&url)
                        .json(&json!({"observations": rows}))
                        .send()
                        .await
                    {
                        Ok(r) if r.status() == 202 => {
                            let v: Value = r.json().await.unwrap();
                            acknowledged += v["accepted"].as_u64().unwrap();
                        }
                        // Refused or cut off by the shutdown: not acknowledged.
                        _ => break,
                    }
                }
                acknowledged
            })
        })
        .collect();
    tokio::time::sleep(Duration::from_millis(1500)).await;
    s.sigterm();
    let start = Instant::now();
    let status = loop {
        if let Some(st) = s.child.try_wait().unwrap() {
            break st;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "jink did not exit within 20 s of SIGTERM"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    stop.store(true, Ordering::Relaxed);
    let mut acknowledged = 0;
    for w in writers {
        acknowledged += w.await.unwrap();
    }
    assert!(
        status.success(),
        "exit status {status:?}; log:\n{}",
        s.log()
    );
    assert!(acknowledged > 0);
    drop(s);
    let again = Server::start(&db, &["--bind", "127.0.0.1:0"]);
    let stored: Value = again
        .get_json(&format!("/api/v1/missions/{id}/observations"), None)
        .await;
    assert_eq!(stored.as_array().unwrap().len() as u64, acknowledged);
}
