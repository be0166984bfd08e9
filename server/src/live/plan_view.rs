//! What a plan takes from a snapshot: the obstacles it considers (each with its stage),
//! those it leaves out and why, the risk map, and warnings when the clocks disagree.
//!
//! The time rule (README "Time rule"): a plan is anchored on its start, the newest aircraft
//! telemetry (else the server's clock). An obstacle is considered when its newest
//! observation is at most `horizon_s` older than the start; older ones are left out as
//! `stale` (their prediction has expired). The map is the snapshot's live map when the
//! considered set and horizon are the live map's, otherwise a map built from the same
//! predictor over the considered set and anchored at the same time (a pure function of the
//! snapshot, so replay rebuilds it). Warnings:
//! - `clock_mismatch`: telemetry older than the newest observation by more than
//!   [`CLOCK_TOLERANCE_S`], or newer by more than the horizon (the two senders' clocks
//!   disagree, e.g. one stamps on receipt and the other carries its own time);
//! - `obstacles_left_out`: some observed obstacles are not in the plan (listed);
//! - `no_telemetry`: the start is a stack item at the server's clock;
//! - `tours_not_learned`: a considered moving obstacle has been watched for less than
//!   [`LEARN_WATCH_S`] and no lap of its tour is recognized ([`not_learned`]): its
//!   prediction is still wide, and jink should be started at set-up.

use std::sync::Arc;

use predictor::RiskMap;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::snapshot::{LIVE_HORIZON_S, Snapshot, build_map, map_config};
use crate::api::obstacles::StageOut;
use crate::mission::Mission;

/// Telemetry may trail the newest obstacle observation by this much before a plan warns,
/// seconds (a few radio periods).
pub const CLOCK_TOLERANCE_S: f64 = 5.0;

/// How long a moving obstacle is watched before its prediction stops counting as young
/// when no lap of its tour is recognized, seconds. On Webster Field with the judges' spline
/// tours (200 seeds, README "What the first lap costs today") flights were 6.1 s shorter a
/// run after 2 min of watching before take-off, 8.2 s after 15 min, and no shorter after
/// 30 s; a lap recognized ends the learning sooner.
pub const LEARN_WATCH_S: f64 = 120.0;

/// The moving obstacles among `obstacles` still being learned: moving (a speed estimate
/// above 0), no lap of a tour recognized, watched (newest less oldest observation) for
/// less than [`LEARN_WATCH_S`]. `(id, watched seconds)`, in the order given.
pub fn not_learned<'a>(
    obstacles: impl IntoIterator<Item = &'a predictor::ObstacleSummary>,
) -> Vec<(String, f64)> {
    obstacles
        .into_iter()
        .filter_map(|o| {
            let watched = o.last_observation.t_s - o.first_t_s;
            (o.estimates.speed_mps > 0.0 && o.lap.is_none() && watched < LEARN_WATCH_S)
                .then(|| (o.id.clone(), watched))
        })
        .collect()
}

/// The `tours_not_learned` message for `young` ([`not_learned`]); `None` when empty.
pub fn not_learned_message(young: &[(String, f64)]) -> Option<String> {
    if young.is_empty() {
        return None;
    }
    let list: Vec<String> = young
        .iter()
        .map(|(id, w)| format!("{id} ({w:.0} s)"))
        .collect();
    Some(format!(
        "{} moving obstacle(s) watched for less than {LEARN_WATCH_S:.0} s with no lap of a tour recognized: {}. Their predicted spreads are wide and plans go wide of them; jink learns a tour from its own first laps (one to five minutes). Start jink and the obstacle feed at set-up, before take-off.",
        young.len(),
        list.join(", ")
    ))
}

/// An obstacle a plan considered or left out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PlanObstacle {
    /// Obstacle id.
    pub id: String,
    /// Characterization stage used.
    pub stage: StageOut,
    /// Time of its newest observation, Unix seconds.
    pub last_t: f64,
    /// True when it is in the plan's risk map.
    pub considered: bool,
    /// Why it was left out (`stale`: newest observation more than the horizon before the
    /// plan's start).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub left_out: Option<String>,
}

/// Something about a plan's inputs the operator should know.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PlanWarning {
    /// `clock_mismatch`, `obstacles_left_out`, `tours_not_learned` (moving obstacles
    /// watched for less than 2 min with no lap recognized: start jink at set-up),
    /// `no_telemetry` or `turn_radius_assumed` (the request gave no
    /// `aircraft.turn_radius_m`; the message names the one used).
    pub code: String,
    /// What happened and what to do about it.
    pub message: String,
}

/// The dynamic inputs of one plan.
#[derive(Debug, Clone)]
pub struct PlanView {
    /// The risk map (None: no obstacle considered).
    pub map: Option<Arc<RiskMap>>,
    /// Every observed obstacle, considered or not, by id.
    pub obstacles: Vec<PlanObstacle>,
    /// Warnings.
    pub warnings: Vec<PlanWarning>,
    /// Sample-budget hint from the least predictable considered stage (None: none).
    pub variability: Option<f64>,
}

/// Whether a plan starting at `start_t_s` with horizon `horizon_s` considers an obstacle
/// last observed at `last_t_s` (README "Time rule"; otherwise it is left out as `stale`).
pub fn considered(last_t_s: f64, start_t_s: f64, horizon_s: f64) -> bool {
    last_t_s >= start_t_s - horizon_s
}

/// The plan's view of `snap` for a start at `start_t_s` (from telemetry when
/// `from_telemetry`) over `horizon_s`; `with_map` false skips the map (insertion only).
///
/// # Errors
/// A risk-map configuration the grid cannot hold (a fly zone too large for 10 m cells).
pub fn plan_view(
    mission: &Mission,
    snap: &Snapshot,
    start_t_s: f64,
    from_telemetry: bool,
    horizon_s: f64,
    with_map: bool,
) -> Result<PlanView, predictor::RiskMapError> {
    let mut obstacles = Vec::new();
    let mut ids = Vec::new();
    let mut var: Option<f64> = None;
    let mut young = Vec::new();
    for o in snap.predictor.obstacles() {
        let last_t = o.last_observation.t_s;
        let considered = considered(last_t, start_t_s, horizon_s);
        if considered {
            young.extend(not_learned([&o]));
            ids.push(o.id.clone());
            let v = o.stage.variability();
            var = Some(var.map_or(v, |a: f64| a.max(v)));
        }
        obstacles.push(PlanObstacle {
            id: o.id,
            stage: o.stage.into(),
            last_t,
            considered,
            left_out: (!considered).then(|| "stale".to_string()),
        });
    }
    let mut warnings = Vec::new();
    if let Some(t0) = snap.anchor_t_s {
        let what = if from_telemetry {
            "the newest aircraft telemetry"
        } else {
            "the server's clock (no aircraft telemetry)"
        };
        if start_t_s < t0 - CLOCK_TOLERANCE_S {
            warnings.push(PlanWarning {
                code: "clock_mismatch".into(),
                message: format!(
                    "the plan starts at {what} (t={start_t_s:.3}), {:.1} s before the newest obstacle observation (t={t0:.3}): the senders' clocks disagree or telemetry is late; obstacles are used at their newest positions. Stamp telemetry and obstacle data with the same clock (or both on receipt).",
                    t0 - start_t_s
                ),
            });
        } else if start_t_s > t0 + horizon_s {
            warnings.push(PlanWarning {
                code: "clock_mismatch".into(),
                message: format!(
                    "the plan starts at {what} (t={start_t_s:.3}), {:.1} s after the newest obstacle observation (t={t0:.3}), beyond the {horizon_s} s horizon: the senders' clocks disagree (one stamped on receipt?) or obstacle data stopped. Stamp telemetry and obstacle data with the same clock (or both on receipt).",
                    start_t_s - t0
                ),
            });
        }
    }
    let left: Vec<&str> = obstacles
        .iter()
        .filter(|o| !o.considered)
        .map(|o| o.id.as_str())
        .collect();
    if !left.is_empty() {
        warnings.push(PlanWarning {
            code: "obstacles_left_out".into(),
            message: format!(
                "{} observed obstacle(s) left out as stale (newest observation more than {horizon_s} s before the plan's start): {}",
                left.len(),
                left.join(", ")
            ),
        });
    }
    if let Some(message) = not_learned_message(&young) {
        warnings.push(PlanWarning {
            code: "tours_not_learned".into(),
            message,
        });
    }
    if !from_telemetry && !obstacles.is_empty() {
        warnings.push(PlanWarning {
            code: "no_telemetry".into(),
            message: "no aircraft telemetry: the plan starts at a stack item at the server's clock"
                .into(),
        });
    }
    let map = match snap.anchor_t_s {
        Some(t0) if with_map && !ids.is_empty() => {
            if ids == snap.map_ids && horizon_s == LIVE_HORIZON_S && snap.map.is_some() {
                snap.map.clone()
            } else {
                Some(Arc::new(build_map(
                    &snap.predictor,
                    &map_config(mission, horizon_s),
                    &ids,
                    t0,
                )?))
            }
        }
        _ => None,
    };
    Ok(PlanView {
        map,
        obstacles,
        warnings,
        variability: var,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use predictor::{Observation, Predictor};

    /// A predictor (the server's configuration) fed obstacle `id` at 5 Hz for `secs`
    /// seconds along `path` (time to ENU metres).
    fn watched(p: &mut Predictor, id: &str, secs: f64, path: impl Fn(f64) -> [f64; 2]) {
        for k in 0..=(secs * 5.0).round() as usize {
            let t_s = 1000.0 + k as f64 * 0.2;
            let obs = Observation {
                t_s,
                p_m: path(t_s - 1000.0),
                alt_m: 100.0,
                radius_m: 20.0,
            };
            p.observe(id, obs);
        }
    }

    fn circle(t: f64) -> [f64; 2] {
        // 60 m radius at 12 m/s: a lap every 31.4 s.
        let w = 12.0 / 60.0;
        [60.0 * (w * t).cos(), 60.0 * (w * t).sin()]
    }

    #[test]
    fn a_moving_obstacle_is_learned_after_two_minutes_or_its_first_lap_and_a_still_one_never_counts()
     {
        let mut p = Predictor::new(super::super::snapshot::predictor_config());
        watched(&mut p, "young", 30.0, |t| [12.0 * t, 0.0]);
        watched(&mut p, "old", 125.0, |t| [12.0 * t, 500.0]);
        watched(&mut p, "still", 30.0, |_| [0.0, -500.0]);
        watched(&mut p, "lapped", 100.0, |t| {
            let c = circle(t);
            [c[0] + 900.0, c[1]]
        });
        let all: Vec<_> = p.obstacles().collect();
        let lapped = all.iter().find(|o| o.id == "lapped").unwrap();
        assert!(lapped.lap.is_some(), "a circle flown three times is a tour");
        assert!(lapped.last_observation.t_s - lapped.first_t_s < LEARN_WATCH_S);
        let young = not_learned(&all);
        assert_eq!(young.len(), 1, "{young:?}");
        assert_eq!(young[0].0, "young");
        assert!((young[0].1 - 30.0).abs() < 1e-9, "{young:?}");
        let m = not_learned_message(&young).unwrap();
        assert!(
            m.starts_with("1 moving obstacle(s)") && m.contains("young (30 s)"),
            "{m}"
        );
        assert_eq!(not_learned_message(&[]), None);
    }
}
