//! Group commit of observation batches and aircraft telemetry on SQLite.
//!
//! SQLite has one writer, so concurrent writes queue for the single write connection
//! anyway; each paid its own statements, `BEGIN` and `COMMIT`, and every statement is a
//! round trip to the connection's thread (under load, a wait for a core each way). Here
//! one task owns the queue: it takes every write waiting (up to [`MAX_GROUP`]) and stores
//! them in one transaction ([`Store::commit_group`]): one statement bumps the batch
//! counters of all the group's missions, one multi-row insert stores all their
//! observations and one all the telemetry posts' samples (up to 256 rows a statement),
//! then each request is answered. A group of batches alone goes to SQLite as one script
//! (`BEGIN`, the bump, the insert, `COMMIT`: [`Store::commit_script`]), one round trip.
//! Telemetry posts that come without batches need no transaction: they are stored with
//! one statement per [`TELEMETRY_CHUNK_ROWS`] rows, never splitting a post
//! ([`Store::commit_posts`]): one round trip instead of `BEGIN`, a lookup of the missions,
//! the insert and `COMMIT`. A lone write goes at once (no waiting
//! for company), so a quiet mission's latency is a single transaction as before. The task
//! runs on the database writer's runtime ([`super::writer`]).
//!
//! A lone observation batch does not go through the task at all: when no request is queued
//! or being stored ([`GroupCommit::try_lone`]), the request's own task stores it, the same
//! script as a group of one ([`Store::commit_script`]). That skips two of the four thread
//! hand-offs (to the writer's runtime and back), the most of a flight's ingest time that was
//! not SQLite's own. Requests arriving meanwhile queue for the task as before, which waits
//! for the connection; the contracts below hold either way.
//!
//! Plans go through the same queue: the plans of a group are stored after its ingest, by
//! one multi-row insert ([`Store::commit_plans`]), so they share one commit. Each plan is
//! several pages (its row, its inputs and answer, two index entries), and under a flood of
//! plan requests one commit per plan was most of what the WAL had to take.
//!
//! Contracts kept from one transaction per request:
//! - each batch or telemetry post is all or none, and is acknowledged only after its
//!   commit;
//! - batches of a mission take consecutive sequence numbers in arrival order, and a row
//!   already stored (by an earlier request, also one earlier in the same group) is a
//!   duplicate: the first one wins;
//! - a request for a mission that does not exist gets `None` (404) and does not disturb
//!   the others;
//! - if a group's transaction fails, its requests are retried one transaction each, so a
//!   failure is reported to the request that caused it only;
//! - a plan is stored only at a revision still free: of two plans for one revision in the
//!   same group the first wins and the other is told the revision was taken (409), as if
//!   each had been its own transaction.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use sqlx::{AssertSqlSafe, Row};
use tokio::sync::{mpsc, oneshot};

use super::observations::{NewBatch, NewRows, StoredBatch};
use super::plans::{InsertPlanError, PlanRow};
use super::writer::WriterThread;
use super::{
    InsertCounts, ObservationRow, Store, TELEMETRY_COLUMNS, TELEMETRY_INSERT, TelemetryRow,
    bind_telemetry, values_sql_anonymous,
};
use crate::time::to_us;

/// Most requests stored in one transaction.
pub const MAX_GROUP: usize = 64;

/// Telemetry rows per insert statement (9 parameters each, anonymous placeholders: see
/// [`super::observations::SQLITE_INSERT_CHUNK_ROWS`]).
pub(super) const TELEMETRY_CHUNK_ROWS: usize = super::observations::SQLITE_INSERT_CHUNK_ROWS;

type Reply<T> = oneshot::Sender<Result<T, sqlx::Error>>;

/// One telemetry post to store (see [`Store::commit_group`]).
pub type NewTelemetry<'a> = NewRows<'a, TelemetryRow>;

struct Request<R, T> {
    mission_id: String,
    rows: Vec<R>,
    received_at_s: f64,
    writer: String,
    reply: Reply<T>,
}

impl<R: Clone, T> Request<R, T> {
    fn new(
        mission_id: &str,
        rows: &[R],
        received_at_s: f64,
        writer: &str,
        reply: Reply<T>,
    ) -> Self {
        Self {
            mission_id: mission_id.to_string(),
            rows: rows.to_vec(),
            received_at_s,
            writer: writer.to_string(),
            reply,
        }
    }

    fn rows(&self) -> NewRows<'_, R> {
        NewRows {
            mission_id: &self.mission_id,
            rows: &self.rows,
            received_at_s: self.received_at_s,
            writer: &self.writer,
        }
    }
}

type BatchJob = Request<ObservationRow, Option<StoredBatch>>;
type TelemetryJob = Request<TelemetryRow, Option<InsertCounts>>;

type PlanReply = oneshot::Sender<Result<(), InsertPlanError>>;

/// One plan to store (see [`Store::commit_plans`]).
struct PlanJob {
    row: PlanRow,
    reply: PlanReply,
}

/// A group's plans: their rows (one statement's worth) and, in the same order, whom to
/// answer.
#[derive(Default)]
struct Plans {
    rows: Vec<PlanRow>,
    replies: Vec<PlanReply>,
}

enum Job {
    Batch(BatchJob),
    Telemetry(TelemetryJob),
    Plan(PlanJob),
}

/// The queue of the group-commit task.
#[derive(Debug, Clone)]
pub struct GroupCommit {
    tx: mpsc::Sender<Job>,
    /// Requests sent to the task and not yet answered, plus lone writes in flight.
    outstanding: Arc<AtomicUsize>,
    /// Batches stored as lone writes, without the task.
    lone: Arc<AtomicU64>,
}

/// A write counted as outstanding while it lives: a request sent to the task, or a lone
/// write in flight ([`GroupCommit::try_lone`], while it lives every other write goes
/// through the task).
pub struct Outstanding<'a> {
    outstanding: &'a AtomicUsize,
}

impl Drop for Outstanding<'_> {
    fn drop(&mut self) {
        self.outstanding.fetch_sub(1, Ordering::AcqRel);
    }
}

impl GroupCommit {
    /// Starts the task writing through `store` (which must not itself group), on the
    /// database writer's runtime ([`super::writer`]).
    pub fn spawn(store: Store, on: &WriterThread) -> Self {
        let (tx, rx) = mpsc::channel(4 * MAX_GROUP);
        on.spawn_task(run(store, rx));
        Self {
            tx,
            outstanding: Arc::new(AtomicUsize::new(0)),
            lone: Arc::new(AtomicU64::new(0)),
        }
    }

    /// The right to store one write directly, when nothing else is queued or being stored
    /// (`None` otherwise: then [`GroupCommit::submit`]). Counted in
    /// [`GroupCommit::lone_writes`].
    pub fn try_lone(&self) -> Option<Outstanding<'_>> {
        self.outstanding
            .compare_exchange(0, 1, Ordering::AcqRel, Ordering::Acquire)
            .ok()?;
        self.lone.fetch_add(1, Ordering::Relaxed);
        Some(Outstanding {
            outstanding: &self.outstanding,
        })
    }

    /// Counts a request sent to the task until it is answered, cancelled or failed.
    fn enter(&self) -> Outstanding<'_> {
        self.outstanding.fetch_add(1, Ordering::AcqRel);
        Outstanding {
            outstanding: &self.outstanding,
        }
    }

    /// Writes stored directly so far ([`GroupCommit::try_lone`]).
    pub fn lone_writes(&self) -> u64 {
        self.lone.load(Ordering::Relaxed)
    }

    async fn send<T>(&self, job: impl FnOnce(Reply<T>) -> Job) -> Option<Result<T, sqlx::Error>> {
        let (reply, answer) = oneshot::channel();
        let _outstanding = self.enter();
        self.tx.send(job(reply)).await.ok()?;
        answer.await.ok()
    }

    /// Stores one observation batch (see [`Store::insert_observations`]); `None` when the
    /// task has stopped (the caller then writes directly).
    pub async fn submit(
        &self,
        mission_id: &str,
        rows: &[ObservationRow],
        received_at_s: f64,
        writer: &str,
    ) -> Option<Result<Option<StoredBatch>, sqlx::Error>> {
        self.send(|reply| Job::Batch(Request::new(mission_id, rows, received_at_s, writer, reply)))
            .await
    }

    /// Stores one telemetry post (see [`Store::insert_telemetry`]); `None` when the task
    /// has stopped (the caller then writes directly).
    pub async fn submit_telemetry(
        &self,
        mission_id: &str,
        rows: &[TelemetryRow],
        received_at_s: f64,
        writer: &str,
    ) -> Option<Result<Option<InsertCounts>, sqlx::Error>> {
        self.send(|reply| {
            Job::Telemetry(Request::new(mission_id, rows, received_at_s, writer, reply))
        })
        .await
    }

    /// Stores one plan (see [`Store::insert_plan`]); `None` when the task has stopped
    /// (the caller then writes directly).
    pub async fn submit_plan(&self, row: &PlanRow) -> Option<Result<(), InsertPlanError>> {
        let (reply, answer) = oneshot::channel();
        let _outstanding = self.enter();
        let job = Job::Plan(PlanJob {
            row: row.clone(),
            reply,
        });
        self.tx.send(job).await.ok()?;
        answer.await.ok()
    }
}

async fn run(store: Store, mut rx: mpsc::Receiver<Job>) {
    let mut batches: Vec<BatchJob> = Vec::with_capacity(MAX_GROUP);
    let mut posts: Vec<TelemetryJob> = Vec::with_capacity(MAX_GROUP);
    let mut plans = Plans::default();
    while let Some(first) = rx.recv().await {
        let mut take = |job| match job {
            Job::Batch(j) => batches.push(j),
            Job::Telemetry(j) => posts.push(j),
            Job::Plan(j) => {
                plans.rows.push(j.row);
                plans.replies.push(j.reply);
            }
        };
        take(first);
        for _ in 1..MAX_GROUP {
            match rx.try_recv() {
                Ok(j) => take(j),
                Err(_) => break,
            }
        }
        // Ingest first: plans of the group are stored after its batches and posts are
        // answered, by one statement (one commit) of their own.
        store_ingest(&store, &mut batches, &mut posts).await;
        store_plans(&store, &mut plans).await;
        // Nothing waiting: the moment a short checkpoint costs no request anything.
        if rx.is_empty()
            && let Some(wal) = store.wal()
        {
            wal.on_writer_idle(store.write_pool()).await;
        }
    }
}

/// Stores the group's `plans` with one statement ([`Store::commit_plans`]); if it fails,
/// each plan is stored by itself so that a failure reaches only the plan that caused it.
async fn store_plans(store: &Store, plans: &mut Plans) {
    if plans.rows.is_empty() {
        return;
    }
    match store.commit_plans(&plans.rows).await {
        Ok(answers) => {
            for (reply, a) in plans.replies.drain(..).zip(answers) {
                let _ = reply.send(a);
            }
        }
        Err(e) => {
            if plans.rows.len() > 1 {
                tracing::warn!(error = %e, plans = plans.rows.len(), "plan group insert failed; storing its plans one by one");
            }
            for (reply, row) in plans.replies.drain(..).zip(&plans.rows) {
                let _ = reply.send(store.insert_plan_here(row).await);
            }
        }
    }
    plans.rows.clear();
}

/// Stores the group's observation batches and telemetry posts and answers them.
async fn store_ingest(store: &Store, batches: &mut Vec<BatchJob>, posts: &mut Vec<TelemetryJob>) {
    if batches.is_empty() && posts.is_empty() {
        return;
    }
    if batches.is_empty() {
        store_posts(store, posts).await;
        return;
    }
    let new_batches: Vec<NewBatch<'_>> = batches.iter().map(BatchJob::rows).collect();
    let new_posts: Vec<NewTelemetry<'_>> = posts.iter().map(TelemetryJob::rows).collect();
    let result = store.commit_group(&new_batches, &new_posts).await;
    drop((new_batches, new_posts));
    match result {
        Ok((stored, counted)) => {
            for (j, o) in batches.drain(..).zip(stored) {
                let _ = j.reply.send(Ok(o));
            }
            for (j, o) in posts.drain(..).zip(counted) {
                let _ = j.reply.send(Ok(o));
            }
        }
        Err(e) if batches.len() + posts.len() == 1 => {
            if let Some(j) = batches.pop() {
                let _ = j.reply.send(Err(e));
            } else if let Some(j) = posts.pop() {
                let _ = j.reply.send(Err(e));
            }
        }
        Err(e) => {
            tracing::warn!(error = %e, batches = batches.len(), posts = posts.len(), "group commit failed; storing its requests one by one");
            for j in batches.drain(..) {
                let r = store
                    .commit_group(&[j.rows()], &[])
                    .await
                    .map(|(mut v, _)| v.pop().flatten());
                let _ = j.reply.send(r);
            }
            for j in posts.drain(..) {
                let r = store
                    .commit_group(&[], &[j.rows()])
                    .await
                    .map(|(_, mut v)| v.pop().flatten());
                let _ = j.reply.send(r);
            }
        }
    }
}

/// Stores a group of telemetry posts alone (no batches with them): one statement per run
/// of [`post_runs`] without a transaction, a post too large for one statement in a
/// transaction of its own; if a run fails, its posts are retried one transaction each.
async fn store_posts(store: &Store, posts: &mut Vec<TelemetryJob>) {
    let mut answers = Vec::with_capacity(posts.len());
    for (range, one_statement) in post_runs(posts) {
        let run = &posts[range];
        let result = if one_statement {
            let new: Vec<NewTelemetry<'_>> = run.iter().map(TelemetryJob::rows).collect();
            store.commit_posts(&new).await
        } else {
            store
                .commit_group(&[], &[run[0].rows()])
                .await
                .map(|(_, counted)| counted)
        };
        match result {
            Ok(counted) => answers.extend(counted.into_iter().map(Ok)),
            Err(e) if run.len() == 1 => answers.push(Err(e)),
            Err(e) => {
                tracing::warn!(error = %e, posts = run.len(), "telemetry insert failed; storing its posts one by one");
                for j in run {
                    answers.push(
                        store
                            .commit_group(&[], &[j.rows()])
                            .await
                            .map(|(_, mut v)| v.pop().flatten()),
                    );
                }
            }
        }
    }
    for (j, a) in posts.drain(..).zip(answers) {
        let _ = j.reply.send(a);
    }
}

/// Per-request answers of [`Store::commit_group`]: the batches', then the posts'.
pub type GroupAnswers = (Vec<Option<StoredBatch>>, Vec<Option<InsertCounts>>);

impl Store {
    /// Stores observation `batches` (as [`Store::commit_batches`]) and telemetry `posts`
    /// in one transaction, all or none. A post's samples are new unless their time is
    /// already stored for the mission, by an earlier request or a post earlier in
    /// `posts` (the first one wins). Answers per request: `None` when its mission does not
    /// exist.
    ///
    /// # Errors
    /// Database failures (nothing is stored).
    pub async fn commit_group(
        &self,
        batches: &[NewBatch<'_>],
        posts: &[NewTelemetry<'_>],
    ) -> Result<GroupAnswers, sqlx::Error> {
        if posts.is_empty() && self.takes_script(batches) {
            return Ok((self.commit_script(batches).await?, Vec::new()));
        }
        let mut tx = self.write.begin().await?;
        let stored = self.batches_in(&mut tx, batches).await?;
        // Whether each batch's mission exists is known now: no need to ask again.
        let known: HashMap<&str, bool> = batches
            .iter()
            .zip(&stored)
            .map(|(b, s)| (b.mission_id, s.is_some()))
            .collect();
        let counted = telemetry_in(&mut tx, posts, &known).await?;
        tx.commit().await?;
        Ok((stored, counted))
    }

    /// Stores telemetry `posts` that together hold at most [`TELEMETRY_CHUNK_ROWS`] rows
    /// with one statement and no transaction of its own (`BEGIN` and `COMMIT` would be two
    /// more round trips to SQLite's connection thread): a single statement is atomic, so
    /// every post is still all or none. Answers as [`Store::commit_group`].
    ///
    /// # Errors
    /// Database failures (nothing is stored); more rows than one statement takes.
    pub async fn commit_posts(
        &self,
        posts: &[NewTelemetry<'_>],
    ) -> Result<Vec<Option<InsertCounts>>, sqlx::Error> {
        if posts.iter().map(|p| p.rows.len()).sum::<usize>() > TELEMETRY_CHUNK_ROWS {
            return Err(sqlx::Error::Protocol(
                "commit_posts takes one statement's rows at most".into(),
            ));
        }
        let mut conn = self.write.acquire().await?;
        telemetry_in(&mut conn, posts, &HashMap::new()).await
    }
}

/// `posts` cut into runs that one statement of [`Store::commit_posts`] takes, as index
/// ranges in order, marked `true`; a post with more rows than that is a run of its own,
/// marked `false` (it needs a transaction).
fn post_runs(posts: &[TelemetryJob]) -> Vec<(std::ops::Range<usize>, bool)> {
    let mut runs = Vec::new();
    let (mut from, mut rows) = (0, 0);
    for (i, p) in posts.iter().enumerate() {
        let n = p.rows.len();
        if n > TELEMETRY_CHUNK_ROWS {
            if from < i {
                runs.push((from..i, true));
            }
            runs.push((i..i + 1, false));
            (from, rows) = (i + 1, 0);
            continue;
        }
        if rows + n > TELEMETRY_CHUNK_ROWS {
            runs.push((from..i, true));
            (from, rows) = (i, 0);
        }
        rows += n;
    }
    if from < posts.len() {
        runs.push((from..posts.len(), true));
    }
    runs
}

/// Stores telemetry `posts` through `conn` (inside the group's transaction, or alone: see
/// [`Store::commit_posts`]). The insert itself leaves out rows of missions that do not
/// exist (`WHERE EXISTS`), so the usual case is one statement per [`TELEMETRY_CHUNK_ROWS`]
/// rows and nothing else; only posts that stored nothing new (duplicates, an empty post, a
/// missing mission) are then told apart by one lookup of their missions, unless `known`
/// (the group's batches) already says.
async fn telemetry_in(
    conn: &mut sqlx::AnyConnection,
    posts: &[NewTelemetry<'_>],
    known: &HashMap<&str, bool>,
) -> Result<Vec<Option<InsertCounts>>, sqlx::Error> {
    if posts.is_empty() {
        return Ok(Vec::new());
    }
    let rows: Vec<(usize, &TelemetryRow)> = posts
        .iter()
        .enumerate()
        .filter(|(_, p)| known.get(p.mission_id) != Some(&false))
        .flat_map(|(i, p)| p.rows.iter().map(move |r| (i, r)))
        .collect();
    // A stored (mission, time) belongs to the first post that carried it.
    let mut first_post: HashMap<(&str, i64), usize> = HashMap::new();
    for &(i, r) in &rows {
        first_post
            .entry((posts[i].mission_id, to_us(r.t_s)))
            .or_insert(i);
    }
    let mut accepted = vec![0_u64; posts.len()];
    let head = format!(
        "{} SELECT * FROM (VALUES ",
        TELEMETRY_INSERT.trim_end_matches("VALUES ")
    );
    for chunk in rows.chunks(TELEMETRY_CHUNK_ROWS) {
        let sql = values_sql_anonymous(
            &head,
            TELEMETRY_COLUMNS,
            chunk.len(),
            ") AS v WHERE EXISTS (SELECT 1 FROM missions WHERE id = v.column1) \
             ON CONFLICT DO NOTHING RETURNING mission_id, t_us",
        );
        let mut q = sqlx::query(AssertSqlSafe(sql));
        for &(i, r) in chunk {
            let p = &posts[i];
            q = bind_telemetry(q, p.mission_id, r, to_us(p.received_at_s), p.writer);
        }
        for r in q.fetch_all(&mut *conn).await? {
            let (m, t): (String, i64) = (r.try_get(0)?, r.try_get(1)?);
            let k = first_post
                .get(&(m.as_str(), t))
                .ok_or_else(|| sqlx::Error::Protocol(format!("unexpected sample {m} {t}")))?;
            accepted[*k] += 1;
        }
    }
    // A mission exists if the batches say so or a post of it stored a row.
    let mut existing: HashSet<&str> = known
        .iter()
        .filter_map(|(m, there)| there.then_some(*m))
        .collect();
    existing.extend(
        posts
            .iter()
            .zip(&accepted)
            .filter(|(_, a)| **a > 0)
            .map(|(p, _)| p.mission_id),
    );
    let mut ask: Vec<&str> = Vec::new();
    for p in posts {
        if !known.contains_key(p.mission_id)
            && !existing.contains(p.mission_id)
            && !ask.contains(&p.mission_id)
        {
            ask.push(p.mission_id);
        }
    }
    let found = super::existing_missions(&mut *conn, &ask).await?;
    existing.extend(ask.iter().copied().filter(|m| found.contains(*m)));
    Ok(posts
        .iter()
        .zip(accepted)
        .map(|(p, accepted)| {
            existing.contains(p.mission_id).then(|| InsertCounts {
                accepted,
                duplicate: p.rows.len() as u64 - accepted,
            })
        })
        .collect())
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

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn under_a_steady_stream_of_commits_the_wal_starts_over() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let wal = store.wal().expect("SQLite keeps WAL state");
        wal.set_threshold_frames(256);
        let mission = wire::ids::MissionId::from("webster");
        // One client posting telemetry back to back (a commit every few milliseconds, the
        // queue empty between posts) until the WAL has grown past the threshold, a writer
        // checkpoint has completed and the WAL has started over. The loop ends on those
        // events, not on a clock, so a loaded machine only makes it take longer; the
        // deadline is there so that a WAL that never restarts fails instead of hanging.
        // The WAL's length is read after every acknowledged commit, so no restart can fall
        // between two reads.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
        let (mut peak, mut restarts, mut last, mut posts) = (0, 0, 0, 0u32);
        while std::time::Instant::now() < deadline {
            let rows: Vec<TelemetryRow> = (0..50)
                .map(|i| sample(1000.0 + f64::from(posts * 50 + i) * 0.01, 38.14))
                .collect();
            store
                .insert_telemetry(&mission, &rows, 0.0)
                .await
                .expect("stored")
                .expect("the mission exists");
            posts += 1;
            let f = wal.frames();
            if f < last {
                restarts += 1;
            }
            (peak, last) = (peak.max(f), f);
            // Twice: the WAL keeps starting over under the stream, not once by chance.
            if restarts >= 2 && wal.writer_checkpoints().1 >= 1 {
                break;
            }
        }
        let (tried, complete) = wal.writer_checkpoints();
        assert!(
            peak > 256,
            "the WAL never grew past the threshold: {peak} frames after {posts} posts"
        );
        assert!(
            restarts >= 2,
            "the WAL started over {restarts} times in {posts} posts (peak {peak} frames)"
        );
        assert!(complete >= 1, "{tried} writer checkpoints, none complete");
        // Nothing acknowledged was lost, and nothing was stored twice: the read asks for
        // one row more than was posted (a slow machine posts a few million rows before
        // a writer checkpoint completes, so no fixed limit will do).
        let stored = store
            .list_telemetry_since(&mission, 0.0, posts * 50 + 1)
            .await
            .expect("read");
        assert_eq!(stored.len(), posts as usize * 50);
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

    /// What a group stored: per batch its number and counts and the rows it stored, then
    /// every row of the mission with its batch number, as read back.
    type Outcome = (
        Vec<Option<(i64, u64, u64, Vec<ObservationRow>)>>,
        Vec<(i64, ObservationRow)>,
    );

    async fn store_groups(
        store: &Store,
        by_script: bool,
        groups: &[Vec<NewBatch<'_>>],
    ) -> Vec<Outcome> {
        let mut out = Vec::new();
        for g in groups {
            assert!(store.takes_script(g), "the script takes these groups");
            let answers = if by_script {
                store.commit_script(g).await.expect("script")
            } else {
                let mut tx = store.write.begin().await.expect("begin");
                let a = store.batches_in(&mut tx, g).await.expect("statements");
                tx.commit().await.expect("commit");
                a
            };
            let seq = store
                .observation_seq("webster")
                .await
                .expect("seq")
                .expect("mission");
            let rows = store
                .list_observations_through("webster", 0, seq)
                .await
                .expect("read");
            let answers = answers
                .into_iter()
                .map(|a| a.map(|b| (b.seq, b.counts.accepted, b.counts.duplicate, b.stored)))
                .collect();
            out.push((answers, rows));
        }
        out
    }

    #[tokio::test]
    async fn a_batch_stored_by_one_script_is_stored_as_by_one_statement_at_a_time() {
        let (d1, d2) = (
            tempfile::tempdir().expect("dir"),
            tempfile::tempdir().expect("dir"),
        );
        let (script, statements) = (store_with_webster(&d1).await, store_with_webster(&d2).await);
        let a = [
            row("0", 1.0, 38.1),
            row("1", 1.0, 38.1),
            row("2", 1.5, 38.0),
        ];
        let b = [
            row("0", 1.0, 38.2),
            row("0", 2.0, 38.2),
            row("0", 2.0, 38.3),
        ];
        let c = [row("1", 3.0, 38.3)];
        let d = [
            row("1", 1.0, 38.4),
            row("3", 4.0, 38.4),
            row("2", 0.5, 38.4),
        ];
        let batch = |mission_id, rows, received_at_s| NewBatch {
            mission_id,
            rows,
            received_at_s,
            writer: "gcs",
        };
        let groups = vec![
            vec![batch("webster", &a[..], 10.0)],
            // Three batches of one mission with a missing mission between them, rows
            // already stored, and one row twice in a batch.
            vec![
                batch("webster", &b, 11.0),
                batch("nope", &c, 11.5),
                batch("webster", &c, 12.0),
                batch("webster", &d, 12.5),
            ],
            vec![batch("webster", &[][..], 13.0)],
            vec![batch("nope", &a, 14.0)],
            vec![batch("webster", &d, 15.0), batch("webster", &a, 15.0)],
        ];
        let by_script = store_groups(&script, true, &groups).await;
        let one_by_one = store_groups(&statements, false, &groups).await;
        assert_eq!(by_script, one_by_one);
        // What the statements stored, checked by hand at the second and last groups.
        let (answers, rows) = &one_by_one[1];
        assert_eq!(
            answers[0].as_ref().map(|x| (x.0, x.1, x.2)),
            Some((2, 1, 2))
        );
        assert!(answers[1].is_none());
        assert_eq!(answers[2].as_ref().map(|x| (x.0, x.1)), Some((3, 1)));
        assert_eq!(
            answers[3].as_ref().map(|x| (x.0, x.1, x.2)),
            Some((4, 2, 1)),
            "d's (\"1\", 1.0) came with a"
        );
        assert_eq!(rows.len(), 3 + 1 + 1 + 2);
        let (answers, rows) = &one_by_one[4];
        assert_eq!(
            answers
                .iter()
                .map(|x| x.as_ref().map(|x| (x.0, x.1)))
                .collect::<Vec<_>>(),
            [Some((6, 0)), Some((7, 0))],
            "the empty batch took 5, the missing mission's none"
        );
        assert_eq!(rows.len(), 7);
    }

    #[tokio::test]
    async fn a_script_that_fails_stores_nothing_and_leaves_the_connection_ready() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let mut bad = row("1", 2.0, 38.1);
        bad.radius_m = f64::NAN; // bound as NULL: the NOT NULL constraint fails
        let rows = [row("0", 2.0, 38.1), bad];
        let batch = |rows| NewBatch {
            mission_id: "webster",
            rows,
            received_at_s: 10.0,
            writer: "gcs",
        };
        assert!(store.commit_script(&[batch(&rows[..])]).await.is_err());
        assert_eq!(
            store.observation_seq("webster").await.expect("seq"),
            Some(0)
        );
        // The next batch starts a transaction of its own and takes number 1.
        let good = store
            .commit_script(&[batch(&rows[..1])])
            .await
            .expect("commit")
            .pop()
            .flatten()
            .expect("mission");
        assert_eq!((good.seq, good.counts.accepted), (1, 1));
        let id = wire::ids::MissionId::from("webster");
        let stored = store
            .list_observations(&id, None, None)
            .await
            .expect("list");
        assert_eq!(stored, [row("0", 2.0, 38.1)]);
    }

    fn sample(t_s: f64, lat_deg: f64) -> TelemetryRow {
        TelemetryRow {
            t_s,
            lat_deg,
            lon_deg: -76.43,
            alt_msl_m: 60.0,
            heading_deg: 90.0,
            speed_mps: Some(18.0),
        }
    }

    /// A telemetry post of the writer "gcs".
    fn post<'a>(mission_id: &'a str, rows: &'a [TelemetryRow]) -> NewTelemetry<'a> {
        NewTelemetry {
            mission_id,
            rows,
            received_at_s: 10.0,
            writer: "gcs",
        }
    }

    fn counts(accepted: u64, duplicate: u64) -> Option<InsertCounts> {
        Some(InsertCounts {
            accepted,
            duplicate,
        })
    }

    #[tokio::test]
    async fn telemetry_posts_of_one_group_count_their_own_new_samples_next_to_batches() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let id = wire::ids::MissionId::from("webster");
        // t = 1 stored before the group.
        store
            .insert_telemetry(&id, &[sample(1.0, 38.0)], 5.0)
            .await
            .expect("insert")
            .expect("mission");
        let a = [sample(1.0, 38.1), sample(2.0, 38.1), sample(3.0, 38.1)];
        let b = [sample(3.0, 38.2), sample(4.0, 38.2), sample(4.0, 38.3)];
        let c = [sample(5.0, 38.4)];
        let obs = [row("0", 1.0, 38.1)];
        let batch = NewBatch {
            mission_id: "webster",
            rows: &obs,
            received_at_s: 10.0,
            writer: "gcs",
        };
        let (stored, counted) = store
            .commit_group(
                &[batch],
                &[
                    post("webster", &a),
                    post("nope", &c),
                    post("webster", &b),
                    post("webster", &[]),
                ],
            )
            .await
            .expect("commit");
        assert_eq!(stored[0].as_ref().expect("batch").counts.accepted, 1);
        assert_eq!(
            counted,
            [counts(2, 1), None, counts(1, 2), counts(0, 0)],
            "a: t=1 was stored before; b: t=3 is a's, its second t=4 its own duplicate"
        );
        let listed = store.list_telemetry_written(&id, None).await.expect("list");
        let got: Vec<(f64, f64, &str)> = listed
            .iter()
            .map(|(r, w)| (r.t_s, r.lat_deg, w.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                (1.0, 38.0, "local"),
                (2.0, 38.1, "gcs"),
                (3.0, 38.1, "gcs"),
                (4.0, 38.2, "gcs")
            ],
            "the first copy of each time wins"
        );
    }

    #[tokio::test]
    async fn posts_stored_without_a_transaction_tell_duplicates_from_missing_missions() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let id = wire::ids::MissionId::from("webster");
        store
            .insert_telemetry(&id, &[sample(1.0, 38.0)], 5.0)
            .await
            .expect("insert")
            .expect("mission");
        let a = [sample(1.0, 38.1), sample(2.0, 38.1)];
        let b = [sample(2.0, 38.2), sample(3.0, 38.2), sample(3.0, 38.3)];
        let old = [sample(1.0, 38.5)];
        let counted = store
            .commit_posts(&[
                post("webster", &a),
                post("nope", &a),
                post("webster", &b),
                post("webster", &old),
                post("webster", &[]),
                post("nope", &[]),
            ])
            .await
            .expect("commit");
        assert_eq!(
            counted,
            [
                counts(1, 1),
                None,
                counts(1, 2),
                counts(0, 1),
                counts(0, 0),
                None
            ],
            "a: t=1 stored before; b: t=2 is a's, its second t=3 its own duplicate; \
             an all-duplicate post and an empty one still exist; missing missions are None"
        );
        let listed = store.list_telemetry_written(&id, None).await.expect("list");
        let got: Vec<(f64, f64, &str)> = listed
            .iter()
            .map(|(r, w)| (r.t_s, r.lat_deg, w.as_str()))
            .collect();
        assert_eq!(
            got,
            [(1.0, 38.0, "local"), (2.0, 38.1, "gcs"), (3.0, 38.2, "gcs")]
        );
        let too_many: Vec<TelemetryRow> = (0..=TELEMETRY_CHUNK_ROWS)
            .map(|k| sample(100.0 + k as f64, 38.0))
            .collect();
        assert!(
            store
                .commit_posts(&[post("webster", &too_many)])
                .await
                .is_err(),
            "more rows than one statement takes is refused, not split"
        );
        assert_eq!(
            store.list_telemetry(&id, None).await.expect("list").len(),
            3
        );
    }

    #[test]
    fn posts_are_cut_into_statements_at_post_boundaries() {
        let job = |n: usize| {
            let (reply, _) = oneshot::channel();
            TelemetryJob::new("m", &vec![sample(0.0, 38.0); n], 0.0, "local", reply)
        };
        let c = TELEMETRY_CHUNK_ROWS;
        let sizes = [1, 1, c + 8, c - 2, 5, c, 0, 1];
        let jobs: Vec<TelemetryJob> = sizes.iter().map(|&n| job(n)).collect();
        assert_eq!(
            post_runs(&jobs),
            [
                (0..2, true),
                (2..3, false),
                (3..4, true),
                (4..5, true),
                (5..7, true),
                (7..8, true)
            ],
            "(c - 2) + 5 and c + 0 + 1 are more than one statement's c rows"
        );
        for (r, one) in post_runs(&jobs) {
            if one {
                assert!(sizes[r].iter().sum::<usize>() <= TELEMETRY_CHUNK_ROWS);
            }
        }
    }

    #[tokio::test]
    async fn a_lone_telemetry_post_is_stored_directly_and_answers_as_through_the_queue() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let id = wire::ids::MissionId::from("webster");
        let insert = |id: wire::ids::MissionId, rows: Vec<TelemetryRow>| {
            let store = store.clone();
            async move {
                store
                    .insert_telemetry(&id, &rows, 10.0)
                    .await
                    .expect("insert")
            }
        };
        let two = vec![sample(1.0, 38.1), sample(2.0, 38.1)];
        assert_eq!(insert(id.clone(), two.clone()).await, counts(2, 0));
        assert_eq!(
            store.lone_writes(),
            1,
            "nothing else outstanding: stored directly"
        );
        // The same answers as the queue gives: duplicates counted, a missing mission
        // told apart from a post of duplicates, an empty post.
        let again = vec![sample(2.0, 38.2), sample(3.0, 38.2)];
        assert_eq!(insert(id.clone(), again).await, counts(1, 1));
        assert_eq!(insert(wire::ids::MissionId::from("nope"), two).await, None);
        assert_eq!(insert(id.clone(), Vec::new()).await, counts(0, 0));
        assert_eq!(store.lone_writes(), 4);
        // Another write in flight: through the queue, with the same answer.
        let group = store.group.clone().expect("SQLite groups");
        let held = group.try_lone().expect("nothing outstanding");
        assert_eq!(
            insert(id.clone(), vec![sample(4.0, 38.3)]).await,
            counts(1, 0)
        );
        assert_eq!(store.lone_writes(), 5, "the held right only");
        drop(held);
        // Too many rows for one statement: through the queue, in a transaction.
        let big: Vec<TelemetryRow> = (0..=TELEMETRY_CHUNK_ROWS)
            .map(|k| sample(100.0 + k as f64, 38.0))
            .collect();
        let n = big.len() as u64;
        assert_eq!(insert(id.clone(), big).await, counts(n, 0));
        assert_eq!(store.lone_writes(), 5, "a large post never goes alone");
        let rows = store.list_telemetry(&id, None).await.expect("rows");
        assert_eq!(rows.len() as u64, 4 + n);
        assert_eq!(
            (rows[1].t_s, rows[1].lat_deg),
            (2.0, 38.1),
            "the first copy wins"
        );
    }

    #[tokio::test]
    async fn a_post_larger_than_one_statement_goes_through_the_queue_whole() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let id = wire::ids::MissionId::from("webster");
        let big: Vec<TelemetryRow> = (0..3 * TELEMETRY_CHUNK_ROWS)
            .map(|k| sample(k as f64, 38.0))
            .collect();
        let tasks: Vec<_> = (0..10_u32)
            .map(|i| {
                let (store, id, big) = (store.clone(), id.clone(), big.clone());
                tokio::spawn(async move {
                    if i == 5 {
                        store.insert_telemetry(&id, &big, 11.0).await
                    } else {
                        let t = 1000.0 + f64::from(i);
                        store.insert_telemetry(&id, &[sample(t, 38.1)], 11.0).await
                    }
                })
            })
            .collect();
        let mut got = Vec::new();
        for t in tasks {
            let c = t.await.expect("task").expect("insert").expect("mission");
            got.push((c.accepted, c.duplicate));
        }
        let big_n = 3 * TELEMETRY_CHUNK_ROWS as u64;
        let mut want = vec![(1, 0); 10];
        want[5] = (big_n, 0);
        assert_eq!(got, want);
        let rows = store.list_telemetry(&id, None).await.expect("rows");
        assert_eq!(rows.len() as u64, big_n + 9);
    }

    #[tokio::test]
    async fn concurrent_telemetry_posts_through_the_queue_lose_and_double_nothing() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let id = wire::ids::MissionId::from("webster");
        let tasks: Vec<_> = (0..40_u32)
            .map(|i| {
                let (store, id) = (store.clone(), id.clone());
                tokio::spawn(async move {
                    // Posts i and i + 20 carry the same two times.
                    let t = f64::from(i % 20);
                    let rows = [sample(t, 38.1), sample(t + 0.5, 38.1)];
                    let missing = wire::ids::MissionId::from("nope");
                    let none = store.insert_telemetry(&missing, &rows, 11.0).await;
                    assert!(matches!(none, Ok(None)), "{none:?}");
                    store.insert_telemetry(&id, &rows, 11.0).await
                })
            })
            .collect();
        let (mut accepted, mut duplicate) = (0, 0);
        for t in tasks {
            let c = t
                .await
                .expect("task")
                .expect("insert")
                .expect("mission exists");
            accepted += c.accepted;
            duplicate += c.duplicate;
        }
        assert_eq!((accepted, duplicate), (40, 40));
        let rows = store.list_telemetry(&id, None).await.expect("rows");
        assert_eq!(rows.len(), 40);
    }

    #[tokio::test]
    async fn batches_of_several_missions_in_one_group_number_per_mission_in_order() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let text = include_str!("../../../tests/fixtures/interop/mission_2021_webster_field.json");
        let other: Mission = wire::domain::read_mission_text(text, "other").expect("fixture");
        store.insert_missions(&[other], 0.0).await.expect("mission");
        let (w1, o1, w2, o2) = (
            [row("0", 1.0, 38.1)],
            [row("0", 1.0, 38.2), row("1", 1.0, 38.2)],
            [row("0", 2.0, 38.3), row("0", 1.0, 38.3)],
            [row("1", 1.0, 38.4)],
        );
        let batch = |mission_id, rows| NewBatch {
            mission_id,
            rows,
            received_at_s: 10.0,
            writer: "local",
        };
        let sample_rows = [sample(1.0, 38.0)];
        let post = |mission_id| NewTelemetry {
            mission_id,
            rows: &sample_rows,
            received_at_s: 10.0,
            writer: "local",
        };
        let (out, counted) = store
            .commit_group(
                &[
                    batch("webster", &w1),
                    batch("other", &o1),
                    batch("nope", &w1),
                    batch("webster", &w2),
                    batch("other", &o2),
                ],
                &[post("nope"), post("other"), post("gone")],
            )
            .await
            .expect("commit");
        let got: Vec<Option<(i64, u64, u64)>> = out
            .iter()
            .map(|b| {
                b.as_ref()
                    .map(|b| (b.seq, b.counts.accepted, b.counts.duplicate))
            })
            .collect();
        assert_eq!(
            got,
            [
                Some((1, 1, 0)),
                Some((1, 2, 0)),
                None,
                Some((2, 1, 1)),
                Some((2, 0, 1))
            ]
        );
        assert_eq!(out[3].as_ref().expect("w2").stored, [row("0", 2.0, 38.3)]);
        assert_eq!(
            counted,
            [
                None,
                Some(InsertCounts {
                    accepted: 1,
                    duplicate: 0
                }),
                None
            ]
        );
        for (m, seq) in [("webster", 2), ("other", 2)] {
            assert_eq!(store.observation_seq(m).await.expect("seq"), Some(seq));
        }
        let rows = store
            .list_observations_through("other", 0, 2)
            .await
            .expect("rows");
        assert_eq!(rows, [(1, row("0", 1.0, 38.2)), (1, row("1", 1.0, 38.2))]);
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
        // The first was stored alone, directly; those spawned beside it went through the
        // queue while it was in flight.
        let lone = store.lone_writes();
        assert!((1..24).contains(&lone), "lone writes {lone}");
        // 24 rows of "5", and "6" at 4 distinct times.
        assert_eq!(accepted, 28);
        let rows = store
            .list_observations_through("webster", 0, 24)
            .await
            .expect("rows");
        assert_eq!(rows.len(), 28);
    }
    #[tokio::test]
    async fn a_lone_batch_is_stored_directly_and_one_arriving_beside_it_through_the_queue() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        let insert = |t: f64| {
            let store = store.clone();
            async move {
                store
                    .insert_observations("webster", &[row("1", t, 38.1)], 10.0)
                    .await
                    .expect("insert")
                    .expect("mission exists")
            }
        };
        assert_eq!(insert(1.0).await.seq, 1);
        assert_eq!(
            store.lone_writes(),
            1,
            "nothing else outstanding: stored directly"
        );
        let group = store.group.clone().expect("SQLite groups");
        let held = group.try_lone().expect("nothing outstanding");
        assert!(group.try_lone().is_none(), "one lone write at a time");
        // Another write in flight: this one goes through the queue.
        assert_eq!(insert(2.0).await.seq, 2);
        assert_eq!(store.lone_writes(), 2, "the held right only");
        drop(held);
        assert_eq!(insert(3.0).await.seq, 3);
        assert_eq!(store.lone_writes(), 3);
        let rows = store
            .list_observations_through("webster", 0, 3)
            .await
            .expect("rows");
        assert_eq!(rows.len(), 3);
    }

    fn plan(id: &str, mission_id: &str, revision: i64) -> PlanRow {
        PlanRow {
            id: wire::ids::PlanId(id.into()),
            mission_id: wire::ids::MissionId::from(mission_id),
            revision,
            created_at_s: 100.0,
            seed: 7,
            inputs: format!("{{\"plan\":\"{id}\"}}"),
            body: "x".repeat(5000),
            written_by: "gcs".into(),
        }
    }

    #[tokio::test]
    async fn plans_of_one_statement_each_get_their_own_answer_and_the_first_of_a_revision_wins() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        store
            .commit_plans(&[plan("p0", "webster", 1)])
            .await
            .expect("commit")
            .pop()
            .expect("answer")
            .expect("stored");
        let answers = store
            .commit_plans(&[
                plan("a", "webster", 2),
                plan("b", "webster", 1),
                plan("c", "nope", 1),
                plan("d", "webster", 2),
                plan("e", "webster", 3),
            ])
            .await
            .expect("commit");
        let kinds: Vec<String> = answers
            .iter()
            .map(|a| match a {
                Ok(()) => "stored".to_string(),
                Err(InsertPlanError::RevisionTaken(r)) => format!("taken {r}"),
                Err(InsertPlanError::NoMission) => "no mission".to_string(),
                Err(InsertPlanError::Db(e)) => format!("db {e}"),
            })
            .collect();
        assert_eq!(
            kinds,
            ["stored", "taken 1", "no mission", "taken 2", "stored"]
        );
        let id = wire::ids::MissionId::from("webster");
        for (revision, want) in [(1, "p0"), (2, "a"), (3, "e")] {
            let got = store
                .get_plan_by_revision(&id, revision)
                .await
                .expect("read")
                .expect("stored");
            assert_eq!(got, plan(want, "webster", revision), "revision {revision}");
        }
        assert_eq!(store.latest_plan_revision(&id).await.expect("latest"), 3);
    }

    #[tokio::test]
    async fn concurrent_plans_through_the_queue_take_each_revision_once() {
        let dir = tempfile::tempdir().expect("tempdir");
        let store = store_with_webster(&dir).await;
        // 24 requests racing for revisions 1-6, four for each, beside observation batches
        // in the same queue.
        let tasks: Vec<_> = (0..24_i64)
            .map(|i| {
                let store = store.clone();
                tokio::spawn(async move {
                    let rows = [row("9", i as f64, 38.1)];
                    let batch = store.insert_observations("webster", &rows, 11.0);
                    let p = plan(&format!("p{i}"), "webster", i % 6 + 1);
                    let (b, stored) = tokio::join!(batch, store.insert_plan(&p));
                    b.expect("batch").expect("mission exists");
                    (p, stored)
                })
            })
            .collect();
        let mut winners = std::collections::BTreeMap::new();
        for t in tasks {
            let (p, stored) = t.await.expect("task");
            match stored {
                Ok(()) => {
                    assert!(
                        winners.insert(p.revision, p.id.0.clone()).is_none(),
                        "revision {} stored twice",
                        p.revision
                    );
                }
                Err(InsertPlanError::RevisionTaken(r)) => assert_eq!(r, p.revision),
                Err(e) => panic!("plan {}: {e}", p.id.0),
            }
        }
        assert_eq!(
            winners.keys().copied().collect::<Vec<_>>(),
            [1, 2, 3, 4, 5, 6]
        );
        let id = wire::ids::MissionId::from("webster");
        for (revision, winner) in &winners {
            let got = store
                .get_plan_by_revision(&id, *revision)
                .await
                .expect("read")
                .expect("stored");
            assert_eq!(&got.id.0, winner);
        }
        assert_eq!(
            store.observation_seq("webster").await.expect("seq"),
            Some(24)
        );
    }
}
