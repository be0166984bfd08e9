//! An immutable view of one mission's live state: the predictor as of a batch sequence
//! number and the risk map built from it. Plans, `GET .../obstacles` and `GET .../risk`
//! read snapshots, so what an operator sees is what the planner used.
//!
//! A snapshot is a deterministic function of (mission, observation rows through `seq` in
//! feeding order): the predictor is fed batch by batch, and the map is always a full build
//! (never the rounding-drifting incremental one) anchored at the newest observation time,
//! over the obstacles observed within [`STALE_AFTER_S`] of it. A stored plan records `seq`,
//! and replay rebuilds the same snapshot from the store ([`Snapshot::build`]), bit for bit.
//!
//! # Units
//! Times are Unix seconds (the mission clock, see the README's "Time rule"); ENU metres.

use std::sync::Arc;

use predictor::{Observation, Predictor, PredictorConfig, RiskMap, RiskMapConfig, RiskMapError};

use super::helper::MapHelper;
use crate::geodesy::LocalFrame;
use crate::mission::Mission;
use crate::store::ObservationRow;

/// Risk-map cell size of the live map, metres (maps cover the fly zones plus a margin).
pub const SERVICE_CELL_M: f64 = 10.0;
/// Margin around the fly zones' bounding box, metres.
pub const SERVICE_MARGIN_M: f64 = 300.0;
/// Horizon of the live map, seconds (the plans' default horizon).
pub const LIVE_HORIZON_S: f64 = planner::DEFAULT_HORIZON_S;
/// Slice interval of the risk maps, seconds (the planner's, so plans and live maps agree).
pub const SLICE_DT_S: f64 = planner::replan::SLICE_DT_S;
/// An obstacle whose newest observation is older than the map's anchor by more than this
/// is left out of the live map (its prediction has expired), seconds.
pub const STALE_AFTER_S: f64 = LIVE_HORIZON_S;

/// The one risk-map configuration of a mission's maps (live, plans, replays): the fly
/// zones' and home's bounding box plus [`SERVICE_MARGIN_M`], [`SERVICE_CELL_M`] cells,
/// [`SLICE_DT_S`] slices over `horizon_s`.
pub fn map_config(mission: &Mission, horizon_s: f64) -> RiskMapConfig {
    service_config(horizon_s).map_config(&mission.to_planner())
}

/// The service's replanning parameters: the shared defaults ([`planner::ReplanConfig`]:
/// [`SERVICE_CELL_M`] cells, [`SERVICE_MARGIN_M`] margin) over `horizon_s`.
pub fn service_config(horizon_s: f64) -> planner::ReplanConfig {
    planner::ReplanConfig::default().horizon_s(horizon_s)
}

/// Feeds stored rows, in the order given (feeding order), to `predictor`.
pub fn feed(predictor: &mut Predictor, frame: &LocalFrame, rows: &[ObservationRow]) {
    for r in rows {
        predictor.observe(
            &r.obstacle_id,
            Observation {
                t_s: r.t_s,
                p_m: frame.to_enu(r.lat_deg, r.lon_deg),
                alt_m: r.alt_msl_m,
                radius_m: r.radius_m,
            },
        );
    }
}

/// The predictor configuration of the service.
pub fn predictor_config() -> PredictorConfig {
    PredictorConfig::default()
}

/// The one live-map rule of server and simulator (anchor, fresh obstacles, full build).
pub use planner::replan::{build_map, fresh_ids};

/// [`build_map`] into `spare`'s allocation when it has the same configuration (a map
/// of an earlier snapshot), else into a new map, sharing the obstacles with `helper` when
/// given. The cells are the same bit for bit: re-anchoring sets every cell an obstacle
/// touched back to exactly 1, as in a new map, and the helper's parts are put in the
/// one-thread order ([`super::helper`]).
fn build_map_into(
    spare: Option<RiskMap>,
    predictor: &Arc<Predictor>,
    cfg: &RiskMapConfig,
    ids: &[String],
    t0_s: f64,
    helper: Option<&MapHelper>,
) -> Result<RiskMap, RiskMapError> {
    let mut map = match spare {
        Some(mut map) if map.config() == cfg => {
            map.reset(&[], t0_s);
            map
        }
        _ => RiskMap::new(cfg.clone(), &[], t0_s)?,
    };
    super::helper::add_obstacles(&mut map, predictor, ids, t0_s, helper);
    Ok(map)
}

/// One mission's live state as of batch `seq`.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Observation batches applied: every row of batches `<= seq`, none after.
    pub seq: i64,
    /// The predictor (tracks, estimates, stages, stage history).
    pub predictor: Arc<Predictor>,
    /// The mission's ENU frame.
    pub frame: LocalFrame,
    /// The map's anchor: the newest observation time, Unix seconds (None: no observation).
    pub anchor_t_s: Option<f64>,
    /// Obstacles in the map (observed within [`STALE_AFTER_S`] of the anchor), ascending.
    pub map_ids: Vec<String>,
    /// The live map ([`LIVE_HORIZON_S`]); None without observations.
    pub map: Option<Arc<RiskMap>>,
    /// How long building the map took, milliseconds.
    pub build_ms: f64,
}

impl Snapshot {
    /// The snapshot of `predictor` after batch `seq` (CPU work: one full map build).
    pub fn build(mission: &Mission, seq: i64, predictor: Arc<Predictor>) -> Self {
        Self::build_reusing(mission, seq, predictor, None, None)
    }

    /// [`Snapshot::build`], building the map in `spare`'s allocation when its
    /// configuration fits (the same snapshot, bit for bit; saves allocating and filling
    /// a map of several MB per batch), sharing its obstacles with `helper` when given
    /// (the same snapshot again, [`super::helper`]).
    pub fn build_reusing(
        mission: &Mission,
        seq: i64,
        predictor: Arc<Predictor>,
        spare: Option<RiskMap>,
        helper: Option<&MapHelper>,
    ) -> Self {
        let started = std::time::Instant::now();
        let frame = mission.frame();
        let anchor_t_s = predictor.latest_t_s();
        let (map_ids, map) = match anchor_t_s {
            None => (Vec::new(), None),
            Some(t0) => {
                let ids = fresh_ids(&predictor, t0 - STALE_AFTER_S);
                let cfg = map_config(mission, LIVE_HORIZON_S);
                let map = match build_map_into(spare, &predictor, &cfg, &ids, t0, helper) {
                    Ok(m) => Some(Arc::new(m)),
                    Err(e) => {
                        // Plans then build their own map and report the error.
                        tracing::warn!(mission = %mission.id, error = %e, "no live risk map");
                        None
                    }
                };
                (ids, map)
            }
        };
        Self {
            seq,
            predictor,
            frame,
            anchor_t_s,
            map_ids,
            map,
            build_ms: started.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// An empty snapshot (before anything was loaded).
    pub fn empty(mission: &Mission) -> Self {
        Self {
            seq: -1,
            predictor: Arc::new(Predictor::new(predictor_config())),
            frame: mission.frame(),
            anchor_t_s: None,
            map_ids: Vec::new(),
            map: None,
            build_ms: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn webster() -> Mission {
        let text = include_str!("../../../tests/fixtures/interop/mission_2021_webster_field.json");
        wire::domain::read_mission_text(text, "webster").expect("fixture")
    }

    /// Three obstacles over 20 s at 5 Hz, one batch per 0.2 s tick, one obstacle's rows
    /// arriving a tick late (out of order).
    fn batches() -> Vec<Vec<ObservationRow>> {
        (0..100)
            .map(|i| {
                let mut b: Vec<ObservationRow> = (0..3)
                    .map(|k| {
                        let t = 1_700_000_000.0
                            + 0.2 * f64::from(if k == 2 { i.max(1) - 1 } else { i });
                        let a = 0.05 * (t - 1_700_000_000.0) + f64::from(k);
                        ObservationRow {
                            obstacle_id: k.to_string(),
                            t_s: t,
                            lat_deg: 38.145 + 0.002 * a.sin(),
                            lon_deg: -76.429 + 0.0025 * a.cos(),
                            alt_msl_m: 60.0,
                            radius_m: 20.0,
                        }
                    })
                    .collect();
                crate::store::observations::sort_feeding_order(&mut b);
                b
            })
            .collect()
    }

    #[test]
    fn a_snapshot_fed_batch_by_batch_equals_one_rebuilt_from_all_rows() {
        let m = webster();
        let frame = m.frame();
        // Live: batches fed one at a time, a snapshot taken (and so a predictor copy
        // forced) after each.
        let mut live = Arc::new(Predictor::new(predictor_config()));
        let mut snap = Snapshot::empty(&m);
        let all = batches();
        for (seq, b) in all.iter().enumerate() {
            feed(Arc::make_mut(&mut live), &frame, b);
            snap = Snapshot::build(&m, seq as i64 + 1, live.clone());
        }
        // Replay: every row in one pass, in feeding order.
        let rows: Vec<ObservationRow> = all.concat();
        let mut p = Predictor::new(predictor_config());
        feed(&mut p, &frame, &rows);
        let rebuilt = Snapshot::build(&m, all.len() as i64, Arc::new(p));
        assert_eq!(snap.anchor_t_s, rebuilt.anchor_t_s);
        assert_eq!(snap.map_ids, ["0", "1", "2"]);
        assert_eq!(snap.map_ids, rebuilt.map_ids);
        let (a, b) = (snap.map.expect("map"), rebuilt.map.expect("map"));
        let t0 = snap.anchor_t_s.expect("anchor");
        let mut nonzero = 0;
        for k in 0..60 {
            let (sa, sb) = (a.slice(t0 + f64::from(k)), b.slice(t0 + f64::from(k)));
            assert_eq!(sa.data, sb.data, "slice {k}");
            nonzero += sa.data.iter().filter(|v| **v > 0.0).count();
        }
        assert!(nonzero > 0, "the map holds the obstacles");
        let stages = |p: &Predictor| {
            p.obstacles()
                .map(|o| (o.id, o.stage, o.stage_history))
                .collect::<Vec<_>>()
        };
        assert_eq!(stages(&snap.predictor), stages(&rebuilt.predictor));
    }

    #[test]
    fn a_map_shared_with_the_helper_thread_equals_a_one_thread_build_bit_for_bit() {
        let m = webster();
        let frame = m.frame();
        // Ten obstacles: the three of `batches` and seven more on circles of their own.
        let mut rows = batches().concat();
        for k in 3..10 {
            for i in 0..100 {
                let t = 1_700_000_000.0 + 0.2 * f64::from(i);
                let a = 0.03 * f64::from(k) * (t - 1_700_000_000.0) + f64::from(k);
                rows.push(ObservationRow {
                    obstacle_id: k.to_string(),
                    t_s: t,
                    lat_deg: 38.145 + 0.0015 * a.sin() + 0.0002 * f64::from(k),
                    lon_deg: -76.429 + 0.002 * a.cos(),
                    alt_msl_m: 60.0,
                    radius_m: 15.0 + 3.0 * f64::from(k),
                });
            }
        }
        crate::store::observations::sort_feeding_order(&mut rows);
        let mut p = Predictor::new(predictor_config());
        feed(&mut p, &frame, &rows);
        let p = Arc::new(p);
        let one = Snapshot::build(&m, 1, p.clone());
        let a = one.map.expect("map");
        assert_eq!(one.map_ids.len(), 10);
        let helper = MapHelper::spawn().expect("a thread");
        // Where the build and the helper meet depends on timing: every run must give the
        // same cells whatever the split (and whether the spare allocation is reused).
        let mut spare = None;
        for run in 0..8 {
            let shared = Snapshot::build_reusing(&m, 1, p.clone(), spare.take(), Some(&helper));
            let b = shared.map.expect("map");
            super::super::helper::assert_same_cells(&a, &b, &format!("run {run}"));
            for id in &one.map_ids {
                assert_eq!(
                    a.obstacle_mass_m2(id, 30),
                    b.obstacle_mass_m2(id, 30),
                    "{id}"
                );
            }
            spare = Arc::try_unwrap(b).ok();
        }
    }

    #[test]
    fn a_map_built_in_a_spare_allocation_equals_a_new_one() {
        let m = webster();
        let frame = m.frame();
        let all = batches();
        let mut p = Predictor::new(predictor_config());
        feed(&mut p, &frame, &all[..60].concat());
        let old = Snapshot::build(&m, 60, Arc::new(p.clone()));
        let spare = Arc::try_unwrap(old.map.expect("map")).expect("sole owner");
        feed(&mut p, &frame, &all[60..].concat());
        let p = Arc::new(p);
        let (new, reused) = (
            Snapshot::build(&m, 100, p.clone()),
            Snapshot::build_reusing(&m, 100, p, Some(spare), None),
        );
        let (a, b) = (new.map.expect("map"), reused.map.expect("map"));
        assert_ne!(a.t0_s(), old.anchor_t_s.expect("anchor"), "re-anchored");
        for k in 0..=60 {
            let t = a.t0_s() + f64::from(k);
            assert_eq!(a.slice(t).data, b.slice(t).data, "slice {k}");
        }
    }

    #[test]
    fn an_obstacle_silent_for_longer_than_the_horizon_is_left_out_of_the_live_map() {
        let m = webster();
        let mut p = Predictor::new(predictor_config());
        let mut rows = batches().concat();
        // Obstacle "9" seen once, 61 s before the newest observation.
        rows.insert(
            0,
            ObservationRow {
                obstacle_id: "9".into(),
                t_s: 1_700_000_000.0 + 19.8 - STALE_AFTER_S - 1.0,
                lat_deg: 38.145,
                lon_deg: -76.429,
                alt_msl_m: 60.0,
                radius_m: 20.0,
            },
        );
        feed(&mut p, &m.frame(), &rows);
        let s = Snapshot::build(&m, 1, Arc::new(p));
        assert_eq!(s.map_ids, ["0", "1", "2"]);
        assert_eq!(s.predictor.obstacles().count(), 4);
    }
}
