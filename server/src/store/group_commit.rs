//! Group commit of observation batches on SQLite.
//!
//! SQLite has one writer, so concurrent batches queue for the single write connection
//! anyway; each paid its own `BEGIN`, mission-counter bump, insert and `COMMIT`. Here one
//! task owns the queue: it takes every batch waiting (up to [`MAX_GROUP`]) and stores them
//! in one transaction ([`Store::commit_batches`]), one counter bump and one multi-row
//! insert per mission, then answers each request. A lone batch goes at once (no waiting
//! for company), so a quiet mission's latency is a single transaction as before.
//!
//! Contracts kept from one transaction per batch:
//! - each batch is all or none, and is acknowledged only after its commit;
//! - batches of a mission take consecutive sequence numbers in arrival order, and a row
//!   already stored (by an earlier batch, also one earlier in the same group) is a
//!   duplicate: the first one wins;
//! - if a group's transaction fails, its batches are retried one transaction each, so a
//!   failure is reported to the batch that caused it only.

use tokio::sync::{mpsc, oneshot};

use super::observations::{NewBatch, StoredBatch};
use super::{ObservationRow, Store};

/// Most batches stored in one transaction.
pub const MAX_GROUP: usize = 64;

type Reply = oneshot::Sender<Result<Option<StoredBatch>, sqlx::Error>>;

struct Job {
    mission_id: String,
    rows: Vec<ObservationRow>,
    received_at_s: f64,
    writer: String,
    reply: Reply,
}

impl Job {
    fn batch(&self) -> NewBatch<'_> {
        NewBatch {
            mission_id: &self.mission_id,
            rows: &self.rows,
            received_at_s: self.received_at_s,
            writer: &self.writer,
        }
    }
}

/// The queue of the group-commit task.
#[derive(Debug, Clone)]
pub struct GroupCommit {
    tx: mpsc::Sender<Job>,
}

impl GroupCommit {
    /// Starts the task writing through `store` (which must not itself group).
    pub fn spawn(store: Store) -> Self {
        let (tx, rx) = mpsc::channel(4 * MAX_GROUP);
        tokio::spawn(run(store, rx));
        Self { tx }
    }

    /// Stores one batch (see [`Store::insert_observations`]); `None` when the task has
    /// stopped (the caller then writes directly).
    pub async fn submit(
        &self,
        mission_id: &str,
        rows: &[ObservationRow],
        received_at_s: f64,
        writer: &str,
    ) -> Option<Result<Option<StoredBatch>, sqlx::Error>> {
        let (reply, answer) = oneshot::channel();
        let job = Job {
            mission_id: mission_id.to_string(),
            rows: rows.to_vec(),
            received_at_s,
            writer: writer.to_string(),
            reply,
        };
        self.tx.send(job).await.ok()?;
        answer.await.ok()
    }
}

async fn run(store: Store, mut rx: mpsc::Receiver<Job>) {
    let mut jobs: Vec<Job> = Vec::with_capacity(MAX_GROUP);
    while let Some(first) = rx.recv().await {
        jobs.push(first);
        while jobs.len() < MAX_GROUP {
            match rx.try_recv() {
                Ok(j) => jobs.push(j),
                Err(_) => break,
            }
        }
        let batches: Vec<NewBatch<'_>> = jobs.iter().map(Job::batch).collect();
        let result = store.commit_batches(&batches).await;
        drop(batches);
        match result {
            Ok(out) => {
                for (j, o) in jobs.drain(..).zip(out) {
                    let _ = j.reply.send(Ok(o));
                }
            }
            Err(e) if jobs.len() == 1 => {
                let _ = jobs.pop().map(|j| j.reply.send(Err(e)));
            }
            Err(e) => {
                tracing::warn!(error = %e, batches = jobs.len(), "group commit failed; storing its batches one by one");
                for j in jobs.drain(..) {
                    let r = store
                        .commit_batches(&[j.batch()])
                        .await
                        .map(|mut v| v.pop().flatten());
                    let _ = j.reply.send(r);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::Mission;

    fn row(id: &str, t_s: f64, lat_deg: f64) -> ObservationRow {
        ObservationRow {
            obstacle_id: id.into(),
            t_s,
            lat_deg,
            lon_deg: -76.43,
            alt_msl_m: 60.0,
            radius_m: 10.0,
        }
    }

    async fn store_with_webster(dir: &tempfile::TempDir) -> Store {
        let url = format!("sqlite://{}", dir.path().join("g.sqlite").display());
        let store = Store::open(&url).await.expect("open");
        let text = include_str!("../../../tests/fixtures/interop/mission_2021_webster_field.json");
        let m: Mission = wire::domain::read_mission_text(text, "webster").expect("fixture");
        store.insert_missions(&[m], 0.0).await.expect("mission");
        store
    }

    #[tokio::test]
    async fn one_transaction_numbers_batches_in_order_and_the_first_copy_of_a_row_wins() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let a = [row("0", 1.0, 38.1), row("1", 1.0, 38.1)];
        // ("0", 1.0) again with another position: a duplicate of `a`'s row.
        let b = [row("0", 1.0, 38.2), row("0", 2.0, 38.2)];
        let c = [row("0", 3.0, 38.3)];
        let batch = |mission_id, rows| NewBatch {
            mission_id,
            rows,
            received_at_s: 10.0,
            writer: "local",
        };
        let out = store
            .commit_batches(&[
                batch("webster", &a),
                batch("nope", &c),
                batch("webster", &b),
            ])
            .await
            .expect("commit");
        let (first, third) = (out[0].as_ref().expect("a"), out[2].as_ref().expect("b"));
        assert!(out[1].is_none(), "no such mission");
        assert_eq!(
            (first.seq, first.counts.accepted, first.counts.duplicate),
            (1, 2, 0)
        );
        assert_eq!(
            (third.seq, third.counts.accepted, third.counts.duplicate),
            (2, 1, 1)
        );
        assert_eq!(third.stored, [row("0", 2.0, 38.2)]);
        let id = wire::ids::MissionId::from("webster");
        let zero = store
            .list_observations(&id, Some("0"), None)
            .await
            .expect("list");
        assert_eq!(zero, [row("0", 1.0, 38.1), row("0", 2.0, 38.2)]);
        assert_eq!(
            store.observation_seq("webster").await.expect("seq"),
            Some(2)
        );
    }

    #[tokio::test]
    async fn concurrent_batches_through_the_queue_each_get_their_own_number() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let tasks: Vec<_> = (0..24)
            .map(|i| {
                let store = store.clone();
                tokio::spawn(async move {
                    let rows = [
                        row("5", f64::from(i), 38.1),
                        row("6", f64::from(i % 4), 38.1),
                    ];
                    store.insert_observations("webster", &rows, 11.0).await
                })
            })
            .collect();
        let mut seqs = Vec::new();
        let mut accepted = 0;
        for t in tasks {
            let b = t
                .await
                .expect("task")
                .expect("insert")
                .expect("mission exists");
            seqs.push(b.seq);
            accepted += b.counts.accepted;
        }
        seqs.sort_unstable();
        assert_eq!(seqs, (1..=24).collect::<Vec<i64>>());
        // 24 rows of "5", and "6" at 4 distinct times.
        assert_eq!(accepted, 28);
        let rows = store
            .list_observations_through("webster", 0, 24)
            .await
            .expect("rows");
        assert_eq!(rows.len(), 28);
    }
}
