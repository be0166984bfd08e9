//! The newest of what a plan reads, kept in memory beside a single-replica store (SQLite,
//! where this process is the only writer: one `jink serve` per SQLite file): per mission,
//! the mission itself (missions never change once stored), its newest aircraft telemetry
//! samples and its latest plan revision with that revision's row. A plan then reads none
//! of them from the database (issue 9: the three reads and the base revision's cost 0.6-1.0
//! ms at p50 of a plan's 4-5 ms on loopback).
//!
//! Contracts:
//! - **What the store would answer**: every value is the one a read of the database would
//!   give at that moment. Each entry is filled by a read of the database and then kept up
//!   to date by this process's own writes once they have committed; a write whose effect
//!   it cannot mirror exactly (a telemetry post with a duplicate time, a failed write that
//!   may have committed) drops the part it touched, which the next read fills again.
//! - **No stale fill**: a fill read from the database is kept only when no write to that
//!   mission happened while it was read (each write moves the entry's `epoch`; deleting
//!   the mission removes the entry).
//! - **Bounded**: at most [`MAX_ENTRIES`] missions, the least recently used dropped first.
//!
//! PostgreSQL stores have none of this: other replicas write to the same database, so
//! every read goes to it.

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex};

use super::TelemetryRow;
use super::plans::PlanRow;
use crate::mission::Mission;
use crate::time::{from_us, to_us};

/// Most missions kept.
pub const MAX_ENTRIES: usize = 4096;

/// Newest telemetry samples kept per mission: a read of at most this many is answered
/// from memory.
pub const TELEMETRY_TAIL: usize = 32;

#[derive(Default)]
struct Entry {
    mission: Option<Arc<Mission>>,
    /// The newest samples in time order (at most [`TELEMETRY_TAIL`]); `None`: not known.
    telemetry: Option<VecDeque<TelemetryRow>>,
    /// The latest revision (0: none yet) and, once read or written, its row.
    latest: Option<(i64, Option<Arc<PlanRow>>)>,
    /// Moves at every write to the mission (see the module's contracts).
    epoch: u64,
    /// Last use, for dropping the least recently used.
    used: u64,
}

#[derive(Default)]
struct Inner {
    entries: HashMap<String, Entry>,
    /// A counter that orders uses and writes.
    tick: u64,
}

/// See the module documentation.
#[derive(Default)]
pub struct Recent {
    inner: Mutex<Inner>,
}

impl std::fmt::Debug for Recent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recent")
            .field("missions", &self.lock().entries.len())
            .finish()
    }
}

/// A fill ticket: the entry's epoch when a read of the database began.
#[derive(Debug, Clone, Copy)]
pub struct Epoch(u64);

/// A telemetry sample as the database gives it back: the time in whole microseconds, and
/// no negative zero (SQLite stores an integral REAL as an integer).
fn as_stored(r: &TelemetryRow) -> TelemetryRow {
    TelemetryRow {
        t_s: from_us(to_us(r.t_s)),
        lat_deg: r.lat_deg + 0.0,
        lon_deg: r.lon_deg + 0.0,
        alt_msl_m: r.alt_msl_m + 0.0,
        heading_deg: r.heading_deg + 0.0,
        speed_mps: r.speed_mps.map(|v| v + 0.0),
    }
}

impl Inner {
    /// The entry of `id`, created when missing, marked used.
    fn entry(&mut self, id: &str) -> &mut Entry {
        self.tick += 1;
        let tick = self.tick;
        if !self.entries.contains_key(id) {
            if self.entries.len() >= MAX_ENTRIES
                && let Some(oldest) = self
                    .entries
                    .iter()
                    .min_by_key(|(_, e)| e.used)
                    .map(|(k, _)| k.clone())
            {
                self.entries.remove(&oldest);
            }
            self.entries.insert(
                id.to_string(),
                Entry {
                    epoch: tick,
                    ..Entry::default()
                },
            );
        }
        let e = self.entries.get_mut(id).expect("inserted above");
        e.used = tick;
        e
    }

    /// The entry of `id` for a write: created when missing, its epoch moved.
    fn written(&mut self, id: &str) -> &mut Entry {
        let e = self.entry(id);
        e.epoch = e.used;
        e
    }

    /// The entry of `id` when it is still at `epoch`.
    fn unchanged(&mut self, id: &str, epoch: Epoch) -> Option<&mut Entry> {
        self.entries.get_mut(id).filter(|e| e.epoch == epoch.0)
    }
}

impl Recent {
    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // Every critical section leaves the map whole: a panic cannot half-write an entry.
        self.inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Starts a fill of `id`: pass the result to the `fill_*` call after the read.
    pub fn epoch(&self, id: &str) -> Epoch {
        Epoch(self.lock().entry(id).epoch)
    }

    // ---- missions ----

    /// The mission, if known.
    pub fn mission(&self, id: &str) -> Option<Arc<Mission>> {
        self.lock().entry(id).mission.clone()
    }

    /// A mission read from the database since `epoch`.
    pub fn fill_mission(&self, epoch: Epoch, mission: &Mission) {
        if let Some(e) = self.lock().unchanged(&mission.id.0, epoch) {
            e.mission = Some(Arc::new(mission.clone()));
        }
    }

    /// The mission was deleted (or its deletion failed and may have committed).
    pub fn forget(&self, id: &str) {
        self.lock().entries.remove(id);
    }

    // ---- telemetry ----

    /// The newest `last` samples in time order, when known.
    pub fn telemetry(&self, id: &str, last: usize) -> Option<Vec<TelemetryRow>> {
        if last > TELEMETRY_TAIL {
            return None;
        }
        let mut g = self.lock();
        let tail = g.entry(id).telemetry.as_ref()?;
        Some(
            tail.iter()
                .skip(tail.len().saturating_sub(last))
                .cloned()
                .collect(),
        )
    }

    /// The newest [`TELEMETRY_TAIL`] samples (or all, when fewer), in time order, read
    /// from the database since `epoch`.
    pub fn fill_telemetry(&self, id: &str, epoch: Epoch, newest: &[TelemetryRow]) {
        let mut g = self.lock();
        if let Some(e) = g.unchanged(id, epoch) {
            let from = newest.len().saturating_sub(TELEMETRY_TAIL);
            e.telemetry = Some(newest[from..].iter().cloned().collect());
        }
    }

    /// `rows` were posted and the store answered: `stored_all` when every one of them was
    /// newly stored (so none had the time of a stored sample or of another in `rows`).
    /// Otherwise (duplicates, or an error that may have committed) the tail is dropped.
    pub fn telemetry_written(&self, id: &str, rows: &[TelemetryRow], stored_all: bool) {
        let mut g = self.lock();
        let e = g.written(id);
        if !stored_all {
            e.telemetry = None;
            return;
        }
        let Some(tail) = e.telemetry.as_mut() else {
            return;
        };
        for r in rows {
            let r = as_stored(r);
            // Older than every sample kept while the tail is full: not among the newest.
            if tail.len() >= TELEMETRY_TAIL && tail.front().is_some_and(|f| r.t_s < f.t_s) {
                continue;
            }
            let at = tail.partition_point(|s| s.t_s < r.t_s);
            if tail.get(at).is_some_and(|s| s.t_s == r.t_s) {
                // Stored already, so the store reported a duplicate: never here.
                e.telemetry = None;
                return;
            }
            tail.insert(at, r);
            if tail.len() > TELEMETRY_TAIL {
                tail.pop_front();
            }
        }
    }

    // ---- plans ----

    /// The latest revision (0: none), when known.
    pub fn latest_revision(&self, id: &str) -> Option<i64> {
        self.lock().entry(id).latest.as_ref().map(|(r, _)| *r)
    }

    /// The row of revision `revision`, when it is the latest and known.
    pub fn plan(&self, id: &str, revision: i64) -> Option<PlanRow> {
        match &self.lock().entry(id).latest {
            Some((r, Some(row))) if *r == revision => Some(PlanRow::clone(row)),
            _ => None,
        }
    }

    /// The latest revision, read from the database since `epoch`.
    pub fn fill_latest_revision(&self, id: &str, epoch: Epoch, revision: i64) {
        let mut g = self.lock();
        if let Some(e) = g.unchanged(id, epoch)
            && e.latest.as_ref().is_none_or(|(r, _)| *r != revision)
        {
            e.latest = Some((revision, None));
        }
    }

    /// The row of a revision, read from the database: kept when it is the latest known.
    pub fn fill_plan(&self, id: &str, row: &PlanRow) {
        let mut g = self.lock();
        let e = g.entry(id);
        if let Some((r, cached @ None)) = e.latest.as_mut()
            && *r == row.revision
        {
            *cached = Some(Arc::new(row.clone()));
        }
    }

    /// `row` was stored (committed). Revisions only grow: an older one arriving late is
    /// ignored.
    pub fn plan_written(&self, row: &PlanRow) {
        let mut g = self.lock();
        let e = g.written(&row.mission_id.0);
        if e.latest.as_ref().is_none_or(|(r, _)| *r < row.revision) {
            let stored = PlanRow {
                created_at_s: from_us(to_us(row.created_at_s)),
                ..row.clone()
            };
            e.latest = Some((row.revision, Some(Arc::new(stored))));
        }
    }

    /// A plan write of `id` failed in a way that may have committed: forget the latest.
    pub fn plan_unknown(&self, id: &str) {
        self.lock().written(id).latest = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t_s: f64) -> TelemetryRow {
        TelemetryRow {
            t_s,
            lat_deg: 38.0,
            lon_deg: -76.0,
            alt_msl_m: 100.0,
            heading_deg: 0.0,
            speed_mps: None,
        }
    }

    fn times(rows: &[TelemetryRow]) -> Vec<f64> {
        rows.iter().map(|r| r.t_s).collect()
    }

    #[test]
    fn a_fill_read_while_a_write_happened_is_not_kept() {
        let r = Recent::default();
        let e = r.epoch("m");
        r.telemetry_written("m", &[sample(5.0)], true);
        r.fill_telemetry("m", e, &[sample(1.0)]);
        assert!(
            r.telemetry("m", 1).is_none(),
            "filled with a read older than a write"
        );
        let e = r.epoch("m");
        r.fill_telemetry("m", e, &[sample(1.0), sample(5.0)]);
        assert_eq!(times(&r.telemetry("m", 8).unwrap()), [1.0, 5.0]);
        // A deletion between the read and its fill.
        let e = r.epoch("m");
        r.forget("m");
        r.fill_latest_revision("m", e, 3);
        assert_eq!(r.latest_revision("m"), None);
    }

    #[test]
    fn the_tail_keeps_the_newest_samples_in_time_order_and_drops_itself_on_a_duplicate() {
        let r = Recent::default();
        let e = r.epoch("m");
        r.fill_telemetry("m", e, &[]);
        let first: Vec<TelemetryRow> = (0..40).map(|k| sample(100.0 + f64::from(k))).collect();
        r.telemetry_written("m", &first, true);
        let got = r.telemetry("m", TELEMETRY_TAIL).unwrap();
        assert_eq!(times(&got), times(&first[8..]));
        // Out of order: one older than every kept sample is not among the newest; one in
        // between goes in its place.
        r.telemetry_written("m", &[sample(50.0), sample(120.5)], true);
        let got = times(&r.telemetry("m", 3).unwrap());
        assert_eq!(got, [137.0, 138.0, 139.0]);
        let all = times(&r.telemetry("m", TELEMETRY_TAIL).unwrap());
        assert_eq!(all.len(), TELEMETRY_TAIL);
        assert!(all.contains(&120.5) && !all.contains(&50.0) && all[0] == 109.0);
        assert!(all.windows(2).all(|w| w[0] < w[1]));
        // A post the store reported duplicates in: the tail is no longer known.
        r.telemetry_written("m", &[sample(139.0)], false);
        assert!(r.telemetry("m", 1).is_none());
        // More than the tail is never answered from memory.
        let e = r.epoch("m");
        r.fill_telemetry("m", e, &first);
        assert!(r.telemetry("m", TELEMETRY_TAIL + 1).is_none());
    }

    #[test]
    fn a_sample_is_kept_as_the_database_gives_it_back() {
        let r = Recent::default();
        let e = r.epoch("m");
        r.fill_telemetry("m", e, &[]);
        let mut s = sample(1_700_000_000.123_456_7);
        s.heading_deg = -0.0;
        r.telemetry_written("m", &[s], true);
        let got = &r.telemetry("m", 1).unwrap()[0];
        assert_eq!(got.t_s, 1_700_000_000.123_457);
        assert!(got.heading_deg.is_sign_positive());
    }

    fn plan(revision: i64) -> PlanRow {
        PlanRow {
            id: wire::ids::PlanId(format!("p{revision}")),
            mission_id: wire::ids::MissionId::from("m"),
            revision,
            created_at_s: 1.000_000_4,
            seed: 7,
            inputs: "{}".into(),
            body: "{}".into(),
            written_by: "local".into(),
        }
    }

    #[test]
    fn the_latest_revision_only_grows_and_a_failed_write_forgets_it() {
        let r = Recent::default();
        assert_eq!(r.latest_revision("m"), None);
        let e = r.epoch("m");
        r.fill_latest_revision("m", e, 2);
        assert_eq!(r.latest_revision("m"), Some(2));
        assert!(r.plan("m", 2).is_none(), "the row is not known yet");
        r.fill_plan("m", &plan(2));
        assert_eq!(r.plan("m", 2).unwrap().id.0, "p2");
        r.plan_written(&plan(4));
        r.plan_written(&plan(3));
        assert_eq!(r.latest_revision("m"), Some(4));
        assert!(r.plan("m", 3).is_none());
        assert_eq!(r.plan("m", 4).unwrap().created_at_s, 1.0);
        r.plan_unknown("m");
        assert_eq!(r.latest_revision("m"), None);
    }

    #[test]
    fn at_most_the_entry_cap_is_kept_the_least_recently_used_dropped() {
        let r = Recent::default();
        for k in 0..MAX_ENTRIES {
            let e = r.epoch(&format!("m{k}"));
            r.fill_latest_revision(&format!("m{k}"), e, 1);
        }
        assert_eq!(r.latest_revision("m0"), Some(1)); // m0 used again: m1 is the oldest
        let e = r.epoch("new");
        r.fill_latest_revision("new", e, 1);
        assert_eq!(r.lock().entries.len(), MAX_ENTRIES);
        assert_eq!(r.latest_revision("m0"), Some(1));
        assert!(!r.lock().entries.contains_key("m1"));
    }
}

/// The cache against the database it stands for: every answer it gives is compared with a
/// read of the database itself.
#[cfg(test)]
mod against_the_database {
    use super::super::plans::{InsertPlanError, PlanRow};
    use super::super::{Store, TelemetryRow};
    use crate::mission::Mission;
    use wire::ids::{MissionId, PlanId};

    async fn db_latest(store: &Store, id: &MissionId) -> i64 {
        use sqlx::Row;
        sqlx::query("SELECT COALESCE(MAX(revision), 0) FROM plans WHERE mission_id = $1")
            .bind(id.to_string())
            .fetch_one(store.read_pool())
            .await
            .expect("read")
            .try_get::<i64, _>(0)
            .expect("revision")
    }

    async fn db_tail(store: &Store, id: &MissionId, n: usize) -> Vec<TelemetryRow> {
        let all: Vec<TelemetryRow> = store
            .list_telemetry_written(id, None)
            .await
            .expect("read")
            .into_iter()
            .map(|(r, _)| r)
            .collect();
        all[all.len().saturating_sub(n)..].to_vec()
    }

    fn bits(rows: &[TelemetryRow]) -> Vec<[u64; 6]> {
        rows.iter()
            .map(|r| {
                [
                    r.t_s.to_bits(),
                    r.lat_deg.to_bits(),
                    r.lon_deg.to_bits(),
                    r.alt_msl_m.to_bits(),
                    r.heading_deg.to_bits(),
                    r.speed_mps.map_or(u64::MAX, f64::to_bits),
                ]
            })
            .collect()
    }

    #[tokio::test]
    async fn every_answer_from_memory_is_the_databases_through_posts_plans_and_a_deletion() {
        let dir = tempfile::tempdir().expect("tempdir");
        let url = format!("sqlite://{}", dir.path().join("r.sqlite").display());
        let store = Store::open(&url).await.expect("open");
        let text = include_str!("../../../tests/fixtures/interop/mission_2021_webster_field.json");
        let m: Mission = wire::domain::read_mission_text(text, "webster").expect("fixture");
        store.insert_missions(&[m], 0.0).await.expect("mission");
        let id = MissionId::from("webster");
        let mut rng = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move |n: u64| {
            rng = rng
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (rng >> 33) % n
        };
        let (mut reads, mut from_db_fills) = (0, 0);
        for step in 0..400 {
            match next(10) {
                // A post of 1-4 samples: mostly new times a fifth of a second apart, some
                // out of order, some repeating a stored time or one in the same post,
                // some with a time finer than a microsecond or a negative zero.
                0..=4 => {
                    let rows: Vec<TelemetryRow> = (0..=next(4))
                        .map(|_| {
                            let t = match next(8) {
                                0 => 1_000.0 + next(u64::from(step as u32 + 1)) as f64 * 0.2,
                                1 => 1_000.0 + step as f64 * 0.2 + 0.000_000_3,
                                _ => 1_000.0 + (step as f64 + next(5) as f64 / 5.0) * 0.2,
                            };
                            TelemetryRow {
                                t_s: t,
                                lat_deg: 38.14 + next(1000) as f64 * 1e-6,
                                lon_deg: -76.43,
                                alt_msl_m: if next(4) == 0 {
                                    100.0
                                } else {
                                    60.0 + next(50) as f64 * 0.1
                                },
                                heading_deg: if next(6) == 0 { -0.0 } else { next(360) as f64 },
                                speed_mps: (next(3) > 0).then(|| 18.0 + next(10) as f64 * 0.1),
                            }
                        })
                        .collect();
                    store
                        .insert_telemetry(&id, &rows, 5.0)
                        .await
                        .expect("insert")
                        .expect("mission");
                }
                // A read of the newest n samples, 1-32.
                5..=6 => {
                    let n = 1 + next(32) as usize;
                    let cached = store
                        .recent
                        .as_ref()
                        .expect("SQLite")
                        .telemetry(&id.0, n)
                        .is_some();
                    from_db_fills += usize::from(!cached);
                    let got = store
                        .list_telemetry(&id, Some(n as u32))
                        .await
                        .expect("read");
                    assert_eq!(
                        bits(&got),
                        bits(&db_tail(&store, &id, n).await),
                        "step {step}, last {n}"
                    );
                    reads += 1;
                }
                // A plan at the next revision, or (a client behind) at one already taken.
                7..=8 => {
                    let latest = store.latest_plan_revision(&id).await.expect("latest");
                    assert_eq!(latest, db_latest(&store, &id).await, "step {step}");
                    let stale = latest > 0 && next(4) == 0;
                    let revision = if stale { latest } else { latest + 1 };
                    let row = PlanRow {
                        id: PlanId(format!("p{step}")),
                        mission_id: id.clone(),
                        revision,
                        created_at_s: 2_000.0 + step as f64 * 0.333_333_3,
                        seed: step,
                        inputs: format!("{{\"step\":{step}}}"),
                        body: "{}".into(),
                        written_by: "local".into(),
                    };
                    match store.insert_plan(&row).await {
                        Ok(()) => assert!(!stale),
                        Err(InsertPlanError::RevisionTaken(r)) => assert!(stale && r == revision),
                        Err(e) => panic!("step {step}: {e}"),
                    }
                }
                // The latest revision's row and the mission.
                _ => {
                    let latest = store.latest_plan_revision(&id).await.expect("latest");
                    assert_eq!(latest, db_latest(&store, &id).await, "step {step}");
                    if latest > 0 {
                        let got = store.get_plan_by_revision(&id, latest).await.expect("read");
                        let db = store
                            .plan_where(
                                "revision = $2",
                                &id,
                                super::super::plans::PlanKey::Revision(latest),
                            )
                            .await
                            .expect("read");
                        assert_eq!(got, db, "step {step}");
                        assert!(got.is_some());
                    }
                    let m = store
                        .get_mission(&id)
                        .await
                        .expect("read")
                        .expect("mission");
                    assert_eq!(Some(m), store.read_mission(&id).await.expect("read"));
                }
            }
        }
        assert!(
            reads > 40 && from_db_fills < reads / 2,
            "{reads} reads, {from_db_fills} from the database"
        );
        // Deleted: nothing of it is answered from memory.
        assert!(store.delete_mission(&id).await.expect("delete"));
        assert_eq!(store.get_mission(&id).await.expect("read"), None);
        assert!(
            store
                .list_telemetry(&id, Some(8))
                .await
                .expect("read")
                .is_empty()
        );
        assert_eq!(store.latest_plan_revision(&id).await.expect("read"), 0);
    }
}
