//! Monte Carlo bisection (seed 002) in closed loop, exactly as `jink serve` plans: the
//! predictor is fed the obstacle telemetry received since the last call, and the planner
//! replans the stack's tail through the one replanning seam ([`planner::replan`]) with the
//! service's parameters ([`planner::ReplanConfig::default`]: 10 m cells, the multi-resolution
//! schedule, 30 s horizon, 300 m margin) against the same live map the server keeps
//! ([`planner::live_map`]: anchored at the newest observation, every fresh obstacle, no
//! threat filter). The predictor's stage is either forced (to compare stages) or automatic.
//! As in the server, the live state (predictor and map) is brought up to date first and the
//! plan then reads the built map ([`planner::Dynamic::Map`]); the time of the first part is
//! reported apart from the plan's ([`Strategy::take_live_ms`]), because the server does it
//! when observations arrive, not while a plan request waits.
//! Plans run without a deadline so that a run is reproducible bit for bit; the plan seed is
//! derived from the run seed and the call count.

use predictor::{Observation, Predictor, PredictorConfig, Stage};

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
    live_ms: Option<f64>,
    live_cpu_ms: Option<f64>,
    clock: super::TargetClock,
}

impl Bisection {
    /// A fresh strategy; `forced` pins the predictor's stage.
    pub fn new(forced: Option<ForcedStage>, seed: u64) -> Self {
        let cfg = PredictorConfig::default().forced_stage(forced.map(stage_of));
        Self {
            predictor: Predictor::new(cfg),
            fed: vec![],
            config: planner::ReplanConfig::default(),
            period_s: 1.0,
            seed,
            calls: 0,
            live_ms: None,
            live_cpu_ms: None,
            clock: super::TargetClock::default(),
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

    fn take_live_ms(&mut self) -> Option<f64> {
        self.live_ms.take()
    }

    fn take_live_cpu_ms(&mut self) -> Option<f64> {
        self.live_cpu_ms.take()
    }

    fn decide(&mut self, view: &View<'_>) -> Command {
        let started = std::time::Instant::now();
        let cpu0 = crate::cpu::thread_cpu_ms();
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
        self.calls += 1;
        let seed = planner::plan::leg_seed(self.seed, self.calls as usize, 0);
        // The server's live state: the map built from the predictor (in the server, in the
        // background when a batch arrives), then the plan on it.
        let live = planner::live_map(&self.predictor, view.mission, &self.config);
        let obstacles: Vec<predictor::ObstacleSummary> = self.predictor.obstacles().collect();
        self.live_ms = Some(started.elapsed().as_secs_f64() * 1e3);
        self.live_cpu_ms = crate::cpu::since(cpu0);
        match live {
            Ok(Some(live)) => super::replan_command(
                view,
                planner::Dynamic::Map {
                    map: &live.map,
                    obstacles: &obstacles,
                },
                &self.config,
                seed,
                &mut self.clock,
            ),
            Ok(None) => super::replan_command(
                view,
                planner::Dynamic::None,
                &self.config,
                seed,
                &mut self.clock,
            ),
            // A degenerate mission: the plan reports it (and the stack is kept).
            Err(_) => super::replan_command(
                view,
                planner::Dynamic::Predictor(&self.predictor),
                &self.config,
                seed,
                &mut self.clock,
            ),
        }
    }
}
