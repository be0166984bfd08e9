//! Per-mission predictor cache (seed 002, "Obstacle characterization", served).
//!
//! Each mission's [`predictor::Predictor`] is built lazily from the stored observations
//! (ordered by time) the first time it is needed, so the characterization (stages, stage
//! history, estimates) survives a restart: it is a deterministic function of the stored
//! telemetry. Afterwards it is kept current two ways: the observation POST handler feeds
//! newly stored rows into a cached predictor ([`PredictorCache::feed`]), and every read
//! catches up with rows stored after the newest one fed (rows another replica stored).
//! Out-of-order rows older than that posted to another replica are picked up on the next
//! rebuild only.
//!
//! The risk map is the predictor's own cached map, anchored at the latest telemetry or
//! observation time: re-anchored (a full rebuild into the same allocation) when that time
//! moves, updated incrementally per obstacle when only new observations arrived.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use predictor::{Observation, Predictor, PredictorConfig, RiskMapConfig};

use crate::error::ApiError;
use crate::geodesy::LocalFrame;
use crate::mission::Mission;
use crate::store::{ObservationRow, Store};

/// Risk-map cell size the service uses, metres (maps cover the fly zones plus a margin).
pub const SERVICE_CELL_M: f64 = 10.0;
/// Margin around the fly zones' bounding box, metres.
pub const SERVICE_MARGIN_M: f64 = 300.0;

/// One mission's predictor and the frame its observations are converted with.
#[derive(Debug)]
pub struct MissionPredictor {
    /// The predictor.
    pub predictor: Predictor,
    /// The mission's ENU frame.
    pub frame: LocalFrame,
    /// Newest observation time fed so far, Unix seconds.
    pub fed_until_s: f64,
    /// Risk-map grid for this mission.
    pub map_cfg: RiskMapConfig,
}

impl MissionPredictor {
    fn new(mission: &Mission) -> Self {
        let frame = mission.frame();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut pts: Vec<[f64; 2]> = mission
            .content
            .fly_zones
            .iter()
            .flat_map(|z| z.boundary.iter())
            .map(|p| frame.to_enu(p.lat, p.lon))
            .collect();
        pts.push([0.0, 0.0]);
        for p in &pts {
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
        }
        let map_cfg = RiskMapConfig::default()
            .bounds(
                [lo[0] - SERVICE_MARGIN_M, lo[1] - SERVICE_MARGIN_M],
                [hi[0] + SERVICE_MARGIN_M, hi[1] + SERVICE_MARGIN_M],
            )
            .cell_m(SERVICE_CELL_M);
        Self {
            predictor: Predictor::new(PredictorConfig::default()),
            frame,
            fed_until_s: f64::NEG_INFINITY,
            map_cfg,
        }
    }

    /// Feeds stored rows (any order; duplicates are ignored by the predictor).
    pub fn feed(&mut self, rows: &[ObservationRow]) {
        for r in rows {
            self.predictor.observe(
                &r.obstacle_id,
                Observation {
                    t_s: r.t_s,
                    p_m: self.frame.to_enu(r.lat_deg, r.lon_deg),
                    alt_m: r.alt_msl_m,
                    radius_m: r.radius_m,
                },
            );
            self.fed_until_s = self.fed_until_s.max(r.t_s);
        }
    }
}

/// Shared handle to one mission's predictor.
pub type SharedPredictor = Arc<Mutex<MissionPredictor>>;

/// Predictors by mission id.
#[derive(Debug, Default)]
pub struct PredictorCache {
    missions: Mutex<HashMap<String, SharedPredictor>>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A panic while holding the lock leaves a predictor that is at worst missing rows,
    // which the next catch-up or rebuild restores: keep serving.
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl PredictorCache {
    /// Feeds newly stored rows to the mission's predictor if it is cached (otherwise the
    /// next read builds it from the store, rows included). Cheap: a few observations.
    pub fn feed(&self, mission_id: &str, rows: &[ObservationRow]) {
        let cached = lock(&self.missions).get(mission_id).cloned();
        if let Some(p) = cached {
            lock(&p).feed(rows);
        }
    }

    /// Forgets a mission (deleted).
    pub fn forget(&self, mission_id: &str) {
        lock(&self.missions).remove(mission_id);
    }

    /// The mission's predictor, built from the store on first use and caught up with rows
    /// stored since. The CPU part runs through `run_cpu`.
    ///
    /// # Errors
    /// Database errors.
    pub async fn get(
        &self,
        state: &crate::app::AppState,
        store: &Store,
        mission: &Mission,
    ) -> Result<SharedPredictor, ApiError> {
        let cached = lock(&self.missions).get(&mission.id).cloned();
        let (shared, after) = match cached {
            Some(p) => {
                let after = lock(&p).fed_until_s;
                (p, Some(after))
            }
            None => (Arc::new(Mutex::new(MissionPredictor::new(mission))), None),
        };
        let rows = store
            .list_observations(&mission.id, None, after.filter(|a| a.is_finite()))
            .await?;
        if !rows.is_empty() {
            let p = shared.clone();
            state.run_cpu(move || lock(&p).feed(&rows)).await?;
        }
        if after.is_none() {
            // Another request may have built it meanwhile: keep the first one.
            let mut m = lock(&self.missions);
            return Ok(m.entry(mission.id.clone()).or_insert(shared).clone());
        }
        Ok(shared)
    }
}
