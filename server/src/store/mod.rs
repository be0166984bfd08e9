//! Persistence behind one type, [`Store`], over SQLite or PostgreSQL (sqlx's `Any` driver,
//! chosen by URL at run time; runtime-checked queries; one migrations folder per dialect).
//!
//! Durability: SQLite runs in WAL mode with `synchronous=NORMAL`, which keeps every
//! committed transaction across a crash of the process (kill -9); only an operating-system
//! crash or power loss can lose the last transactions. Writes to SQLite go through a
//! single connection (SQLite has one writer anyway), so they queue in-process instead of
//! spinning on `SQLITE_BUSY`.

use std::str::FromStr;
use std::time::Duration;

use sqlx::any::{AnyConnectOptions, AnyPoolOptions};
use sqlx::{AnyPool, AssertSqlSafe, Executor, Row};

use crate::mission::Mission;
use crate::time::{from_us, to_us};
use wire::ids::MissionId;

pub mod group_commit;
pub mod observations;
pub mod plans;
pub mod recent;
pub mod tokens;
pub mod wal;
pub mod writer;
pub mod writers;

/// A runtime-checked query on the `Any` driver.
type AnyQuery<'q> = sqlx::query::Query<'q, sqlx::Any, sqlx::any::AnyArguments>;

/// Which database a store talks to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// A SQLite file.
    Sqlite,
    /// A PostgreSQL server.
    Postgres,
}

/// A moving-obstacle observation as stored: the validated wire value.
pub use wire::telemetry::Observation as ObservationRow;

/// An aircraft telemetry sample as stored: the validated wire value.
pub use wire::telemetry::AircraftSample as TelemetryRow;

/// How many rows of a batch were new and how many were already stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct InsertCounts {
    /// Newly stored.
    pub accepted: u64,
    /// Already stored (same key); not stored again.
    pub duplicate: u64,
}

/// The service's storage.
#[derive(Clone, Debug)]
pub struct Store {
    backend: Backend,
    read: AnyPool,
    write: AnyPool,
    /// SQLite: the group-commit task observation batches and telemetry go through.
    group: Option<group_commit::GroupCommit>,
    /// SQLite: the runtime the frequent writes run on ([`writer`]).
    writer: Option<writer::WriterThread>,
    /// SQLite: what the checkpoints know of the WAL ([`wal`]).
    wal: Option<std::sync::Arc<wal::Wal>>,
    /// SQLite (one replica): the newest of what a plan reads, in memory ([`recent`]).
    recent: Option<std::sync::Arc<recent::Recent>>,
}

/// Errors opening a store.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OpenError {
    /// The URL is neither `sqlite:` nor `postgres:`; fix `--database-url`.
    #[error("unsupported database URL '{0}': use sqlite://FILE or postgres://USER@HOST/DB")]
    UnsupportedUrl(String),
    /// Connecting failed; check the server is up and the URL is right.
    #[error("cannot connect to the database: {0}")]
    Connect(#[source] sqlx::Error),
    /// A migration failed; the database may be from a newer jink.
    #[error("database migration failed: {0}")]
    Migrate(#[source] sqlx::migrate::MigrateError),
}

// Checkpoints run in a background task and, briefly, when the group commit is idle
// ([`wal`]), not inside a writer's commit, so that a commit never stalls behind copying
// the WAL into the database file. `journal_size_limit` cuts the WAL file back when it
// starts over ([`wal::JOURNAL_SIZE_LIMIT_BYTES`]).
const SQLITE_PRAGMAS: &str = "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA busy_timeout=10000; \
     PRAGMA foreign_keys=ON; PRAGMA wal_autocheckpoint=0;";

/// `PRAGMA journal_size_limit` at [`wal::JOURNAL_SIZE_LIMIT_BYTES`], run after
/// [`SQLITE_PRAGMAS`] on every SQLite connection.
static JOURNAL_SIZE_LIMIT: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
    format!(
        "PRAGMA journal_size_limit={}",
        wal::JOURNAL_SIZE_LIMIT_BYTES
    )
});

impl Store {
    /// Opens (creating a SQLite file if needed) and migrates the database at `url`.
    ///
    /// # Errors
    /// [`OpenError`] when the URL is unsupported, the connection fails or migrating fails.
    pub async fn open(url: &str) -> Result<Self, OpenError> {
        sqlx::any::install_default_drivers();
        let backend = if url.starts_with("sqlite:") {
            Backend::Sqlite
        } else if url.starts_with("postgres:") || url.starts_with("postgresql:") {
            Backend::Postgres
        } else {
            return Err(OpenError::UnsupportedUrl(url.to_string()));
        };
        let (read, write) = match backend {
            Backend::Sqlite => {
                let url = if url.contains("mode=") {
                    url.to_string()
                } else if url.contains('?') {
                    format!("{url}&mode=rwc")
                } else {
                    format!("{url}?mode=rwc")
                };
                let opts = AnyConnectOptions::from_str(&url).map_err(OpenError::Connect)?;
                let pool = |n: u32| {
                    AnyPoolOptions::new()
                        .max_connections(n)
                        // Every connection opened at start, none on a request's path.
                        .min_connections(n)
                        // No ping (a round trip to the connection's thread) before each
                        // use: a connection to a local file does not go stale.
                        .test_before_acquire(false)
                        .acquire_timeout(Duration::from_secs(30))
                        .after_connect(|conn, _| {
                            Box::pin(async move {
                                conn.execute(SQLITE_PRAGMAS).await?;
                                conn.execute(JOURNAL_SIZE_LIMIT.as_str()).await?;
                                Ok(())
                            })
                        })
                };
                let write = pool(1)
                    .connect_with(opts.clone())
                    .await
                    .map_err(OpenError::Connect)?;
                let read = pool(4)
                    .connect_with(opts)
                    .await
                    .map_err(OpenError::Connect)?;
                (read, write)
            }
            Backend::Postgres => {
                let pool = AnyPoolOptions::new()
                    .max_connections(16)
                    .acquire_timeout(Duration::from_secs(30))
                    .connect(url)
                    .await
                    .map_err(OpenError::Connect)?;
                (pool.clone(), pool)
            }
        };
        let mut store = Self {
            backend,
            read,
            write,
            group: None,
            writer: None,
            wal: None,
            recent: None,
        };
        store.migrate().await?;
        if backend == Backend::Sqlite {
            let w = wal::Wal::new();
            tokio::spawn(wal::checkpoint_loop(
                store.read.clone(),
                store.write.clone(),
                w.clone(),
            ));
            store.wal = Some(w);
            let writer = writer::WriterThread::spawn().map_err(|e| OpenError::Connect(e.into()))?;
            store.group = Some(group_commit::GroupCommit::spawn(store.clone(), &writer));
            store.writer = Some(writer);
            store.recent = Some(std::sync::Arc::new(recent::Recent::default()));
        }
        Ok(store)
    }

    async fn migrate(&self) -> Result<(), OpenError> {
        match self.backend {
            Backend::Sqlite => {
                sqlx::migrate!("../migrations/sqlite")
                    .run(&self.write)
                    .await
            }
            Backend::Postgres => {
                sqlx::migrate!("../migrations/postgres")
                    .run(&self.write)
                    .await
            }
        }
        .map_err(OpenError::Migrate)
    }

    /// SQLite: what the checkpoints know of the WAL (`None` on PostgreSQL).
    pub fn wal(&self) -> Option<&wal::Wal> {
        self.wal.as_deref()
    }

    /// After a lone write ([`group_commit::GroupCommit::try_lone`]): what the group's task
    /// does when its queue empties, a checkpoint on the write connection when the WAL is
    /// long and one is due ([`wal::Wal::on_writer_idle`]), on the writer's runtime, so that
    /// the request that wrote does not wait for it.
    pub(crate) fn after_lone_write(&self) {
        if let (Some(wal), Some(writer)) = (&self.wal, &self.writer)
            && wal.long()
        {
            let (wal, pool) = (wal.clone(), self.write.clone());
            writer.spawn_task(async move { wal.on_writer_idle(&pool).await });
        }
    }

    /// Writes stored directly, without the group's task (SQLite; 0 elsewhere).
    pub fn lone_writes(&self) -> u64 {
        self.group
            .as_ref()
            .map_or(0, group_commit::GroupCommit::lone_writes)
    }

    /// Which database this is.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The pool for writes (a single connection on SQLite).
    pub fn write_pool(&self) -> &AnyPool {
        &self.write
    }

    /// The pool for reads.
    pub fn read_pool(&self) -> &AnyPool {
        &self.read
    }

    /// Flushes and closes the store at shutdown: waits for the transactions in flight
    /// (the SQLite group commit's included) to finish, checkpoints the SQLite WAL into the
    /// database file, and closes both pools.
    pub async fn close(&self) {
        if self.backend == Backend::Sqlite
            && let Err(e) = sqlx::query("PRAGMA wal_checkpoint(TRUNCATE)")
                .execute(&self.write)
                .await
        {
            tracing::warn!(error = %e, "final WAL checkpoint failed (the WAL keeps the data)");
        }
        self.write.close().await;
        self.read.close().await;
    }

    /// Checks the database answers.
    #[tracing::instrument(skip(self))]
    pub async fn ping(&self) -> Result<(), sqlx::Error> {
        sqlx::query("SELECT 1")
            .execute(&self.read)
            .await
            .map(|_| ())
    }

    // ---- missions ----------------------------------------------------------------------

    /// Stores missions, all or none.
    #[tracing::instrument(skip_all, fields(n = missions.len()))]
    pub async fn insert_missions(
        &self,
        missions: &[Mission],
        created_at_s: f64,
    ) -> Result<(), sqlx::Error> {
        let mut tx = self.write.begin().await?;
        for m in missions {
            let body = serde_json::to_string(m).map_err(|e| sqlx::Error::Encode(Box::new(e)))?;
            sqlx::query("INSERT INTO missions (id, created_at_us, source_format, body, written_by) VALUES ($1, $2, $3, $4, $5)")
                .bind(m.id.0.clone())
                .bind(to_us(created_at_s))
                .bind(m.source_format.as_str())
                .bind(body)
                .bind(crate::auth::writer())
                .execute(&mut *tx)
                .await?;
        }
        tx.commit().await
    }

    /// One mission, if it exists.
    #[tracing::instrument(skip(self))]
    pub async fn get_mission(&self, id: &MissionId) -> Result<Option<Mission>, sqlx::Error> {
        let Some(recent) = &self.recent else {
            return self.read_mission(id).await;
        };
        if let Some(m) = recent.mission(&id.0) {
            return Ok(Some(Mission::clone(&m)));
        }
        let epoch = recent.epoch(&id.0);
        let m = self.read_mission(id).await?;
        if let Some(m) = &m {
            recent.fill_mission(epoch, m);
        }
        Ok(m)
    }

    /// One mission, read from the database.
    async fn read_mission(&self, id: &MissionId) -> Result<Option<Mission>, sqlx::Error> {
        let row = sqlx::query("SELECT body FROM missions WHERE id = $1")
            .bind(id.to_string())
            .fetch_optional(&self.read)
            .await?;
        row.map(|r| decode_mission(&r.try_get::<String, _>(0)?))
            .transpose()
    }

    /// True when the mission exists.
    pub async fn mission_exists(&self, id: &MissionId) -> Result<bool, sqlx::Error> {
        let row = sqlx::query("SELECT 1 FROM missions WHERE id = $1")
            .bind(id.to_string())
            .fetch_optional(&self.read)
            .await?;
        Ok(row.is_some())
    }

    /// All missions, oldest first.
    #[tracing::instrument(skip(self))]
    pub async fn list_missions(&self) -> Result<Vec<Mission>, sqlx::Error> {
        let rows = sqlx::query("SELECT body FROM missions ORDER BY created_at_us, id")
            .fetch_all(&self.read)
            .await?;
        rows.iter()
            .map(|r| decode_mission(&r.try_get::<String, _>(0)?))
            .collect()
    }

    /// Deletes a mission and everything recorded for it. False when it did not exist.
    #[tracing::instrument(skip(self))]
    pub async fn delete_mission(&self, id: &MissionId) -> Result<bool, sqlx::Error> {
        let deleted = self.delete_mission_here(id).await;
        // Also on an error: the deletion may have committed.
        if let Some(recent) = &self.recent {
            recent.forget(&id.0);
        }
        deleted
    }

    async fn delete_mission_here(&self, id: &MissionId) -> Result<bool, sqlx::Error> {
        let mut tx = self.write.begin().await?;
        for table in CHILD_TABLES {
            let sql = format!("DELETE FROM {table} WHERE mission_id = $1");
            sqlx::query(AssertSqlSafe(sql))
                .bind(id.to_string())
                .execute(&mut *tx)
                .await?;
        }
        let n = sqlx::query("DELETE FROM missions WHERE id = $1")
            .bind(id.to_string())
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(n.rows_affected() > 0)
    }

    // ---- telemetry ---------------------------------------------------------------------

    /// Inserts `rows` in one transaction with `ON CONFLICT DO NOTHING`, `cols` placeholders
    /// per row bound by `bind`, and counts how many were new.
    async fn insert_batch<T>(
        &self,
        head: &str,
        cols: usize,
        rows: &[T],
        bind: impl for<'q> Fn(AnyQuery<'q>, &T) -> AnyQuery<'q>,
    ) -> Result<InsertCounts, sqlx::Error> {
        // Keep statements to a bounded number of parameters (SQLite's default limit is
        // 32766; PostgreSQL's 65535).
        const CHUNK_ROWS: usize = 500;
        if rows.len() <= CHUNK_ROWS {
            // One statement is atomic on its own: no BEGIN/COMMIT round trips to the
            // database (on SQLite, two fewer hops to its connection thread per sample).
            let sql = values_sql(head, cols, rows.len(), " ON CONFLICT DO NOTHING");
            let mut q = sqlx::query(AssertSqlSafe(sql));
            for r in rows {
                q = bind(q, r);
            }
            let accepted = q.execute(&self.write).await?.rows_affected();
            return Ok(InsertCounts {
                accepted,
                duplicate: rows.len() as u64 - accepted,
            });
        }
        let mut tx = self.write.begin().await?;
        let mut accepted = 0;
        for chunk in rows.chunks(CHUNK_ROWS) {
            let sql = values_sql(head, cols, chunk.len(), " ON CONFLICT DO NOTHING");
            let mut q = sqlx::query(AssertSqlSafe(sql));
            for r in chunk {
                q = bind(q, r);
            }
            accepted += q.execute(&mut *tx).await?.rows_affected();
        }
        tx.commit().await?;
        Ok(InsertCounts {
            accepted,
            duplicate: rows.len() as u64 - accepted,
        })
    }

    /// A mission's observations ordered by time (then obstacle), optionally of one
    /// obstacle and after a time.
    #[tracing::instrument(skip(self))]
    pub async fn list_observations(
        &self,
        mission_id: &MissionId,
        obstacle_id: Option<&str>,
        after_s: Option<f64>,
    ) -> Result<Vec<ObservationRow>, sqlx::Error> {
        let rows = self
            .list_observations_written(mission_id, obstacle_id, after_s)
            .await?;
        Ok(rows.into_iter().map(|(row, _writer)| row).collect())
    }

    /// A mission's observations with `after_us < t <= until_us` that had been received by
    /// `received_until_us`, ordered by time then obstacle: the exact set a plan used, for
    /// replaying it later.
    #[tracing::instrument(skip(self))]
    pub async fn list_observations_window(
        &self,
        mission_id: &MissionId,
        after_us: i64,
        until_us: i64,
        received_until_us: i64,
    ) -> Result<Vec<ObservationRow>, sqlx::Error> {
        let rows = sqlx::query(
            "SELECT obstacle_id, t_us, lat_deg, lon_deg, alt_msl_m, radius_m FROM obstacle_observations \
             WHERE mission_id = $1 AND t_us > $2 AND t_us <= $3 AND received_at_us <= $4 ORDER BY t_us, obstacle_id",
        )
        .bind(mission_id.to_string())
        .bind(after_us)
        .bind(until_us)
        .bind(received_until_us)
        .fetch_all(&self.read)
        .await?;
        rows.iter().map(observation_row).collect()
    }

    /// Stores aircraft telemetry, all or none; a sample at an already stored time is a
    /// duplicate. `Ok(None)` when the mission does not exist. On SQLite, a post arriving
    /// while no other write is outstanding is stored by the caller's task (one statement,
    /// [`Store::commit_posts`]); posts arriving together share one transaction with the
    /// observation batches waiting then (`group_commit`), on the writer thread (`writer`).
    #[tracing::instrument(skip(self, rows), fields(n = rows.len()))]
    pub async fn insert_telemetry(
        &self,
        mission_id: &MissionId,
        rows: &[TelemetryRow],
        received_at_s: f64,
    ) -> Result<Option<InsertCounts>, sqlx::Error> {
        let writer = crate::auth::writer();
        let lone = self
            .group
            .as_ref()
            .filter(|_| rows.len() <= group_commit::TELEMETRY_CHUNK_ROWS)
            .and_then(group_commit::GroupCommit::try_lone);
        let stored = if let Some(_lone) = lone {
            // Alone and small enough for one statement: stored here, without the
            // hand-offs to the group's task and back (as a lone observation batch).
            let post = group_commit::NewTelemetry {
                mission_id: &mission_id.0,
                rows,
                received_at_s,
                writer: &writer,
            };
            let r = self
                .commit_posts(std::slice::from_ref(&post))
                .await
                .map(|mut v| v.pop().flatten());
            self.after_lone_write();
            Some(r)
        } else if let Some(g) = &self.group {
            g.submit_telemetry(&mission_id.0, rows, received_at_s, &writer)
                .await
        } else {
            None
        };
        let stored = match stored {
            Some(r) => r,
            None => missing_mission(
                self.insert_telemetry_inner(mission_id, rows, received_at_s, &writer)
                    .await,
            ),
        };
        if let Some(recent) = &self.recent {
            match &stored {
                // No mission: nothing stored.
                Ok(None) => {}
                Ok(Some(c)) => recent.telemetry_written(
                    &mission_id.0,
                    rows,
                    c.duplicate == 0 && c.accepted == rows.len() as u64,
                ),
                Err(_) => recent.telemetry_written(&mission_id.0, rows, false),
            }
        }
        stored
    }

    async fn insert_telemetry_inner(
        &self,
        mission_id: &MissionId,
        rows: &[TelemetryRow],
        received_at_s: f64,
        writer: &str,
    ) -> Result<InsertCounts, sqlx::Error> {
        if rows.is_empty() {
            return self.empty_batch(mission_id).await;
        }
        let received_us = to_us(received_at_s);
        self.insert_batch(TELEMETRY_INSERT, TELEMETRY_COLUMNS, rows, |q, r| {
            bind_telemetry(q, &mission_id.0, r, received_us, writer)
        })
        .await
    }

    /// An empty batch stores nothing but still fails like an insert for a missing mission.
    async fn empty_batch(&self, mission_id: &MissionId) -> Result<InsertCounts, sqlx::Error> {
        if self.mission_exists(mission_id).await? {
            Ok(InsertCounts::default())
        } else {
            Err(sqlx::Error::RowNotFound)
        }
    }

    /// A mission's aircraft telemetry ordered by time; `last` keeps only the newest n.
    #[tracing::instrument(skip(self))]
    pub async fn list_telemetry(
        &self,
        mission_id: &MissionId,
        last: Option<u32>,
    ) -> Result<Vec<TelemetryRow>, sqlx::Error> {
        if let Some(recent) = &self.recent
            && let Some(n) = last.map(|n| n as usize)
            && n <= recent::TELEMETRY_TAIL
        {
            if let Some(rows) = recent.telemetry(&mission_id.0, n) {
                return Ok(rows);
            }
            let epoch = recent.epoch(&mission_id.0);
            let tail = self
                .list_telemetry_written(mission_id, Some(recent::TELEMETRY_TAIL as u32))
                .await?;
            let tail: Vec<TelemetryRow> = tail.into_iter().map(|(row, _writer)| row).collect();
            recent.fill_telemetry(&mission_id.0, epoch, &tail);
            return Ok(tail[tail.len().saturating_sub(n)..].to_vec());
        }
        let rows = self.list_telemetry_written(mission_id, last).await?;
        Ok(rows.into_iter().map(|(row, _writer)| row).collect())
    }

    /// A mission's aircraft telemetry at or after `since_s` (seconds), ordered by time: the
    /// newest `last` samples of it.
    #[tracing::instrument(skip(self))]
    pub async fn list_telemetry_since(
        &self,
        mission_id: &MissionId,
        since_s: f64,
        last: u32,
    ) -> Result<Vec<TelemetryRow>, sqlx::Error> {
        let rows = sqlx::query(
            "SELECT t_us, lat_deg, lon_deg, alt_msl_m, heading_deg, speed_mps FROM aircraft_telemetry \
             WHERE mission_id = $1 AND t_us >= $2 ORDER BY t_us DESC LIMIT $3",
        )
        .bind(mission_id.to_string())
        .bind(to_us(since_s))
        .bind(i64::from(last))
        .fetch_all(&self.read)
        .await?;
        let mut out = rows
            .iter()
            .map(|r| writers::telemetry_row_at(r, 0))
            .collect::<Result<Vec<_>, sqlx::Error>>()?;
        out.reverse();
        Ok(out)
    }
}

/// The head of a telemetry insert (`values_sql` adds the rows) and its columns per row, in
/// the order [`bind_telemetry`] binds them.
pub(crate) const TELEMETRY_INSERT: &str = "INSERT INTO aircraft_telemetry (mission_id, t_us, lat_deg, lon_deg, alt_msl_m, heading_deg, speed_mps, received_at_us, written_by) VALUES ";
pub(crate) const TELEMETRY_COLUMNS: usize = 9;

/// Binds one telemetry sample's row of [`TELEMETRY_INSERT`].
pub(crate) fn bind_telemetry<'q>(
    q: AnyQuery<'q>,
    mission_id: &str,
    r: &TelemetryRow,
    received_us: i64,
    writer: &str,
) -> AnyQuery<'q> {
    q.bind(mission_id.to_string())
        .bind(to_us(r.t_s))
        .bind(r.lat_deg)
        .bind(r.lon_deg)
        .bind(r.alt_msl_m)
        .bind(r.heading_deg)
        .bind(r.speed_mps)
        .bind(received_us)
        .bind(writer.to_string())
}

/// `Ok(None)` for an insert that failed because its mission does not exist.
pub(crate) fn missing_mission<T>(r: Result<T, sqlx::Error>) -> Result<Option<T>, sqlx::Error> {
    match r {
        Ok(v) => Ok(Some(v)),
        Err(sqlx::Error::Database(e))
            if e.kind() == sqlx::error::ErrorKind::ForeignKeyViolation =>
        {
            Ok(None)
        }
        Err(sqlx::Error::RowNotFound) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Tables whose rows belong to a mission (deleted with it). Later migrations add theirs.
pub const CHILD_TABLES: &[&str] = &[
    "obstacle_observations",
    "aircraft_telemetry",
    "plans",
    "interop_links",
    "interop_forwarded",
    "interop_numbers",
];

/// Decodes `SELECT obstacle_id, t_us, lat_deg, lon_deg, alt_msl_m, radius_m`.
pub(crate) fn observation_row(r: &sqlx::any::AnyRow) -> Result<ObservationRow, sqlx::Error> {
    Ok(ObservationRow {
        obstacle_id: r.try_get(0)?,
        t_s: from_us(r.try_get(1)?),
        lat_deg: r.try_get(2)?,
        lon_deg: r.try_get(3)?,
        alt_msl_m: r.try_get(4)?,
        radius_m: r.try_get(5)?,
    })
}

fn decode_mission(body: &str) -> Result<Mission, sqlx::Error> {
    serde_json::from_str(body).map_err(|e| sqlx::Error::Decode(Box::new(e)))
}

/// `INSERT ... VALUES ($1,..,$k), ($k+1,..) <tail>` for `rows` rows of `cols` columns.
/// Only placeholders are generated: no value is ever spliced into the SQL.
pub(crate) fn values_sql(head: &str, cols: usize, rows: usize, tail: &str) -> String {
    use std::fmt::Write as _;
    values_rows(head, rows * cols * 5, rows, tail, |s, r| {
        for c in 0..cols {
            if c > 0 {
                s.push(',');
            }
            let _ = write!(s, "${}", r * cols + c + 1);
        }
    })
}

/// `head`, then `rows` parenthesised rows separated by commas, each written by `row`
/// (given its index), then `tail`.
fn values_rows(
    head: &str,
    size_hint: usize,
    rows: usize,
    tail: &str,
    mut row: impl FnMut(&mut String, usize),
) -> String {
    let mut s = String::with_capacity(head.len() + size_hint + 3 * rows + tail.len());
    s.push_str(head);
    for r in 0..rows {
        if r > 0 {
            s.push(',');
        }
        s.push('(');
        row(&mut s, r);
        s.push(')');
    }
    s.push_str(tail);
    s
}

/// [`values_sql`] or [`values_sql_anonymous`].
pub(crate) type ValuesSql = fn(&str, usize, usize, &str) -> String;

/// As [`values_sql`] with anonymous `?` placeholders, for SQLite: sqlx binds a numbered
/// `$n` by looking its name up in the statement's parameter list (linear in the
/// parameters, so binding a statement costs their square), an anonymous one by position.
/// Values are bound in the same row-major order.
pub(crate) fn values_sql_anonymous(head: &str, cols: usize, rows: usize, tail: &str) -> String {
    let row = vec!["?"; cols].join(",");
    values_rows(head, rows * row.len(), rows, tail, |s, _| s.push_str(&row))
}

/// Which of `ids` are missions, read through `conn` (inside a writer's transaction or
/// statement sequence, so the answer matches what its inserts saw). One query.
pub(crate) async fn existing_missions(
    conn: &mut sqlx::AnyConnection,
    ids: &[&str],
) -> Result<std::collections::HashSet<String>, sqlx::Error> {
    let mut found = std::collections::HashSet::new();
    if ids.is_empty() {
        return Ok(found);
    }
    let marks = (1..=ids.len())
        .map(|i| format!("${i}"))
        .collect::<Vec<_>>()
        .join(",");
    let mut q = sqlx::query(sqlx::AssertSqlSafe(format!(
        "SELECT id FROM missions WHERE id IN ({marks})"
    )));
    for m in ids {
        q = q.bind(m.to_string());
    }
    for r in q.fetch_all(&mut *conn).await? {
        found.insert(r.try_get::<String, _>(0)?);
    }
    Ok(found)
}

/// Whether `e` is the database refusing a write for a constraint of `kind` (a name or
/// revision already taken, a missing parent row): the callers' typed errors.
fn violates(e: &sqlx::Error, kind: sqlx::error::ErrorKind) -> bool {
    matches!(e, sqlx::Error::Database(d) if d.kind() == kind)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_sql_numbers_placeholders_row_major() {
        assert_eq!(
            values_sql("INSERT INTO t VALUES ", 2, 2, ";"),
            "INSERT INTO t VALUES ($1,$2),($3,$4);"
        );
        assert_eq!(
            values_sql_anonymous("INSERT INTO t VALUES ", 2, 3, ";"),
            "INSERT INTO t VALUES (?,?),(?,?),(?,?);"
        );
    }
}
