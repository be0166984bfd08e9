//! Live mission state (issue 9): per mission, the predictor fed batch by batch and an
//! immutable [`Snapshot`] (predictor + risk map) that plans, `GET .../obstacles` and
//! `GET .../risk` read.
//!
//! Contracts:
//! - **One writer per mission**: a mission's predictor is changed only under its own
//!   writer lock (an async mutex per mission); there is no lock across missions except the
//!   registry's, held only to look an entry up.
//! - **Ingest never waits on a plan**: the observation handler feeds the committed batch
//!   (microseconds per row) and returns; the map is rebuilt by a background task. Plans
//!   read the published snapshot and never hold the writer lock while computing.
//! - **No half-applied batch**: the writer publishes whole batches (`seq` advances by a
//!   batch at a time); a snapshot holds an `Arc` of the predictor as of that `seq`. The
//!   writer feeds through `Arc::make_mut`, so a batch arriving while a snapshot holds the
//!   predictor copies it once (the cost `plan_load` measures).
//! - **Read your writes**: a read first brings the snapshot up to the batches applied
//!   when it arrived (waiting for a map build in flight, a few ms at most); on PostgreSQL
//!   it first catches up with the store's newest batch number (one indexed read), so a
//!   replica never plans on older data than another replica acknowledged.
//! - **Rebuilt on first use** from the store (all batches in feeding order), so a restart
//!   loses nothing; **evicted** after `idle` without use, and the least recently used
//!   beyond `max_missions`, so memory stays bounded.
//! - **Replicas** (PostgreSQL): [`notify`] listens to the batches other replicas commit
//!   and catches the cached missions up.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use predictor::Predictor;

use crate::app::AppState;
use crate::error::ApiError;
use crate::mission::Mission;
use crate::store::observations::StoredBatch;
use crate::store::{Backend, ObservationRow};
use wire::ids::MissionId;

pub mod notify;
pub mod plan_view;
pub mod snapshot;

pub use snapshot::{Snapshot, map_config};

/// Feeding more rows than this at once runs on the CPU pool instead of the runtime.
const INLINE_FEED_ROWS: usize = 256;

/// Limits of the live state.
#[derive(Debug, Clone, Copy)]
pub struct LiveConfig {
    /// A mission unused for this long is dropped (rebuilt from the store on next use).
    pub idle: Duration,
    /// At most this many missions are live; the least recently used goes first.
    pub max_missions: usize,
}

impl Default for LiveConfig {
    fn default() -> Self {
        Self {
            idle: Duration::from_secs(600),
            max_missions: 1000,
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // Every critical section here only swaps or reads an Arc: a panic cannot leave a
    // half-written value behind.
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

struct Writer {
    predictor: Arc<Predictor>,
    applied: i64,
}

/// One mission's live state.
pub struct MissionLive {
    mission: Arc<Mission>,
    writer: Arc<tokio::sync::Mutex<Writer>>,
    loaded: AtomicBool,
    /// Newest batch applied by the writer (mirrors `Writer::applied` for lock-free reads).
    applied: AtomicI64,
    published: Mutex<Arc<Snapshot>>,
    build: tokio::sync::Mutex<()>,
    last_used: Mutex<Instant>,
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
            writer: Arc::new(tokio::sync::Mutex::new(Writer {
                predictor: Arc::new(Predictor::new(snapshot::predictor_config())),
                applied: 0,
            })),
            loaded: AtomicBool::new(false),
            applied: AtomicI64::new(0),
            published: Mutex::new(Arc::new(empty)),
            build: tokio::sync::Mutex::new(()),
            last_used: Mutex::new(Instant::now()),
        }
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
                        snapshot::feed(Arc::make_mut(&mut w.predictor), &frame, &rows);
                        w
                    })
                    .await?;
            } else {
                snapshot::feed(Arc::make_mut(&mut w.predictor), &frame, &rows);
            }
            w.applied = target;
            self.applied.store(target, Ordering::Release);
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
            snapshot::feed(
                Arc::make_mut(&mut w.predictor),
                &self.mission.frame(),
                &batch.stored,
            );
            w.applied = batch.seq;
            self.applied.store(batch.seq, Ordering::Release);
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
        *lock(&self.last_used) = Instant::now();
        if (!self.loaded.load(Ordering::Acquire) || state.store.backend() == Backend::Postgres)
            && !self.catch_up(state, None).await?
        {
            return Err(ApiError::not_found("mission", self.mission.id.as_str()));
        }
        let cur = self.published();
        if cur.seq >= self.applied.load(Ordering::Acquire) {
            return Ok(cur);
        }
        let _building = self.build.lock().await;
        let cur = self.published();
        let (predictor, seq) = {
            let w = self.writer.lock().await;
            (w.predictor.clone(), w.applied)
        };
        if cur.seq >= seq {
            return Ok(cur);
        }
        let mission = self.mission.clone();
        let snap = Arc::new(
            state
                .run_cpu(move || Snapshot::build(&mission, seq, predictor))
                .await?,
        );
        *lock(&self.published) = snap.clone();
        Ok(snap)
    }
}

/// Every live mission, by id.
#[derive(Debug)]
pub struct LiveStates {
    cfg: LiveConfig,
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
            cfg,
            missions: Mutex::new(HashMap::new()),
            last_sweep: Mutex::new(Instant::now()),
        }
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
        self.entry(mission).snapshot(state).await
    }

    /// The cached state of a mission, if live.
    pub fn cached(&self, mission_id: &str) -> Option<Arc<MissionLive>> {
        lock(&self.missions).get(mission_id).cloned()
    }

    /// Applies a batch this replica committed, then rebuilds the map in the background
    /// (the caller does not wait for it).
    pub async fn apply(&self, state: &AppState, mission_id: &str, batch: &StoredBatch) {
        let Some(live) = self.cached(mission_id) else {
            return;
        };
        if let Err(e) = live.apply(state, batch).await {
            // The next read catches up from the store.
            tracing::warn!(mission = %mission_id, error = %e, "live state not updated");
            live.loaded.store(false, Ordering::Release);
            return;
        }
        prebuild(state, live);
    }

    /// A batch `seq` of `mission_id` was committed (by any replica): catch up if live.
    pub async fn notified(&self, state: &AppState, mission_id: &str, seq: i64) {
        let Some(live) = self.cached(mission_id) else {
            return;
        };
        if !live.loaded.load(Ordering::Acquire) || live.applied.load(Ordering::Acquire) >= seq {
            return;
        }
        match live.catch_up(state, Some(seq)).await {
            Ok(_) => prebuild(state, live),
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
    pub fn forget(&self, mission_id: &str) {
        lock(&self.missions).remove(mission_id);
    }

    fn sweep(&self) {
        let now = Instant::now();
        {
            let mut last = lock(&self.last_sweep);
            if now.duration_since(*last) < (self.cfg.idle / 4).max(Duration::from_millis(100)) {
                return;
            }
            *last = now;
        }
        lock(&self.missions).retain(|_, l| now.duration_since(*lock(&l.last_used)) < self.cfg.idle);
    }
}

/// Publishes the snapshot of the batches applied so far, off the caller's path.
fn prebuild(state: &AppState, live: Arc<MissionLive>) {
    let state = state.clone();
    tokio::spawn(async move {
        if let Err(e) = live.snapshot(&state).await {
            tracing::warn!(mission = %live.mission.id, error = %e, "snapshot build failed");
        }
    });
}
