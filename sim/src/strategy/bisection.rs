//! Monte Carlo bisection (seed 002) in closed loop: the predictor is fed the obstacle
//! telemetry received since the last call, a risk map is built from slice time "now" over
//! the horizon (threat-filtered against the remaining route), and the planner replans the
//! stack's tail with its static pre-pass plus Monte Carlo bisection. The predictor's stage is
//! either forced (to compare stages) or automatic.
//!
//! Defaults tuned for closed-loop use at 1 Hz: horizon 20 s in 1 s slices, 12 m cells,
//! 64 particles, buffer 10 m. Plans run without a deadline so that a run is reproducible
//! bit for bit; the plan seed is derived from the run seed and the call count.

use predictor::{Observation, Predictor, PredictorConfig, RiskMapConfig, Stage};

use super::planner_adapter::{
    from_planner_stack, to_planner_aircraft, to_planner_mission, to_planner_stack, to_planner_state,
};
use super::route::route_points;
use super::{Command, ForcedStage, Strategy, View};
use crate::geometry::xy;

/// Map a forced stage to the predictor's.
pub fn stage_of(s: ForcedStage) -> Stage {
    match s {
        ForcedStage::NoFly => Stage::NoFly,
        ForcedStage::Random => Stage::Random,
        ForcedStage::Advanced => Stage::Advanced,
        ForcedStage::Memory => Stage::Memory,
    }
}

/// Monte Carlo bisection against the predictor's risk map.
#[derive(Debug)]
pub struct Bisection {
    predictor: Predictor,
    fed: Vec<usize>,
    /// Risk-map parameters (bounds are set from the mission at the first call).
    pub map: RiskMapConfig,
    /// Planner parameters.
    pub plan: planner::PlanParams,
    /// Replanning period, seconds.
    pub period_s: f64,
    seed: u64,
    calls: u64,
    planner_mission: Option<planner::Mission>,
}

impl Bisection {
    /// A fresh strategy; `forced` pins the predictor's stage.
    pub fn new(forced: Option<ForcedStage>, seed: u64) -> Self {
        let cfg = PredictorConfig::default().forced_stage(forced.map(stage_of));
        let horizon_s = 20.0;
        Self {
            predictor: Predictor::new(cfg),
            fed: vec![],
            map: RiskMapConfig::default()
                .cell_m(12.0)
                .time(1.0, horizon_s)
                .particles(64)
                .buffer_m(10.0)
                // One resolution throughout: the 20 s horizon is short, and the README's
                // results table was measured this way.
                .resolution(f64::INFINITY, f64::INFINITY, 1)
                .seed(seed),
            plan: planner::PlanParams::default().horizon_s(horizon_s),
            period_s: 1.0,
            seed,
            calls: 0,
            planner_mission: None,
        }
    }

    /// The predictor (for reports).
    pub fn predictor(&self) -> &Predictor {
        &self.predictor
    }
}

impl Strategy for Bisection {
    fn period_s(&self) -> f64 {
        self.period_s
    }

    fn decide(&mut self, view: &View<'_>) -> Command {
        if self.planner_mission.is_none() {
            let (lo, hi) = view.mission.bounds_m();
            self.map = self.map.clone().bounds(
                [lo[0] - 100.0, lo[1] - 100.0],
                [hi[0] + 100.0, hi[1] + 100.0],
            );
            self.planner_mission = Some(to_planner_mission(view.mission));
        }
        self.fed.resize(view.tracks.len(), 0);
        for (i, track) in view.tracks.iter().enumerate() {
            let id = i.to_string();
            for o in &track[self.fed[i]..] {
                let obs = Observation {
                    t_s: o.t_s,
                    p_m: [o.p_m[0], o.p_m[1]],
                    alt_m: o.p_m[2],
                    radius_m: o.radius_m,
                };
                self.predictor.observe(&id, obs);
            }
            self.fed[i] = track.len();
        }
        let path: Vec<[f64; 2]> = route_points(view.stack, view.own.p_m)
            .into_iter()
            .map(xy)
            .collect();
        let map = self.predictor.risk_map(&self.map, &path, view.t_s);
        let mission = self.planner_mission.as_ref().expect("set above");
        let stack = to_planner_stack(view.stack);
        self.calls += 1;
        let req = planner::PlanRequest {
            mission,
            aircraft: to_planner_aircraft(view.aircraft),
            stack: &stack,
            current_index: view.stack.current,
            state: to_planner_state(&view.own),
            params: self.plan,
            seed: planner::plan::leg_seed(self.seed, self.calls as usize, 0),
        };
        match planner::plan(&req, map) {
            Ok(p) => Command::Replace(from_planner_stack(&p.items, p.current_index)),
            Err(_) => Command::Keep,
        }
    }
}
