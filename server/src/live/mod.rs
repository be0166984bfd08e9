//! Live mission state (issue 9): per mission, the predictor fed batch by batch and an
//! immutable [`Snapshot`] (predictor + risk map) that plans, `GET .../obstacles` and
//! `GET .../risk` read.
//!
//! Contracts:
//! - **One writer per mission**: a mission's predictor is changed only under its own
//!   writer lock (an async mutex per mission); there is no lock across missions except the
//!   registry's, held only to look an entry up.
//! - **Ingest never waits on a plan**: the observation handler feeds the committed batch
//!   (microseconds per row) and returns. Plans read the published snapshot and never hold
//!   the writer lock while computing.
//! - **Maps only where they are read**: a risk map is built for plans and `GET .../risk`
//!   (which mark the mission's map as in use); `GET .../obstacles` reads the predictor
//!   alone ([`PredictorView`]). While a mission's map is in use (read within
//!   [`LiveConfig::map_idle`]), batches rebuild it in the background, so the next plan
//!   usually finds it ready. That rebuild waits for a CPU slot at background priority
//!   (after every plan and every map a request waits for, [`crate::cpu`]), and at most one
//!   waits per mission: batches arriving meanwhile are built by it, one rebuild for the
//!   lot. A map unread for longer is dropped (the predictor stays) and no longer
//!   rebuilt, and at most [`LiveConfig::max_maps`] maps are kept (the least recently read
//!   dropped first). A dropped map is rebuilt by the next read that needs it, bit for bit
//!   (it is a pure function of the predictor).
//! - **Two hands per build**: a map build shares its obstacles with one helper thread at
//!   the lowest priority (SCHED_IDLE, [`helper`], [`LiveConfig::map_helper`]) and puts the helper's
//!   parts in the one-thread order, so the map is the same bit for bit; the build never
//!   waits for the helper.
//! - **No half-applied batch**: the writer publishes whole batches (`seq` advances by a
//!   batch at a time); a snapshot holds an `Arc` of the predictor as of that `seq`. The
//!   writer never changes a copy a snapshot holds: it keeps two copies and feeds the one
//!   no reader holds, bringing it up to date first ([`writer`], the left-right pattern),
//!   and copies the predictor only when readers hold both.
//! - **Read your writes** for `GET .../risk` and `GET .../obstacles`: a read first brings
//!   the snapshot up to the batches applied when it arrived (waiting for a map build in
//!   flight); on PostgreSQL it first catches up with the store's newest batch number (one
//!   indexed read), so a replica never shows older data than another replica acknowledged.
//! - **Plans take the last published map** ([`MissionLive::plan_snapshot`]) when it lacks
//!   only batches applied within the plan's `max_map_age` (default
//!   [`LiveConfig::plan_map_max_age`]), instead of waiting for the rebuild those batches
//!   started; the plan reports the map's [`MapLag`] (batches behind, age). The snapshot
//!   is still a whole one (a published `seq`, its predictor and its map together), so a
//!   plan never mixes batches, and replay rebuilds it from the `seq` the plan stored.
//! - **Rebuilt on first use** from the store (all batches in feeding order), so a restart
//!   loses nothing; **evicted** after `idle` without use, and the least recently used
//!   beyond `max_missions`, so memory stays bounded (maps, the large part, go earlier: see
//!   above).
//! - **Replicas** (PostgreSQL): [`notify`] listens to the batches other replicas commit
//!   and catches the cached missions up.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use predictor::Predictor;

use crate::app::AppState;
use crate::cpu::{CpuPermit, Priority};
use crate::error::ApiError;
use crate::mission::Mission;
use crate::store::observations::StoredBatch;
use crate::store::{Backend, ObservationRow};
use wire::ids::MissionId;

pub mod helper;
pub mod notify;
pub mod plan_view;
pub mod snapshot;
mod writer;

use writer::Writer;

pub use snapshot::{Snapshot, map_config};

/// Maps of replaced snapshots kept for their allocation (see [`LiveStates::recycle`]).
const SPARE_MAPS: usize = 2;

/// Feeding more rows than this at once runs on the CPU pool instead of the runtime.
const INLINE_FEED_ROWS: usize = 256;

/// Default of [`LiveConfig::plan_map_max_age`], milliseconds: a plan may use the map
/// published before a batch accepted at most this long ago (at a 5 Hz feed, the batch
/// posted just before it) instead of waiting for that batch's rebuild; it starts beside
/// the rebuild on the CPU budget's extra slot ([`crate::cpu`]). It never skips a batch that
/// brings an obstacle the published map does not know ([`MissionLive::plan_snapshot`]).
/// A flying aircraft's plan at 5 Hz then answers in 3.2-3.7 ms at p50 against 4.9-5.8
/// (README, "The bench's aircraft flies its plans"); 0 waits for every batch (read your
/// writes).
pub const DEFAULT_PLAN_MAP_MAX_AGE_MS: u64 = 250;

/// Batches applied but not yet in the published map, remembered with their time of
/// application (for [`MapLag::age_ms`]); beyond this many, the oldest are merged (a map
/// that far behind is rebuilt before a plan uses it anyway).
const PENDING_MAX: usize = 64;

/// How far the map a plan used lags behind the batches the replica had applied.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MapLag {
    /// Batches applied but not in the map (0: the map holds every applied batch).
    pub batches: i64,
    /// How long the oldest of those batches had been applied, milliseconds (0 when
    /// `batches` is 0).
    pub age_ms: f64,
}

/// Limits of the live state.
#[derive(Debug, Clone, Copy)]
pub struct LiveConfig {
    /// A mission unused for this long is dropped (rebuilt from the store on next use).
    pub idle: Duration,
    /// At most this many missions are live; the least recently used goes first.
    pub max_missions: usize,
    /// A mission's risk map not read (by a plan or `GET .../risk`) for this long is
    /// dropped and no longer rebuilt in the background; its predictor stays live.
    pub map_idle: Duration,
    /// At most this many missions keep a risk map; the least recently read goes first.
    pub max_maps: usize,
    /// A plan takes the last published map while the oldest batch missing from it was
    /// applied at most this long ago (a rebuild is then under way); beyond it, the plan
    /// waits for the map of every applied batch. A request's `max_map_age_ms` overrides it.
    pub plan_map_max_age: Duration,
    /// Map builds share their obstacles with a helper thread at the lowest priority
    /// ([`helper`]): on a machine of two or more cores, the core kept for the runtime
    /// builds part of a map while it is idle. Default: on with two or more cores.
    pub map_helper: bool,
}

/// Default of [`LiveConfig::max_maps`] (`--live-max-maps`): a Webster Field map holds
/// about 6 MB, so 100 live missions with a plan each stay under issue 9's 200 MB (at 32,
/// since maps grew from 4 to 6 MB, they read 242-246 MB in `plan_load`; at 20, 172-176).
pub const DEFAULT_MAX_MAPS: usize = 20;

impl Default for LiveConfig {
    fn default() -> Self {
        Self {
            idle: Duration::from_secs(600),
            max_missions: 1000,
            map_idle: Duration::from_secs(10),
            max_maps: DEFAULT_MAX_MAPS,
            plan_map_max_age: Duration::from_millis(DEFAULT_PLAN_MAP_MAX_AGE_MS),
            map_helper: std::thread::available_parallelism().is_ok_and(|n| n.get() >= 2),
        }
    }
}

/// A mission's predictor as of a batch, without a risk map (what `GET .../obstacles`
/// reads).
#[derive(Debug, Clone)]
pub struct PredictorView {
    /// Observation batches applied: every row of batches `<= seq`, none after.
    pub seq: i64,
    /// The predictor (tracks, estimates, stages, stage history).
    pub predictor: Arc<Predictor>,
    /// The mission's ENU frame.
    pub frame: crate::geodesy::LocalFrame,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // Every critical section here only swaps or reads an Arc: a panic cannot leave a
    // half-written value behind.
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// One mission's live state.
pub struct MissionLive {
    mission: Arc<Mission>,
    writer: Arc<tokio::sync::Mutex<Writer>>,
    loaded: AtomicBool,
    /// Newest batch applied by the writer (mirrors `Writer::applied` for lock-free reads).
    applied: AtomicI64,
    /// The newest snapshot with its map, or the empty one (seq -1) after the map was
    /// dropped.
    published: Mutex<Arc<Snapshot>>,
    build: tokio::sync::Mutex<()>,
    last_used: Mutex<Instant>,
    /// Last read of the map (None: not read since it was dropped).
    map_used: Mutex<Option<Instant>>,
    /// Batches applied after the published snapshot's, oldest first: (seq, applied at).
    pending: Mutex<VecDeque<(i64, Instant)>>,
    /// A background rebuild waits for a CPU slot (it will build every batch applied by
    /// the time it starts: later batches need not queue another).
    rebuild_queued: AtomicBool,
    /// Snapshots built (with a map) since the mission went live.
    builds: std::sync::atomic::AtomicU64,
}

impl std::fmt::Debug for MissionLive {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MissionLive")
            .field("mission", &self.mission.id)
            .field("applied", &self.applied.load(Ordering::Relaxed))
            .finish_non_exhaustive()
    }
}

impl MissionLive {
    fn new(mission: Mission) -> Self {
        let empty = Snapshot::empty(&mission);
        Self {
            mission: Arc::new(mission),
            writer: Arc::new(tokio::sync::Mutex::new(Writer::new(Predictor::new(
                snapshot::predictor_config(),
            )))),
            loaded: AtomicBool::new(false),
            applied: AtomicI64::new(0),
            published: Mutex::new(Arc::new(empty)),
            build: tokio::sync::Mutex::new(()),
            last_used: Mutex::new(Instant::now()),
            map_used: Mutex::new(None),
            pending: Mutex::new(VecDeque::new()),
            rebuild_queued: AtomicBool::new(false),
            builds: std::sync::atomic::AtomicU64::new(0),
        }
    }

    /// Remembers that batches through `seq` were applied now.
    fn note_applied(&self, seq: i64) {
        let mut p = lock(&self.pending);
        if p.len() >= PENDING_MAX {
            // Merge the second entry into the third, keeping the older time: ages are
            // then overestimated, never under.
            if let Some((_, t)) = p.remove(1)
                && let Some(next) = p.get_mut(1)
            {
                next.1 = t;
            }
        }
        p.push_back((seq, Instant::now()));
    }

    /// How far `snap` lags behind the batches applied so far.
    fn lag(&self, snap: &Snapshot) -> MapLag {
        let applied = self.applied.load(Ordering::Acquire);
        if snap.seq >= applied {
            return MapLag::default();
        }
        let oldest = lock(&self.pending)
            .iter()
            .find(|(seq, _)| *seq > snap.seq)
            .map(|(_, at)| *at);
        MapLag {
            batches: applied - snap.seq,
            age_ms: oldest.map_or(f64::INFINITY, |at| at.elapsed().as_secs_f64() * 1e3),
        }
    }

    /// Publishes `snap` and forgets the pending batches it holds; returns the replaced one.
    fn publish(&self, snap: Arc<Snapshot>) -> Arc<Snapshot> {
        let seq = snap.seq;
        let old = std::mem::replace(&mut *lock(&self.published), snap);
        let mut p = lock(&self.pending);
        while p.front().is_some_and(|(s, _)| *s <= seq) {
            p.pop_front();
        }
        old
    }

    /// True when the map was read within `map_idle` (batches then rebuild it at once).
    fn map_in_use(&self, now: Instant, map_idle: Duration) -> bool {
        lock(&self.map_used).is_some_and(|t| now.duration_since(t) < map_idle)
    }

    /// Drops the map (the predictor stays); the next read that needs one rebuilds it.
    /// Returns the snapshot that held it, for [`LiveStates::recycle`].
    #[must_use]
    fn drop_map(&self) -> Option<Arc<Snapshot>> {
        *lock(&self.map_used) = None;
        let mut p = lock(&self.published);
        (p.map.is_some() || p.seq >= 0)
            .then(|| std::mem::replace(&mut *p, Arc::new(Snapshot::empty(&self.mission))))
    }

    fn has_map(&self) -> bool {
        lock(&self.published).seq >= 0
    }

    /// The mission this state belongs to.
    pub fn mission(&self) -> &Mission {
        &self.mission
    }

    /// The snapshot last published (possibly behind the writer; see [`Self::snapshot`]).
    pub fn published(&self) -> Arc<Snapshot> {
        lock(&self.published).clone()
    }

    /// Brings the writer up to batch `target` (the store's newest when `None`) with one
    /// read of the missing batches. Returns false when the mission no longer exists.
    async fn catch_up(&self, state: &AppState, target: Option<i64>) -> Result<bool, ApiError> {
        // Read the target before taking the writer lock: ingest never waits on this read.
        let target = match target {
            Some(t) => t,
            None => match state.store.observation_seq(&self.mission.id).await? {
                Some(t) => t,
                None => return Ok(false),
            },
        };
        if self.loaded.load(Ordering::Acquire) && self.applied.load(Ordering::Acquire) >= target {
            return Ok(true);
        }
        let mut w = self.writer.clone().lock_owned().await;
        if w.applied < target {
            let rows: Vec<ObservationRow> = state
                .store
                .list_observations_through(&self.mission.id, w.applied, target)
                .await?
                .into_iter()
                .map(|(_, r)| r)
                .collect();
            let frame = self.mission.frame();
            if rows.len() > INLINE_FEED_ROWS {
                w = state
                    .run_cpu(move || {
                        w.feed(&frame, &rows);
                        w
                    })
                    .await?;
            } else {
                w.feed(&frame, &rows);
            }
            w.applied = target;
            self.applied.store(target, Ordering::Release);
            self.note_applied(target);
        }
        self.loaded.store(true, Ordering::Release);
        Ok(true)
    }

    /// Applies a batch this replica just committed (or catches up when batches are
    /// missing before it). Cheap: the batch's rows are fed, nothing else.
    async fn apply(&self, state: &AppState, batch: &StoredBatch) -> Result<(), ApiError> {
        if !self.loaded.load(Ordering::Acquire) {
            // The first read loads everything from the store, this batch included.
            return Ok(());
        }
        let mut w = self.writer.lock().await;
        if batch.seq <= w.applied {
            return Ok(());
        }
        if batch.seq == w.applied + 1 {
            w.feed(&self.mission.frame(), &batch.stored);
            w.applied = batch.seq;
            self.applied.store(batch.seq, Ordering::Release);
            self.note_applied(batch.seq);
            return Ok(());
        }
        drop(w);
        self.catch_up(state, Some(batch.seq)).await.map(|_| ())
    }

    /// The snapshot with every batch applied so far (read your writes): returns the
    /// published one when current, otherwise builds the map (or waits for the build in
    /// flight) and publishes it.
    ///
    /// # Errors
    /// Database failures while catching up; a job panic.
    pub async fn snapshot(&self, state: &AppState) -> Result<Arc<Snapshot>, ApiError> {
        let now = Instant::now();
        *lock(&self.last_used) = now;
        *lock(&self.map_used) = Some(now);
        self.current(state).await?;
        self.build_current(state).await
    }

    /// The snapshot a plan reads: the last published one when the batches it lacks were
    /// all applied within `max_age` and bring no obstacle it does not have (their rebuild
    /// is then started if none is under way, and the plan does not wait for it), else the
    /// snapshot of every batch applied so far (as [`Self::snapshot`]). Returned with how
    /// far it lags. A new obstacle is never left out for speed: the first plan after it
    /// appears waits for the map that holds it.
    ///
    /// # Errors
    /// Database failures while catching up; a job panic.
    pub async fn plan_snapshot(
        self: &Arc<Self>,
        state: &AppState,
        max_age: Duration,
    ) -> Result<(Arc<Snapshot>, MapLag), ApiError> {
        let now = Instant::now();
        *lock(&self.last_used) = now;
        *lock(&self.map_used) = Some(now);
        self.current(state).await?;
        let cur = self.published();
        if cur.seq >= 0 {
            let lag = self.lag(&cur);
            if lag.batches == 0 {
                return Ok((cur, lag));
            }
            if lag.age_ms <= max_age.as_secs_f64() * 1e3 && !self.brings_new_obstacle(&cur).await {
                if self.build.try_lock().is_ok() {
                    // No build under way (the map was not in use when the batches came).
                    spawn_build(state, self.clone());
                }
                return Ok((cur, lag));
            }
        }
        drop(cur);
        let snap = self.build_current(state).await?;
        let mut lag = self.lag(&snap);
        if !lag.age_ms.is_finite() {
            // Batches applied during the build whose time was not kept: report them as
            // just applied rather than as an infinite age on the wire.
            lag.age_ms = 0.0;
        }
        Ok((snap, lag))
    }

    /// Whether the batches applied after `snap` bring an obstacle `snap` does not have
    /// (tracks are never removed, so a count says it).
    async fn brings_new_obstacle(&self, snap: &Snapshot) -> bool {
        let applied = self.writer.lock().await.predictor();
        applied.obstacles().count() > snap.predictor.obstacles().count()
    }

    /// The predictor with every batch applied so far (read your writes), without a map.
    ///
    /// # Errors
    /// Database failures while catching up; 404 when the mission was deleted meanwhile.
    pub async fn predictor_view(&self, state: &AppState) -> Result<PredictorView, ApiError> {
        *lock(&self.last_used) = Instant::now();
        self.current(state).await?;
        let w = self.writer.lock().await;
        Ok(PredictorView {
            seq: w.applied,
            predictor: w.predictor(),
            frame: self.mission.frame(),
        })
    }

    /// Loads the mission on first use, and on PostgreSQL catches up with the store.
    async fn current(&self, state: &AppState) -> Result<(), ApiError> {
        if (!self.loaded.load(Ordering::Acquire) || state.store.backend() == Backend::Postgres)
            && !self.catch_up(state, None).await?
        {
            return Err(ApiError::not_found("mission", self.mission.id.as_str()));
        }
        Ok(())
    }

    /// Publishes (or waits for) the snapshot of the batches applied so far.
    async fn build_current(&self, state: &AppState) -> Result<Arc<Snapshot>, ApiError> {
        let cur = self.published();
        if cur.seq >= self.applied.load(Ordering::Acquire) {
            return Ok(cur);
        }
        drop(cur);
        let _building = self.build.lock().await;
        let cur = self.published();
        let (predictor, seq) = {
            let w = self.writer.lock().await;
            (w.predictor(), w.applied)
        };
        if cur.seq >= seq {
            return Ok(cur);
        }
        // Not held here, so that its map can be recycled below.
        drop(cur);
        let permit = state.cpu.acquire(Priority::Foreground).await;
        self.build_and_publish(state, seq, predictor, permit).await
    }

    /// Builds the snapshot of `predictor` (batch `seq`) in `permit`'s CPU slot and
    /// publishes it. The caller holds the build lock.
    async fn build_and_publish(
        &self,
        state: &AppState,
        seq: i64,
        predictor: Arc<Predictor>,
        permit: CpuPermit,
    ) -> Result<Arc<Snapshot>, ApiError> {
        let mission = self.mission.clone();
        let spare = state.live.take_spare();
        let helper = state.live.helper.clone();
        let snap = Arc::new(
            crate::app::run_with(permit, move || {
                Snapshot::build_reusing(&mission, seq, predictor, spare, helper.as_ref())
            })
            .await?,
        );
        self.builds.fetch_add(1, Ordering::Relaxed);
        let old = self.publish(snap.clone());
        state.live.recycle(old);
        Ok(snap)
    }

    /// A background rebuild in the CPU slot `permit` holds: publishes the snapshot of the
    /// batches applied so far, unless it is current or someone else holds the build or
    /// writer lock (a build under way, or a catch-up, which starts its own rebuild). It
    /// never waits while holding the slot: a foreground job holding one of those locks
    /// may be waiting for that very slot.
    async fn build_in_background(
        &self,
        state: &AppState,
        permit: CpuPermit,
    ) -> Result<(), ApiError> {
        if self.published().seq >= self.applied.load(Ordering::Acquire) {
            return Ok(());
        }
        let Ok(_building) = self.build.try_lock() else {
            return Ok(());
        };
        let (predictor, seq) = match self.writer.try_lock() {
            Ok(w) => (w.predictor(), w.applied),
            Err(_) => return Ok(()),
        };
        if self.published().seq >= seq {
            return Ok(());
        }
        self.build_and_publish(state, seq, predictor, permit)
            .await
            .map(drop)
    }
}

/// Every live mission, by id.
#[derive(Debug)]
pub struct LiveStates {
    cfg: LiveConfig,
    /// Maps of replaced snapshots nobody reads any more, whose allocations the next builds
    /// reuse (at most [`SPARE_MAPS`]).
    spare_maps: Mutex<Vec<predictor::RiskMap>>,
    /// Shares map builds ([`LiveConfig::map_helper`]).
    helper: Option<helper::MapHelper>,
    missions: Mutex<HashMap<MissionId, Arc<MissionLive>>>,
    last_sweep: Mutex<Instant>,
}

impl Default for LiveStates {
    fn default() -> Self {
        Self::new(LiveConfig::default())
    }
}

impl LiveStates {
    /// No mission live yet.
    pub fn new(cfg: LiveConfig) -> Self {
        Self {
            helper: if cfg.map_helper {
                helper::MapHelper::spawn()
            } else {
                None
            },
            cfg,
            spare_maps: Mutex::new(Vec::new()),
            missions: Mutex::new(HashMap::new()),
            last_sweep: Mutex::new(Instant::now()),
        }
    }

    /// The live state's gauges in the Prometheus text format: missions live, those with a
    /// published risk map, and the heap those maps and the spare ones hold.
    pub fn render_metrics(&self) -> String {
        let all: Vec<Arc<MissionLive>> = lock(&self.missions).values().cloned().collect();
        let maps: Vec<Arc<predictor::RiskMap>> = all
            .iter()
            .filter_map(|l| lock(&l.published).map.clone())
            .collect();
        let bytes = maps.iter().map(|m| m.heap_bytes()).sum::<usize>()
            + lock(&self.spare_maps)
                .iter()
                .map(predictor::RiskMap::heap_bytes)
                .sum::<usize>();
        format!(
            "# HELP jink_live_missions Missions whose live state (predictor) is in memory.\n\
             # TYPE jink_live_missions gauge\n\
             jink_live_missions {}\n\
             # HELP jink_live_maps Live missions with a published risk map.\n\
             # TYPE jink_live_maps gauge\n\
             jink_live_maps {}\n\
             # HELP jink_live_map_heap_bytes Heap held by the published risk maps and the spare ones kept for reuse (allocated capacity).\n\
             # TYPE jink_live_map_heap_bytes gauge\n\
             jink_live_map_heap_bytes {bytes}\n",
            all.len(),
            maps.len(),
        )
    }

    /// Missions currently live.
    pub fn len(&self) -> usize {
        lock(&self.missions).len()
    }

    /// True when no mission is live.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The live state of `mission` (created on first use, loaded by its first snapshot).
    pub fn entry(&self, mission: &Mission) -> Arc<MissionLive> {
        self.sweep();
        let mut m = lock(&self.missions);
        let live = m
            .entry(mission.id.clone())
            .or_insert_with(|| Arc::new(MissionLive::new(mission.clone())))
            .clone();
        *lock(&live.last_used) = Instant::now();
        if m.len() > self.cfg.max_missions {
            let oldest = m
                .iter()
                .filter(|(id, _)| **id != mission.id)
                .min_by_key(|(_, l)| *lock(&l.last_used))
                .map(|(id, _)| id.clone());
            if let Some(id) = oldest {
                m.remove(&id);
            }
        }
        live
    }

    /// The current snapshot of `mission` (see [`MissionLive::snapshot`]).
    ///
    /// # Errors
    /// Database failures; 404 when the mission was deleted meanwhile.
    pub async fn snapshot(
        &self,
        state: &AppState,
        mission: &Mission,
    ) -> Result<Arc<Snapshot>, ApiError> {
        let live = self.entry(mission);
        let snap = live.snapshot(state).await?;
        self.cap_maps(&mission.id);
        Ok(snap)
    }

    /// The snapshot a plan of `mission` reads (see [`MissionLive::plan_snapshot`]);
    /// `max_age` defaults to [`LiveConfig::plan_map_max_age`].
    ///
    /// # Errors
    /// Database failures; 404 when the mission was deleted meanwhile.
    pub async fn plan_snapshot(
        &self,
        state: &AppState,
        mission: &Mission,
        max_age: Option<Duration>,
    ) -> Result<(Arc<Snapshot>, MapLag), ApiError> {
        let live = self.entry(mission);
        let out = live
            .plan_snapshot(state, max_age.unwrap_or(self.cfg.plan_map_max_age))
            .await?;
        self.cap_maps(&mission.id);
        Ok(out)
    }

    /// The predictor of `mission` with every batch applied so far, without building a map
    /// (see [`MissionLive::predictor_view`]).
    ///
    /// # Errors
    /// Database failures; 404 when the mission was deleted meanwhile.
    pub async fn predictor_view(
        &self,
        state: &AppState,
        mission: &Mission,
    ) -> Result<PredictorView, ApiError> {
        self.entry(mission).predictor_view(state).await
    }

    fn take_spare(&self) -> Option<predictor::RiskMap> {
        lock(&self.spare_maps).pop()
    }

    /// Keeps the map of a replaced or dropped snapshot for its allocation, when nothing
    /// else holds it. A map dropped for [`LiveConfig::max_maps`] is kept too, so that a
    /// server cycling through more missions than it keeps maps for reuses their 4 MB
    /// allocations instead of freeing one and allocating the next (glibc then serves them
    /// from its heaps, and how much of those stays resident depended on the threads'
    /// timing: 101 missions with one plan each read 207-287 MB of VmRSS where 172-181 MB
    /// were held, README "What a plan reads, from memory").
    fn recycle(&self, old: Arc<Snapshot>) {
        let map = Arc::try_unwrap(old)
            .ok()
            .and_then(|s| s.map)
            .and_then(|m| Arc::try_unwrap(m).ok());
        let mut spare = lock(&self.spare_maps);
        if let Some(m) = map
            && spare.len() < SPARE_MAPS
        {
            spare.push(m);
        }
    }

    /// Drops the maps of the least recently read missions beyond
    /// [`LiveConfig::max_maps`], never `keep`'s.
    fn cap_maps(&self, keep: &str) {
        let mut with_map: Vec<(Option<Instant>, Arc<MissionLive>)> = lock(&self.missions)
            .iter()
            .filter(|(id, l)| id.as_str() != keep && l.has_map())
            .map(|(_, l)| (*lock(&l.map_used), l.clone()))
            .collect();
        // `keep` holds one of the allowed maps.
        let allowed = self.cfg.max_maps.saturating_sub(1);
        if with_map.len() > allowed {
            with_map.sort_by_key(|(t, _)| *t);
            for (_, l) in &with_map[..with_map.len() - allowed] {
                if let Some(old) = l.drop_map() {
                    self.recycle(old);
                }
            }
        }
    }

    /// The cached state of a mission, if live.
    pub fn cached(&self, mission_id: &MissionId) -> Option<Arc<MissionLive>> {
        lock(&self.missions).get(mission_id).cloned()
    }

    /// Applies a batch this replica committed, then, while the mission's map is in use,
    /// rebuilds the map in the background (the caller does not wait for it).
    pub async fn apply(&self, state: &AppState, mission_id: &MissionId, batch: &StoredBatch) {
        let Some(live) = self.cached(mission_id) else {
            return;
        };
        if let Err(e) = live.apply(state, batch).await {
            // The next read catches up from the store.
            tracing::warn!(mission = %mission_id, error = %e, "live state not updated");
            live.loaded.store(false, Ordering::Release);
            return;
        }
        self.prebuild(state, live);
    }

    /// A batch `seq` of `mission_id` was committed (by any replica): catch up if live.
    pub async fn notified(&self, state: &AppState, mission_id: &MissionId, seq: i64) {
        let Some(live) = self.cached(mission_id) else {
            return;
        };
        if !live.loaded.load(Ordering::Acquire) || live.applied.load(Ordering::Acquire) >= seq {
            return;
        }
        match live.catch_up(state, Some(seq)).await {
            Ok(_) => self.prebuild(state, live),
            Err(e) => tracing::warn!(mission = %mission_id, error = %e, "catch-up failed"),
        }
    }

    /// Catches every live mission up with the store (after the listener reconnected).
    pub async fn catch_up_all(&self, state: &AppState) {
        let all: Vec<Arc<MissionLive>> = lock(&self.missions).values().cloned().collect();
        for live in all {
            if live.loaded.load(Ordering::Acquire)
                && let Err(e) = live.catch_up(state, None).await
            {
                tracing::warn!(mission = %live.mission.id, error = %e, "catch-up failed");
            }
        }
    }

    /// Forgets a mission (deleted).
    pub fn forget(&self, mission_id: &MissionId) {
        lock(&self.missions).remove(mission_id);
    }

    /// Drops missions idle for `idle` and maps unread for `map_idle` (at most every
    /// quarter of the shorter).
    fn sweep(&self) {
        let now = Instant::now();
        {
            let mut last = lock(&self.last_sweep);
            let every = (self.cfg.idle.min(self.cfg.map_idle) / 4).max(Duration::from_millis(100));
            if now.duration_since(*last) < every {
                return;
            }
            *last = now;
        }
        let mut dropped = Vec::new();
        lock(&self.missions).retain(|_, l| {
            if l.has_map() && !l.map_in_use(now, self.cfg.map_idle) {
                dropped.extend(l.drop_map());
            }
            now.duration_since(*lock(&l.last_used)) < self.cfg.idle
        });
        for old in dropped {
            self.recycle(old);
        }
    }

    /// While `live`'s map is in use, publishes the snapshot of the batches applied so far,
    /// off the caller's path.
    fn prebuild(&self, state: &AppState, live: Arc<MissionLive>) {
        if !live.map_in_use(Instant::now(), self.cfg.map_idle) {
            return;
        }
        spawn_build(state, live);
    }
}

/// Publishes the snapshot of `live`'s applied batches in the background, at
/// [`Priority::Background`]: after every plan and every map a request waits for. At most
/// one rebuild per mission waits for a slot; it covers every batch applied before it
/// starts, so a burst of batches costs one rebuild, not one each.
fn spawn_build(state: &AppState, live: Arc<MissionLive>) {
    if live.rebuild_queued.swap(true, Ordering::AcqRel) {
        return;
    }
    let state = state.clone();
    tokio::spawn(async move {
        let permit = state.cpu.acquire(Priority::Background).await;
        // Batches applied from now on may not be in this build: they queue the next one.
        live.rebuild_queued.store(false, Ordering::Release);
        if let Err(e) = live.build_in_background(&state, permit).await {
            tracing::warn!(mission = %live.mission.id, error = %e, "snapshot build failed");
        }
    });
}

#[cfg(test)]
mod tests;
