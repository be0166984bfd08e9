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
//! - `no_telemetry`: the start is a stack item at the server's clock.

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
    /// `clock_mismatch`, `obstacles_left_out`, `no_telemetry` or `turn_radius_assumed`
    /// (the request gave no `aircraft.turn_radius_m`; the message names the one used).
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
    for o in snap.predictor.obstacles() {
        let last_t = o.last_observation.t_s;
        let considered = last_t >= start_t_s - horizon_s;
        if considered {
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
