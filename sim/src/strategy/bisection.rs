//! Monte Carlo bisection (seed 002) in closed loop: the predictor is fed the obstacle
//! telemetry received since the last call, a risk map is built from slice time "now" over
//! the horizon (threat-filtered against the remaining route), and the planner replans the
//! stack's tail with its static pre-pass plus Monte Carlo bisection. The predictor's stage is
//! either forced (to compare stages) or automatic.
//!
//! Planning goes through the same seam as the server ([`planner::replan`]): the same
//! risk-map grid rule (fly zones and home plus a margin), the same stage-to-sample-budget
//! policy, the same pipeline. The parameters differ from the shared defaults only where
//! stated in [`Bisection::new`] (closed-loop use at 1 Hz, the README's results table was
//! measured this way): horizon 20 s, 12 m cells, 100 m margin, one resolution,
//! 64 particles, buffer 10 m. Plans run without a deadline so that a run is reproducible
//! bit for bit; the plan seed is derived from the run seed and the call count.

use predictor::{Observation, Predictor, PredictorConfig, Stage};

use super::planner_adapter::{
    from_planner_stack, to_planner_aircraft, to_planner_mission, to_planner_stack, to_planner_state,
};
use super::{Command, ForcedStage, Strategy, View};

/// Map a forced stage to the predictor's.
pub fn stage_of(s: ForcedStage) -> Stage {
    match s {
        ForcedStage::NoFly => Stage::NoFly,
        ForcedStage::Random => Stage::Random,
        ForcedStage::Advanced => Stage::Advanced,
        ForcedStage::Memory => Stage::Memory,
    }
}

/// The simulator's replanning parameters: the shared defaults except a 20 s horizon,
/// 12 m cells, 100 m margin, one resolution, 64 particles, 10 m buffer and the run seed.
pub fn sim_config(seed: u64) -> planner::ReplanConfig {
    let mut c = planner::ReplanConfig::default().horizon_s(20.0);
    c.margin_m = 100.0;
    c.map = c
        .map
        .cell_m(12.0)
        .particles(64)
        .buffer_m(10.0)
        // One resolution throughout: the 20 s horizon is short.
        .resolution(f64::INFINITY, f64::INFINITY, 1)
        .seed(seed);
    c
}

/// Monte Carlo bisection against the predictor's risk map.
#[derive(Debug)]
pub struct Bisection {
    predictor: Predictor,
    fed: Vec<usize>,
    /// Replanning parameters (risk map and planner).
    pub config: planner::ReplanConfig,
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
        Self {
            predictor: Predictor::new(cfg),
            fed: vec![],
            config: sim_config(seed),
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
        let mission = self.planner_mission.as_ref().expect("set above");
        let stack = to_planner_stack(view.stack);
        self.calls += 1;
        let r = planner::Replan {
            mission,
            aircraft: to_planner_aircraft(view.aircraft),
            state: to_planner_state(&view.own),
            stack: &stack,
            current_index: view.stack.current,
            strategy: planner::Strategy::Bisection,
            seed: planner::plan::leg_seed(self.seed, self.calls as usize, 0),
        };
        let dynamic = planner::Dynamic::Predictor {
            predictor: &mut self.predictor,
            t0_s: view.t_s,
        };
        match planner::replan(&r, dynamic, &self.config, &planner::Termination::none()) {
            Ok(p) => Command::Replace(from_planner_stack(&p.plan.items, p.plan.current_index)),
            Err(_) => Command::Keep,
        }
    }
}
