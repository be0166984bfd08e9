//! Keeping the SQLite WAL short under a steady stream of commits (issue 12).
//!
//! A WAL starts over (its next write goes to its beginning) only when a checkpoint has
//! copied all of it into the database file and no reader still reads from it. Under a flood
//! of writes the background checkpoint never copies all of it, because commits keep
//! appending while it copies, so the WAL grew by about 10 MB/s (575-585 MB in a minute of
//! the overload benchmark). A checkpoint on the write connection itself completes (nothing
//! is appended meanwhile), but each one tried before stalled the writer 50-120 ms (0.9-1 s
//! at a 1 GiB bound): it copied what the background had not, and a checkpoint that
//! completes syncs the database file, writing out every page the background's partial
//! checkpoints had copied since the last complete one.
//!
//! So the work is split, and the writer's share kept small and regular:
//! - [`checkpoint_loop`], in the background on a read connection: a PASSIVE checkpoint
//!   (never blocks writer or readers) every [`QUIET_PERIOD`], and every
//!   [`BACKGROUND_PERIOD`] while the WAL is long ([`FLOOD_FRAMES`]), so that little is left
//!   to copy;
//! - [`Wal::on_writer_idle`], on the write connection when the group commit's queue has just
//!   emptied, at most once per [`WRITER_MIN_INTERVAL`] and only when the WAL holds more than
//!   [`WRITER_THRESHOLD_FRAMES`]: a PASSIVE checkpoint there copies the rest and completes,
//!   so the next write starts the WAL over and the sync covers about a second of copying;
//!   with `journal_size_limit` ([`JOURNAL_SIZE_LIMIT_BYTES`]) a WAL file over 64 MiB is cut
//!   back then.
//!
//! - [`start_over`], right after a background checkpoint that copied the whole WAL: the
//!   write that starts the WAL over writes its new header and syncs it (SQLite does so at
//!   every `synchronous` level but OFF), and without this that write was the next request's
//!   commit. At a flight's load (`plan_load`) the background checkpoint completes every
//!   [`QUIET_PERIOD`], so about one write in seven to ten (ingest, telemetry, plans) paid a
//!   sync of 0.45-7.4 ms inside its `store` phase (`strace -T` of the writer's thread); a
//!   one-frame write of the checkpoint's own pays it instead, when no request waits for it.
//!
//! Tried and not kept: syncing the database file from the background after each of its
//! copies (`fdatasync` on a handle of its own), so that the writer's sync would find nothing
//! left: writer checkpoints of at most 3.9-8.8 ms, but two of five 60 s floods had
//! stalls of 178-284 ms and of 1.2 s inside the handlers, the two without it none.

use std::sync::Arc;
use std::sync::atomic::{AtomicI64, Ordering};
use std::time::{Duration, Instant};

use sqlx::{AnyPool, Row};

/// How often the background checkpoint runs while the WAL is long
/// ([`FLOOD_FRAMES`])...
pub const BACKGROUND_PERIOD: Duration = Duration::from_millis(100);

/// ... and how often otherwise: at a flight's load the WAL stays under 1 MB, and a
/// checkpoint every 100 ms (with a sync of the database file) took ingest's p99 from 25-41 ms
/// to 55-161 ms in `plan_load` (each checkpoint also syncs the WAL, which the writer
/// appends to).
pub const QUIET_PERIOD: Duration = Duration::from_millis(500);

/// The WAL is long (a flood of writes) above this many frames (4 MiB of 4 KiB pages).
pub const FLOOD_FRAMES: i64 = 1024;

/// The writer checkpoints only when the WAL holds more frames than this (4096 pages of
/// 4 KiB: 16 MiB)...
pub const WRITER_THRESHOLD_FRAMES: i64 = 4096;

/// ... and at most this often.
pub const WRITER_MIN_INTERVAL: Duration = Duration::from_secs(1);

/// The WAL file is cut back to at most this many bytes when it starts over.
pub const JOURNAL_SIZE_LIMIT_BYTES: i64 = 64 * 1024 * 1024;

/// What the checkpoints have seen of the WAL, shared by the background loop and the writer.
#[derive(Debug, Default)]
pub struct Wal {
    /// Frames in the WAL at the last checkpoint (any), -1 before the first.
    frames: AtomicI64,
    /// Checkpoints on the write connection that copied the whole WAL.
    writer_complete: AtomicI64,
    /// Writer checkpoints tried.
    writer_tried: AtomicI64,
    /// [`WRITER_THRESHOLD_FRAMES`], lower in tests.
    threshold_frames: AtomicI64,
    last_writer: std::sync::Mutex<Option<Instant>>,
    /// Time spent in writer checkpoints, microseconds: in all, and the longest.
    writer_total_us: AtomicI64,
    writer_max_us: AtomicI64,
    /// WAL restarts made by [`start_over`] (not by a request's commit).
    started_over: AtomicI64,
}

/// The result row of `PRAGMA wal_checkpoint`: (busy, frames in the WAL, frames copied).
async fn checkpoint(pool: &AnyPool) -> Result<(i64, i64, i64), sqlx::Error> {
    let row = sqlx::query("PRAGMA wal_checkpoint(PASSIVE)")
        .fetch_one(pool)
        .await?;
    Ok((row.try_get(0)?, row.try_get(1)?, row.try_get(2)?))
}

impl Wal {
    /// A new shared state.
    pub fn new() -> Arc<Self> {
        let w = Self::default();
        w.frames.store(-1, Ordering::Relaxed);
        w.threshold_frames
            .store(WRITER_THRESHOLD_FRAMES, Ordering::Relaxed);
        Arc::new(w)
    }

    /// Frames in the WAL at the last checkpoint (-1 before the first).
    pub fn frames(&self) -> i64 {
        self.frames.load(Ordering::Relaxed)
    }

    /// (writer checkpoints tried, those that copied the whole WAL).
    pub fn writer_checkpoints(&self) -> (i64, i64) {
        (
            self.writer_tried.load(Ordering::Relaxed),
            self.writer_complete.load(Ordering::Relaxed),
        )
    }

    /// WAL restarts made by the background, after its checkpoints ([`start_over`]).
    pub fn started_over(&self) -> i64 {
        self.started_over.load(Ordering::Relaxed)
    }

    /// Sets the writer's threshold (frames; [`WRITER_THRESHOLD_FRAMES`] by default).
    pub fn set_threshold_frames(&self, frames: i64) {
        self.threshold_frames.store(frames, Ordering::Relaxed);
    }

    /// Whether the WAL held more frames than the writer's threshold at the last
    /// checkpoint (a writer checkpoint may be due: [`Wal::on_writer_idle`] decides).
    pub fn long(&self) -> bool {
        self.frames() > self.threshold_frames.load(Ordering::Relaxed)
    }

    /// Whether the writer should checkpoint now (the WAL is long and the last writer
    /// checkpoint is at least [`WRITER_MIN_INTERVAL`] old); marks the attempt.
    fn writer_due(&self, now: Instant) -> bool {
        if self.frames() <= self.threshold_frames.load(Ordering::Relaxed) {
            return false;
        }
        let mut last = self.last_writer.lock().unwrap_or_else(|e| e.into_inner());
        if last.is_some_and(|l| now.duration_since(l) < WRITER_MIN_INTERVAL) {
            return false;
        }
        *last = Some(now);
        true
    }

    /// Called by the group commit when its queue has just emptied: checkpoints on the write
    /// connection when due ([`Wal::writer_due`]).
    pub async fn on_writer_idle(&self, write: &AnyPool) {
        if !self.writer_due(Instant::now()) {
            return;
        }
        self.writer_tried.fetch_add(1, Ordering::Relaxed);
        let started = Instant::now();
        let result = checkpoint(write).await;
        let us = i64::try_from(started.elapsed().as_micros()).unwrap_or(i64::MAX);
        self.writer_total_us.fetch_add(us, Ordering::Relaxed);
        self.writer_max_us.fetch_max(us, Ordering::Relaxed);
        match result {
            Ok((busy, log, copied)) => {
                self.frames.store(log, Ordering::Relaxed);
                if busy == 0 && copied == log {
                    self.writer_complete.fetch_add(1, Ordering::Relaxed);
                }
            }
            Err(e) => tracing::warn!(error = %e, "WAL checkpoint on the writer failed"),
        }
    }

    /// The Prometheus text of the WAL's state: its length at the last checkpoint, the
    /// writer's checkpoints (tried, complete) and the time they held the writer.
    pub fn render_metrics(&self) -> String {
        let (tried, complete) = self.writer_checkpoints();
        let secs = |us: &AtomicI64| us.load(Ordering::Relaxed) as f64 / 1e6;
        format!(
            "# HELP jink_sqlite_wal_frames Frames (pages) in the SQLite WAL at the last checkpoint.\n\
             # TYPE jink_sqlite_wal_frames gauge\n\
             jink_sqlite_wal_frames {}\n\
             # HELP jink_sqlite_writer_checkpoints_total Checkpoints on the write connection while the WAL was long, and those that copied all of it.\n\
             # TYPE jink_sqlite_writer_checkpoints_total counter\n\
             jink_sqlite_writer_checkpoints_total{{result=\"tried\"}} {tried}\n\
             jink_sqlite_writer_checkpoints_total{{result=\"complete\"}} {complete}\n\
             # HELP jink_sqlite_writer_checkpoint_seconds Time the writer's checkpoints held the write connection: in all, and the longest.\n\
             # TYPE jink_sqlite_writer_checkpoint_seconds gauge\n\
             jink_sqlite_writer_checkpoint_seconds{{stat=\"sum\"}} {:.6}\n\
             jink_sqlite_writer_checkpoint_seconds{{stat=\"max\"}} {:.6}\n\
             # HELP jink_sqlite_wal_started_over_total Times the background started the WAL over after a checkpoint that copied all of it (so that no request's commit syncs the new WAL header).\n\
             # TYPE jink_sqlite_wal_started_over_total counter\n\
             jink_sqlite_wal_started_over_total {}\n",
            self.frames(),
            secs(&self.writer_total_us),
            secs(&self.writer_max_us),
            self.started_over(),
        )
    }
}

/// Starts the WAL over now, after a checkpoint that copied all of it, so that no request's
/// commit has to: the write that starts a WAL over writes the new WAL header and syncs it
/// before its frames (SQLite's `syncHeader`, at every `synchronous` level but OFF). The
/// write is one frame: `PRAGMA user_version` set to the value it has (jink does not use
/// it), on the write connection. When a reader still reads the old WAL, SQLite appends
/// instead and a later commit starts it over, as before.
///
/// # Errors
/// Database failures.
pub async fn start_over(write: &AnyPool) -> Result<(), sqlx::Error> {
    let mut c = write.acquire().await?;
    let v: i64 = sqlx::query("PRAGMA user_version")
        .fetch_one(&mut *c)
        .await?
        .try_get(0)?;
    sqlx::query(sqlx::AssertSqlSafe(format!("PRAGMA user_version = {v}")))
        .execute(&mut *c)
        .await?;
    Ok(())
}

/// One background checkpoint (PASSIVE on `read`), then, when it copied the whole WAL and
/// more than one frame of it (a WAL of one frame is the last restart's own, or a store that
/// writes about once a checkpoint, where a sync now and then costs nobody a deadline),
/// [`start_over`] on `write`.
pub async fn checkpoint_once(read: &AnyPool, write: &AnyPool, wal: &Wal) {
    match checkpoint(read).await {
        Ok((busy, log, copied)) => {
            wal.frames.store(log, Ordering::Relaxed);
            if busy == 0 && log > 1 && copied == log {
                match start_over(write).await {
                    Ok(()) => {
                        wal.started_over.fetch_add(1, Ordering::Relaxed);
                    }
                    Err(e) => tracing::warn!(error = %e, "starting the WAL over failed"),
                }
            }
        }
        Err(e) => tracing::warn!(error = %e, "WAL checkpoint failed"),
    }
}

/// Copies the SQLite WAL into the database file in the background (PASSIVE: it never
/// blocks the writer or readers), often while the WAL is long, so that the writer's
/// checkpoints ([`Wal::on_writer_idle`]) have little left to copy; after a checkpoint that
/// copied all of it, starts the WAL over ([`checkpoint_once`]).
pub async fn checkpoint_loop(pool: AnyPool, write: AnyPool, wal: Arc<Wal>) {
    let mut tick = tokio::time::interval(BACKGROUND_PERIOD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last: Option<Instant> = None;
    loop {
        tick.tick().await;
        if pool.is_closed() {
            return;
        }
        let flood = wal.frames() > FLOOD_FRAMES;
        if !flood && last.is_some_and(|l| l.elapsed() < QUIET_PERIOD) {
            continue;
        }
        last = Some(Instant::now());
        checkpoint_once(&pool, &write, &wal).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sqlx::Executor;

    /// A write and a read pool on a new SQLite file with the store's pragmas, one table,
    /// and the path of its WAL file.
    async fn pools(dir: &tempfile::TempDir) -> (AnyPool, AnyPool, std::path::PathBuf) {
        sqlx::any::install_default_drivers();
        let path = dir.path().join("w.sqlite");
        let url = format!("sqlite://{}?mode=rwc", path.display());
        let pool = || {
            sqlx::any::AnyPoolOptions::new()
                .max_connections(1)
                .after_connect(|conn, _| {
                    Box::pin(async move {
                        conn.execute(super::super::SQLITE_PRAGMAS).await?;
                        Ok(())
                    })
                })
        };
        let write = pool().connect(&url).await.expect("write pool");
        let read = pool().connect(&url).await.expect("read pool");
        sqlx::query("CREATE TABLE t (x INTEGER)")
            .execute(&write)
            .await
            .expect("table");
        (read, write, dir.path().join("w.sqlite-wal"))
    }

    /// The WAL header's checkpoint sequence number (bytes 12-15, big-endian), which SQLite
    /// raises by one each time it starts the WAL over (the write that does so writes the
    /// header anew and syncs it).
    fn restarts_so_far(wal_file: &std::path::Path) -> u32 {
        let b = std::fs::read(wal_file).expect("WAL file");
        u32::from_be_bytes([b[12], b[13], b[14], b[15]])
    }

    async fn commit(write: &AnyPool, x: i64) {
        sqlx::query("INSERT INTO t (x) VALUES (?)")
            .bind(x)
            .execute(write)
            .await
            .expect("insert");
    }

    #[tokio::test]
    async fn after_a_checkpoint_that_copied_everything_no_request_commit_starts_the_wal_over() {
        let dir = tempfile::tempdir().expect("tempdir");
        let (read, write, wal_file) = pools(&dir).await;
        for x in 0..3 {
            commit(&write, x).await;
        }
        // Without `start_over` (a bare checkpoint, as before): the WAL is copied, and the
        // next commit is the one that starts it over.
        let (busy, log, copied) = checkpoint(&read).await.expect("checkpoint");
        assert_eq!(
            (busy, copied),
            (0, log),
            "the checkpoint copied the whole WAL"
        );
        let before = restarts_so_far(&wal_file);
        commit(&write, 3).await;
        assert_eq!(
            restarts_so_far(&wal_file),
            before + 1,
            "a bare checkpoint leaves the restart (and its sync) to the next commit"
        );
        for x in 4..6 {
            commit(&write, x).await;
        }
        // With it: the checkpoint's own one-frame write starts the WAL over, and the next
        // commit appends to the WAL as it finds it.
        let wal = Wal::new();
        let before = restarts_so_far(&wal_file);
        checkpoint_once(&read, &write, &wal).await;
        assert_eq!(
            restarts_so_far(&wal_file),
            before + 1,
            "started over by the background"
        );
        assert_eq!(wal.started_over(), 1);
        commit(&write, 6).await;
        assert_eq!(
            restarts_so_far(&wal_file),
            before + 1,
            "the commit after it did not start the WAL over"
        );
        let (_, log, _) = checkpoint(&read).await.expect("checkpoint");
        assert_eq!(
            log, 2,
            "the WAL holds the start-over frame and the commit's"
        );
        // A WAL of one frame (an idle store: the last start-over's own) is left alone, so an
        // idle store does not write and sync every period.
        let (_, log, _) = checkpoint(&read).await.expect("checkpoint");
        assert_eq!(log, 2);
        checkpoint_once(&read, &write, &wal).await;
        assert_eq!(wal.started_over(), 2, "two frames copied: started over");
        checkpoint_once(&read, &write, &wal).await;
        assert_eq!(wal.started_over(), 2, "one frame, its own: not again");
        assert!(
            wal.render_metrics()
                .contains("jink_sqlite_wal_started_over_total 2")
        );
        // Nothing was lost on the way.
        let n: i64 = sqlx::query("SELECT COUNT(*) FROM t")
            .fetch_one(&read)
            .await
            .expect("count")
            .try_get(0)
            .expect("count");
        assert_eq!(n, 7);
    }

    #[test]
    fn the_writer_checkpoints_only_a_long_wal_and_at_most_once_a_second() {
        let wal = Wal::new();
        let t0 = Instant::now();
        // Before any checkpoint, and with a short WAL: no.
        assert!(!wal.writer_due(t0));
        wal.frames.store(WRITER_THRESHOLD_FRAMES, Ordering::Relaxed);
        assert!(!wal.writer_due(t0));
        // Long: yes, then not again within the interval, then again after it.
        wal.frames
            .store(WRITER_THRESHOLD_FRAMES + 1, Ordering::Relaxed);
        assert!(wal.writer_due(t0));
        assert!(!wal.writer_due(t0 + WRITER_MIN_INTERVAL / 2));
        assert!(wal.writer_due(t0 + WRITER_MIN_INTERVAL));
    }
}
