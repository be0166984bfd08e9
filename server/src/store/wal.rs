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

    /// Sets the writer's threshold (frames; [`WRITER_THRESHOLD_FRAMES`] by default).
    pub fn set_threshold_frames(&self, frames: i64) {
        self.threshold_frames.store(frames, Ordering::Relaxed);
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
             jink_sqlite_writer_checkpoint_seconds{{stat=\"max\"}} {:.6}\n",
            self.frames(),
            secs(&self.writer_total_us),
            secs(&self.writer_max_us),
        )
    }
}

/// Copies the SQLite WAL into the database file in the background (PASSIVE: it never
/// blocks the writer or readers), often while the WAL is long, so that the writer's
/// checkpoints ([`Wal::on_writer_idle`]) have little left to copy.
pub async fn checkpoint_loop(pool: AnyPool, wal: Arc<Wal>) {
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
        match checkpoint(&pool).await {
            Ok((_, log, _)) => wal.frames.store(log, Ordering::Relaxed),
            Err(e) => tracing::warn!(error = %e, "WAL checkpoint failed"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
