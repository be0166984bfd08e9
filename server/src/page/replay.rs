//! The page's replay (issue 13, item 2): everything recorded for a mission on one timeline
//! (aircraft telemetry, obstacle observations, every plan), with what the judges' scoring
//! gives, computed by the simulator's own scoring (`sim::scoring`, not a copy): the whole
//! flight's report, and per second of the flight the judged points' smallest clearance
//! and the obstacles hit.
//!
//! The recorded observations stand for the obstacles' true positions (linear between
//! observations, held before the first and after the last), as the judges' server knew
//! them. Risk maps are not replayed.
//!
//! # Units
//! Unix seconds (the mission clock), ENU metres in the mission's frame, metres MSL.

use std::collections::BTreeMap;

use serde_json::{Value, json};
use sim::scoring::{SphereTruth, interpolate, judge, judge_points};

use super::feed::{plan_json, pt, r1};
use crate::api::plan_record::stored_plan_out;
use crate::app::AppState;
use crate::error::ApiError;
use crate::mission::Mission;

/// At most this many plans are replayed (the newest).
pub const MAX_PLANS: i64 = 3000;
/// Obstacle positions are sent at most this often, seconds.
pub const OBSTACLE_STEP_S: f64 = 0.5;

/// One obstacle's observations `(t, [east, north, alt])` in time order, and its radius.
pub type RecordedTrack = (Vec<(f64, [f64; 3])>, f64);

/// Recorded obstacle tracks as the scoring's ground truth: per obstacle (in id order), its
/// observations `(t, [east, north, alt])` in time order and its radius.
#[derive(Debug, Clone, Default)]
pub struct Recorded {
    /// Obstacle ids, in the order of `tracks`.
    pub ids: Vec<String>,
    /// Per obstacle: observations in time order, and the newest radius.
    pub tracks: Vec<RecordedTrack>,
}

impl SphereTruth for Recorded {
    fn sphere_count(&self) -> usize {
        self.tracks.len()
    }

    fn sphere_at(&self, i: usize, t_s: f64) -> ([f64; 3], f64) {
        let (track, r) = &self.tracks[i];
        let k = track.partition_point(|(t, _)| *t <= t_s);
        let p = match (k.checked_sub(1).map(|j| track[j]), track.get(k)) {
            (Some((t0, a)), Some(&(t1, b))) if t1 > t0 => {
                let f = (t_s - t0) / (t1 - t0);
                [0, 1, 2].map(|j| a[j] + (b[j] - a[j]) * f)
            }
            (Some((_, a)), _) => a,
            (None, Some(&(_, b))) => b,
            (None, None) => [f64::INFINITY; 3],
        };
        (p, *r)
    }
}

/// The judges' report and the per-second series of a flight: `telemetry` `(t, [e, n, alt])`
/// in time order against `truth` and `mission` (in the planner's terms).
pub fn score(telemetry: &[(f64, [f64; 3])], truth: &Recorded, mission: &planner::Mission) -> Value {
    let report = judge(telemetry, truth, mission);
    let waypoints_m: Vec<[f64; 3]> = mission
        .waypoints
        .iter()
        .map(|w| [w.p_m[0], w.p_m[1], w.alt_m])
        .collect();
    // The same judged points, scored one second at a time.
    let points = interpolate(telemetry);
    let mut seconds: BTreeMap<i64, Vec<(f64, [f64; 3])>> = BTreeMap::new();
    for p in points {
        seconds.entry(p.0.floor() as i64).or_default().push(p);
    }
    let series: Vec<Value> = seconds
        .iter()
        .map(|(s, pts)| {
            let r = judge_points(pts, truth, &mission.cylinders, &waypoints_m, Some(mission));
            let hit = |h: &[bool]| -> Vec<usize> {
                h.iter()
                    .enumerate()
                    .filter_map(|(i, h)| h.then_some(i))
                    .collect()
            };
            json!({
                "t": s,
                "clearance_m": finite(r.min_clearance_m),
                "sphere_hits": hit(&r.sphere_hits).iter().map(|&i| truth.ids[i].clone()).collect::<Vec<_>>(),
                "cylinder_hits": hit(&r.cylinder_hits),
            })
        })
        .collect();
    json!({
        "sphere_score": report.sphere_score,
        "cylinder_score": report.cylinder_score,
        "spheres_hit": report.sphere_hits.iter().zip(&truth.ids).filter(|(h, _)| **h).map(|(_, id)| id.clone()).collect::<Vec<_>>(),
        "cylinders_hit": report.cylinder_hits.iter().filter(|h| **h).count(),
        "waypoints_captured": report.waypoints_captured.iter().filter(|c| **c).count(),
        "waypoints": report.waypoints_captured.len(),
        "min_clearance_m": finite(report.min_clearance_m),
        "boundary_violation_s": r1(report.boundary_violation_s),
        "per_second": series,
    })
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then(|| r1(x))
}

/// The mission's recorded timeline and its scoring, as the page's replay reads it.
///
/// # Errors
/// Database failures; a stored plan that cannot be read.
pub async fn replay_json(state: &AppState, mission: &Mission) -> Result<Value, ApiError> {
    let id = &mission.id;
    let frame = mission.frame();
    let telemetry = state.store.list_telemetry(id, None).await?;
    let observations = state.store.list_observations(id, None, None).await?;
    let latest = state.store.latest_plan_revision(id).await?;
    let mut plans = Vec::new();
    for rev in (latest - MAX_PLANS + 1).max(1)..=latest {
        if let Some(row) = state.store.get_plan_by_revision(id, rev).await? {
            plans.push(plan_json(&stored_plan_out(&row)?, &frame));
        }
    }
    let mut by_id: BTreeMap<String, RecordedTrack> = BTreeMap::new();
    for o in &observations {
        let e = by_id.entry(o.obstacle_id.clone()).or_default();
        let [x, y] = frame.to_enu(o.lat_deg, o.lon_deg);
        e.0.push((o.t_s, [x, y, o.alt_msl_m]));
        e.1 = o.radius_m;
    }
    let truth = Recorded {
        ids: by_id.keys().cloned().collect(),
        tracks: by_id.into_values().collect(),
    };
    let tel: Vec<(f64, [f64; 3])> = telemetry
        .iter()
        .map(|r| {
            let [x, y] = frame.to_enu(r.lat_deg, r.lon_deg);
            (r.t_s, [x, y, r.alt_msl_m])
        })
        .collect();
    let pm = mission.to_planner();
    let (truth, scoring) = state
        .run_cpu(move || {
            let s = score(&tel, &truth, &pm);
            (truth, s)
        })
        .await?;
    let obstacles: Vec<Value> = truth
        .ids
        .iter()
        .zip(&truth.tracks)
        .map(|(id, (track, r))| {
            let mut last = f64::NEG_INFINITY;
            let samples: Vec<Value> = track
                .iter()
                .filter(|(t, _)| {
                    let keep = *t >= last + OBSTACLE_STEP_S;
                    if keep {
                        last = *t;
                    }
                    keep
                })
                .map(|(t, p)| json!([t, pt([p[0], p[1]])]))
                .collect();
            json!({"id": id, "radius_m": r1(*r), "samples": samples})
        })
        .collect();
    Ok(json!({
        "telemetry": telemetry.iter().map(|r| json!([r.t_s, pt(frame.to_enu(r.lat_deg, r.lon_deg)), r1(r.alt_msl_m), r.heading_deg])).collect::<Vec<_>>(),
        "obstacles": obstacles,
        "plans": plans,
        "scoring": scoring,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of radius 10 m observed at x = 0 (t = 0) and x = 100 m (t = 10), at 100 m.
    fn one_sphere() -> Recorded {
        Recorded {
            ids: vec!["7".into()],
            tracks: vec![(
                vec![(0.0, [0.0, 0.0, 100.0]), (10.0, [100.0, 0.0, 100.0])],
                10.0,
            )],
        }
    }

    #[test]
    fn recorded_obstacles_move_linearly_between_observations_and_hold_outside_them() {
        let r = one_sphere();
        assert_eq!(r.sphere_at(0, 5.0).0, [50.0, 0.0, 100.0]);
        assert_eq!(r.sphere_at(0, -3.0).0, [0.0, 0.0, 100.0]);
        assert_eq!(r.sphere_at(0, 12.0).0, [100.0, 0.0, 100.0]);
    }

    #[test]
    fn the_scoring_names_the_second_and_the_obstacle_the_aircraft_hit() {
        let r = one_sphere();
        let m = planner::Mission {
            fly_zones: vec![],
            waypoints: vec![],
            cylinders: vec![],
        };
        // The aircraft waits at (50, 0, 100) from t = 4 to t = 6: the sphere passes it at
        // t = 5 (inside from 4 to 6); at t = 1 to 2 it is 30 to 40 m away.
        let tel = [
            (1.0, [50.0, 0.0, 100.0]),
            (2.0, [50.0, 0.0, 100.0]),
            (4.5, [50.0, 0.0, 100.0]),
            (5.5, [50.0, 0.0, 100.0]),
        ];
        let s = score(&tel, &r, &m);
        assert_eq!(s["sphere_score"], 0.0);
        assert_eq!(s["spheres_hit"], json!(["7"]));
        let per = s["per_second"].as_array().unwrap();
        let at = |t: i64| per.iter().find(|v| v["t"] == t).unwrap();
        assert_eq!(at(1)["sphere_hits"], json!([]));
        // At t = 1.9 the sphere is at x = 19 m: 31 m from the aircraft, 21 m from its surface.
        assert_eq!(at(1)["clearance_m"], 21.0);
        assert_eq!(at(5)["sphere_hits"], json!(["7"]));
        assert!(at(4)["clearance_m"].as_f64().unwrap() < 0.0);
    }
}
