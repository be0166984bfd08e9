//! Moving-obstacle observations, stored in numbered batches.
//!
//! Every accepted batch takes its mission's next sequence number (`missions.obs_seq`,
//! bumped inside the batch's transaction). On PostgreSQL the bump locks the mission row
//! until the commit, so batches of one mission commit in sequence order: once batch `n`
//! is visible, every batch before it is too, and "rows with `seq > n`" is a complete
//! catch-up read. On PostgreSQL the commit also sends `NOTIFY jink_observations,
//! '<seq> <mission id>'` (delivered only if the transaction commits), which other replicas
//! listen to (`crate::live::notify`).
//!
//! The order in which the live state feeds rows to the predictor is the order
//! [`Store::list_observations_through`] returns them in: by sequence number, then time,
//! then obstacle id (byte order, sorted here so that no database collation matters).

use std::collections::HashMap;

use sqlx::{AssertSqlSafe, Row};

use super::{
    AnyQuery, Backend, InsertCounts, ObservationRow, Store, ValuesSql, observation_row, values_sql,
    values_sql_anonymous,
};
use crate::time::to_us;

/// PostgreSQL notification channel announcing committed observation batches; the payload
/// is `"<seq> <mission id>"`.
pub const OBSERVATION_CHANNEL: &str = "jink_observations";

/// One committed observation batch.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredBatch {
    /// The batch's sequence number within its mission (1, 2, ...).
    pub seq: i64,
    /// New and duplicate counts.
    pub counts: InsertCounts,
    /// The rows actually stored (duplicates left out), in feeding order (time, then
    /// obstacle id), with their times as stored (microseconds).
    pub stored: Vec<ObservationRow>,
}

/// Sorts rows into feeding order: time, then obstacle id (bytes).
pub fn sort_feeding_order(rows: &mut [ObservationRow]) {
    rows.sort_by(|a, b| {
        to_us(a.t_s)
            .cmp(&to_us(b.t_s))
            .then_with(|| a.obstacle_id.as_bytes().cmp(b.obstacle_id.as_bytes()))
    });
}

/// Rows per insert statement on PostgreSQL.
const INSERT_CHUNK_ROWS: usize = 32;

/// Rows per insert statement on SQLite, whose statements take anonymous placeholders
/// ([`super::values_sql_anonymous`]): with numbered ones sqlx looks each name up in
/// SQLite's parameter list (linear), so binding cost the square of the parameters (a group
/// of 32 batches of 10 rows in one statement spent more time binding than storing) and
/// statements were kept to 32 rows, each a round trip to the connection's thread.
pub(super) const SQLITE_INSERT_CHUNK_ROWS: usize = 256;

/// One request's rows to store: an observation batch ([`Store::commit_batches`]) or a
/// telemetry post (`Store::commit_group`).
#[derive(Debug)]
pub struct NewRows<'a, R> {
    /// Its mission.
    pub mission_id: &'a str,
    /// Its rows, in any order.
    pub rows: &'a [R],
    /// When it was received, Unix seconds.
    pub received_at_s: f64,
    /// The name of the token that sent it (`local` without one).
    pub writer: &'a str,
}

impl<R> Clone for NewRows<'_, R> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<R> Copy for NewRows<'_, R> {}

/// One observation batch to store (see [`Store::commit_batches`]).
pub type NewBatch<'a> = NewRows<'a, ObservationRow>;

impl Store {
    /// Stores obstacle observations as the mission's next batch, all or none; a row whose
    /// (mission, obstacle, time) is already stored is a duplicate and is not stored again
    /// (the first one wins). `Ok(None)` when the mission does not exist. On SQLite,
    /// batches arriving together share one transaction ([`super::group_commit`]).
    ///
    /// # Errors
    /// Database failures.
    #[tracing::instrument(skip(self, rows), fields(n = rows.len()))]
    pub async fn insert_observations(
        &self,
        mission_id: &str,
        rows: &[ObservationRow],
        received_at_s: f64,
    ) -> Result<Option<StoredBatch>, sqlx::Error> {
        let writer = crate::auth::writer();
        let batch = NewBatch {
            mission_id,
            rows,
            received_at_s,
            writer: &writer,
        };
        if let Some(g) = &self.group {
            // Alone: stored here, without the hand-offs to the group's task and back.
            let one = std::slice::from_ref(&batch);
            if self.takes_script(one)
                && let Some(_lone) = g.try_lone()
            {
                let r = self.commit_script(one).await.map(|mut v| v.pop().flatten());
                self.after_lone_write();
                return r;
            }
            if let Some(r) = g.submit(mission_id, rows, received_at_s, &writer).await {
                return r;
            }
        }
        Ok(self
            .commit_batches(std::slice::from_ref(&batch))
            .await?
            .pop()
            .flatten())
    }

    /// Stores `batches` in one transaction, all or none: per mission (in order of first
    /// appearance) one bump of its batch counter by its number of batches, which take the
    /// consecutive numbers in the order given, and one insert of their rows. Answers per
    /// batch: `None` when its mission does not exist.
    ///
    /// # Errors
    /// Database failures (nothing is stored).
    pub async fn commit_batches(
        &self,
        batches: &[NewBatch<'_>],
    ) -> Result<Vec<Option<StoredBatch>>, sqlx::Error> {
        if self.takes_script(batches) {
            return self.commit_script(batches).await;
        }
        let mut tx = self.write.begin().await?;
        let out = self.batches_in(&mut tx, batches).await?;
        tx.commit().await?;
        Ok(out)
    }

    /// [`Store::commit_batches`]'s work inside the transaction `tx` (not committed here).
    pub(super) async fn batches_in(
        &self,
        tx: &mut sqlx::Transaction<'static, sqlx::Any>,
        batches: &[NewBatch<'_>],
    ) -> Result<Vec<Option<StoredBatch>>, sqlx::Error> {
        let missions = batch_counts(batches);
        if missions.is_empty() {
            return Ok(vec![None; batches.len()]);
        }
        // One statement bumps every mission's counter (one round trip to the database
        // however many missions the group holds); a mission that does not exist returns
        // no row.
        let mut q = sqlx::query(AssertSqlSafe(bump_sql(missions.len(), |k| {
            [format!("${}", 2 * k + 1), format!("${}", 2 * k + 2)]
        })));
        for &(m, n) in &missions {
            q = q.bind(m.to_string()).bind(n);
        }
        let mut last_seq: HashMap<String, i64> = HashMap::new();
        for r in q.fetch_all(&mut **tx).await? {
            last_seq.insert(r.try_get(0)?, r.try_get(1)?);
        }
        let numbers = Numbering::new(batches, &missions, &last_seq);
        let rows: Vec<(&str, i64, i64, &str, &ObservationRow)> = batches
            .iter()
            .zip(&numbers.seqs)
            .filter_map(|(b, seq)| Some((b, (*seq)?)))
            .flat_map(|(b, seq)| {
                let received_us = to_us(b.received_at_s);
                b.rows
                    .iter()
                    .map(move |r| (b.mission_id, seq, received_us, b.writer, r))
            })
            .collect();
        let mut stored: Vec<Vec<ObservationRow>> = vec![Vec::new(); batches.len()];
        let (chunk_rows, values): (usize, ValuesSql) = if self.backend == Backend::Sqlite {
            (SQLITE_INSERT_CHUNK_ROWS, values_sql_anonymous)
        } else {
            (INSERT_CHUNK_ROWS, values_sql)
        };
        for chunk in rows.chunks(chunk_rows) {
            let sql = values(
                &format!("{OBSERVATION_INSERT} VALUES "),
                10,
                chunk.len(),
                &format!(" ON CONFLICT DO NOTHING {OBSERVATION_RETURNING}"),
            );
            let mut q = sqlx::query(AssertSqlSafe(sql));
            for &(mission_id, seq, received_us, writer, r) in chunk {
                q = bind_observation(q, mission_id, r, received_us, seq, writer);
            }
            for r in q.fetch_all(&mut **tx).await? {
                numbers.take_row(&r, &mut stored)?;
            }
        }
        if self.backend == Backend::Postgres {
            for (i, seq) in numbers.seqs.iter().enumerate() {
                let Some(seq) = *seq else { continue };
                sqlx::query("SELECT 1 FROM (SELECT pg_notify($1, $2)) AS n")
                    .bind(OBSERVATION_CHANNEL)
                    .bind(format!("{seq} {}", batches[i].mission_id))
                    .execute(&mut **tx)
                    .await?;
            }
        }
        Ok(numbers.answers(batches, stored))
    }

    /// Whether [`Store::commit_script`] takes `batches`: on SQLite, when their rows fit
    /// one insert statement.
    pub(super) fn takes_script(&self, batches: &[NewBatch<'_>]) -> bool {
        self.backend == Backend::Sqlite
            && !batches.is_empty()
            && batches.iter().map(|b| b.rows.len()).sum::<usize>() <= SQLITE_INSERT_CHUNK_ROWS
    }

    /// [`Store::commit_batches`] on SQLite as one script sent to the connection's thread
    /// at once: `BEGIN`, the bump of the batch counters, the insert (each row's batch
    /// number computed in SQL from its mission's counter as just bumped) and `COMMIT`.
    /// Each statement sent alone is a round trip to sqlx's SQLite thread (a wake-up of
    /// that thread and then of this one, each a wait for a core when both are busy), so
    /// this is one round trip instead of four. The same answers, numbers and rows as the
    /// statements sent one by one (test
    /// `a_batch_stored_by_one_script_is_stored_as_by_one_statement_at_a_time`).
    ///
    /// sqlx's SQLite driver runs every statement of a query and binds anonymous `?`
    /// placeholders across them in order (its `SqliteArguments::bind` takes an offset);
    /// sqlx marks several statements in one query as deprecated (launchbadge/sqlx#3108),
    /// so an upgrade that drops it fails this module's tests rather than storing anything
    /// wrong. On any error the transaction is rolled back before the error is returned,
    /// and the connection is closed if even that fails.
    ///
    /// # Errors
    /// Database failures (nothing is stored); `batches` that [`Store::takes_script`]
    /// refuses.
    pub(super) async fn commit_script(
        &self,
        batches: &[NewBatch<'_>],
    ) -> Result<Vec<Option<StoredBatch>>, sqlx::Error> {
        if !self.takes_script(batches) {
            return Err(sqlx::Error::Protocol(
                "commit_script takes one insert statement's rows on SQLite".into(),
            ));
        }
        let missions = batch_counts(batches);
        let n_rows: usize = batches.iter().map(|b| b.rows.len()).sum();
        let mut sql = format!(
            "BEGIN; {}; ",
            bump_sql(missions.len(), |_| ["?".into(), "?".into()])
        );
        if n_rows > 0 {
            // The ninth value is how many batches of its mission come after the row's
            // in the group: its number is the mission's counter (bumped just above) less
            // that. A mission that does not exist joins no row.
            sql.push_str(&values_sql_anonymous(
                &format!(
                    "{OBSERVATION_INSERT} SELECT v.column1, v.column2, v.column3, v.column4, v.column5, v.column6, v.column7, v.column8, m.obs_seq - v.column9, v.column10 FROM (VALUES "
                ),
                10,
                n_rows,
                &format!(
                    ") AS v, missions AS m WHERE m.id = v.column1 ON CONFLICT DO NOTHING {OBSERVATION_RETURNING}; "
                ),
            ));
        }
        sql.push_str("COMMIT;");
        let mut q = sqlx::query(AssertSqlSafe(sql));
        for &(m, n) in &missions {
            q = q.bind(m.to_string()).bind(n);
        }
        for &(m, _) in &missions {
            q = q.bind(m.to_string());
        }
        let mut after: HashMap<&str, i64> = missions.iter().copied().collect();
        for b in batches {
            let later = after.get_mut(b.mission_id).map_or(0, |n| {
                *n -= 1;
                *n
            });
            let received_us = to_us(b.received_at_s);
            for r in b.rows {
                q = bind_observation(q, b.mission_id, r, received_us, later, b.writer);
            }
        }
        let mut conn = self.write.acquire().await?;
        let rows = match q.fetch_all(&mut *conn).await {
            Ok(rows) => rows,
            Err(e) => {
                if sqlx::query("ROLLBACK").execute(&mut *conn).await.is_err() {
                    conn.close_on_drop();
                }
                return Err(e);
            }
        };
        drop(conn);
        // The counters' rows (two columns) come first, then the stored rows (eight).
        let mut last_seq: HashMap<String, i64> = HashMap::new();
        for r in rows.iter().filter(|r| r.len() == 2) {
            last_seq.insert(r.try_get(0)?, r.try_get(1)?);
        }
        let numbers = Numbering::new(batches, &missions, &last_seq);
        let mut stored: Vec<Vec<ObservationRow>> = vec![Vec::new(); batches.len()];
        for r in rows.iter().filter(|r| r.len() != 2) {
            numbers.take_row(r, &mut stored)?;
        }
        Ok(numbers.answers(batches, stored))
    }

    /// The mission's newest committed batch number (0 before the first batch); `None`
    /// when the mission does not exist.
    ///
    /// # Errors
    /// Database failures.
    pub async fn observation_seq(&self, mission_id: &str) -> Result<Option<i64>, sqlx::Error> {
        let row = sqlx::query("SELECT obs_seq FROM missions WHERE id = $1")
            .bind(mission_id.to_string())
            .fetch_optional(&self.read)
            .await?;
        row.map(|r| r.try_get(0)).transpose()
    }

    /// The rows of batches `after_seq < seq <= through_seq`, in feeding order (sequence
    /// number, time, obstacle id), each with its batch number.
    ///
    /// # Errors
    /// Database failures.
    #[tracing::instrument(skip(self))]
    pub async fn list_observations_through(
        &self,
        mission_id: &str,
        after_seq: i64,
        through_seq: i64,
    ) -> Result<Vec<(i64, ObservationRow)>, sqlx::Error> {
        let rows = sqlx::query(
            "SELECT obstacle_id, t_us, lat_deg, lon_deg, alt_msl_m, radius_m, seq FROM obstacle_observations \
             WHERE mission_id = $1 AND seq > $2 AND seq <= $3 ORDER BY seq, t_us",
        )
        .bind(mission_id.to_string())
        .bind(after_seq)
        .bind(through_seq)
        .fetch_all(&self.read)
        .await?;
        let mut out = rows
            .iter()
            .map(|r| Ok((r.try_get::<i64, _>(6)?, observation_row(r)?)))
            .collect::<Result<Vec<_>, sqlx::Error>>()?;
        out.sort_by(|(sa, a), (sb, b)| {
            sa.cmp(sb)
                .then_with(|| to_us(a.t_s).cmp(&to_us(b.t_s)))
                .then_with(|| a.obstacle_id.as_bytes().cmp(b.obstacle_id.as_bytes()))
        });
        Ok(out)
    }
}

/// The observation inserts' head: the ten columns [`bind_observation`] binds, in order.
const OBSERVATION_INSERT: &str = "INSERT INTO obstacle_observations (mission_id, obstacle_id, t_us, lat_deg, lon_deg, alt_msl_m, radius_m, received_at_us, seq, written_by)";

/// What the observation inserts return of each stored row: [`observation_row`]'s six
/// columns, then the batch number and the mission ([`Numbering::take_row`]).
const OBSERVATION_RETURNING: &str =
    "RETURNING obstacle_id, t_us, lat_deg, lon_deg, alt_msl_m, radius_m, seq, mission_id";

/// The statement that bumps the batch counters of `n` missions at once, returning each
/// existing mission's id and new counter (a mission that does not exist returns no row);
/// `marks(k)` gives the placeholders of the `k`-th mission's id and count (its id is
/// bound again for `IN` when they are anonymous).
fn bump_sql(n: usize, marks: impl Fn(usize) -> [String; 2]) -> String {
    let marks: Vec<[String; 2]> = (0..n).map(marks).collect();
    let cases: String = marks
        .iter()
        .map(|[id, count]| format!(" WHEN {id} THEN {count}"))
        .collect();
    let ids = marks
        .iter()
        .map(|[id, _]| id.as_str())
        .collect::<Vec<_>>()
        .join(",");
    format!(
        "UPDATE missions SET obs_seq = obs_seq + CASE id{cases} END WHERE id IN ({ids}) RETURNING id, obs_seq"
    )
}

/// Binds one observation's ten values (mission, obstacle, time, position, radius, time of
/// receipt, `seq`, writer) in the order of the inserts' column lists; `seq` is the batch
/// number, or in [`Store::commit_script`] how many batches of the mission come after it.
fn bind_observation<'q>(
    q: AnyQuery<'q>,
    mission_id: &str,
    r: &ObservationRow,
    received_us: i64,
    seq: i64,
    writer: &str,
) -> AnyQuery<'q> {
    q.bind(mission_id.to_string())
        .bind(r.obstacle_id.clone())
        .bind(to_us(r.t_s))
        .bind(r.lat_deg)
        .bind(r.lon_deg)
        .bind(r.alt_msl_m)
        .bind(r.radius_m)
        .bind(received_us)
        .bind(seq)
        .bind(writer.to_string())
}

/// The missions of `batches` in order of first appearance, each with its number of
/// batches.
fn batch_counts<'a>(batches: &[NewBatch<'a>]) -> Vec<(&'a str, i64)> {
    let mut missions: Vec<(&str, i64)> = Vec::new();
    for b in batches {
        match missions.iter_mut().find(|(m, _)| *m == b.mission_id) {
            Some((_, n)) => *n += 1,
            None => missions.push((b.mission_id, 1)),
        }
    }
    missions
}

/// The numbers a group's batches took: each batch of an existing mission the next of its
/// mission's numbers, in the order given.
struct Numbering<'a> {
    /// Per batch, its number (`None`: its mission does not exist).
    seqs: Vec<Option<i64>>,
    /// The batch of each (mission, number).
    batch_of: HashMap<(&'a str, i64), usize>,
}

impl<'a> Numbering<'a> {
    /// `last_seq`: each existing mission's counter after the bump by its count in
    /// `missions` ([`batch_counts`]).
    fn new(
        batches: &[NewBatch<'a>],
        missions: &[(&'a str, i64)],
        last_seq: &HashMap<String, i64>,
    ) -> Self {
        let mut next_seq: HashMap<&str, i64> = missions
            .iter()
            .filter_map(|&(m, n)| Some((m, last_seq.get(m)? - n + 1)))
            .collect();
        let mut batch_of = HashMap::new();
        let mut seqs = vec![None; batches.len()];
        for (i, b) in batches.iter().enumerate() {
            if let Some(seq) = next_seq.get_mut(b.mission_id) {
                seqs[i] = Some(*seq);
                batch_of.insert((b.mission_id, *seq), i);
                *seq += 1;
            }
        }
        Self { seqs, batch_of }
    }

    /// Files a row the insert returned (obstacle, time, position, radius, number,
    /// mission) under its batch.
    fn take_row(
        &self,
        r: &sqlx::any::AnyRow,
        stored: &mut [Vec<ObservationRow>],
    ) -> Result<(), sqlx::Error> {
        let (seq, mission_id): (i64, String) = (r.try_get(6)?, r.try_get(7)?);
        let k = self
            .batch_of
            .get(&(mission_id.as_str(), seq))
            .ok_or_else(|| {
                sqlx::Error::Protocol(format!("unexpected batch {seq} of {mission_id}"))
            })?;
        stored[*k].push(observation_row(r)?);
        Ok(())
    }

    /// Each batch's answer from the rows filed under it.
    fn answers(
        &self,
        batches: &[NewBatch<'_>],
        stored: Vec<Vec<ObservationRow>>,
    ) -> Vec<Option<StoredBatch>> {
        self.seqs
            .iter()
            .zip(stored)
            .zip(batches)
            .map(|((seq, mut st), b)| {
                let seq = (*seq)?;
                sort_feeding_order(&mut st);
                let accepted = st.len() as u64;
                Some(StoredBatch {
                    seq,
                    counts: InsertCounts {
                        accepted,
                        duplicate: b.rows.len() as u64 - accepted,
                    },
                    stored: st,
                })
            })
            .collect()
    }
}
