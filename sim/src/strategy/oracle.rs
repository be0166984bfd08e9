//! The oracle: the ceiling every table is compared with (issue 10). The same aircraft,
//! replanning period, stack handling and planner as [`super::bisection`], with hold
//! circles on (`planner::PlanParams::hold`: a verified wait), but planning
//! against the spheres' true future (ground truth) instead of a prediction: the risk field
//! is 1 inside a sphere (radius plus the same safety buffer as the predictor's map) whose
//! true altitude at that time is within reach of the leg's altitudes, else 0. A hit the
//! oracle takes is one the planner could not avoid even knowing the future.

use predictor::RiskField;

use super::{Command, Strategy, View};
use crate::geometry::dist;
use crate::scenario::MovingSphere;

/// Ground truth as a risk field for the altitude band `[alt_lo_m, alt_hi_m]`.
struct Truth<'a> {
    spheres: &'a [MovingSphere],
    buffer_m: f64,
    alt_lo_m: f64,
    alt_hi_m: f64,
}

impl Truth<'_> {
    /// 1 inside a sphere (plus the buffer) that reaches altitudes `[lo, hi]` at `t_s`.
    fn inside(&self, p_m: [f64; 2], t_s: f64, [lo, hi]: [f64; 2]) -> f64 {
        for s in self.spheres {
            let c = s.track.at(t_s);
            let r = s.radius_m + self.buffer_m;
            if c[2] + r >= lo && c[2] - r <= hi && dist(p_m, [c[0], c[1]]) <= r {
                return 1.0;
            }
        }
        0.0
    }
}

impl RiskField for Truth<'_> {
    fn risk(&self, p_m: [f64; 2], t_s: f64) -> f64 {
        self.inside(p_m, t_s, [self.alt_lo_m, self.alt_hi_m])
    }

    /// The leg's own altitudes (within the route's): a sphere the leg passes over or
    /// under is not in its way, as for the prediction's map.
    fn risk_in_band(&self, p_m: [f64; 2], t_s: f64, band_m: [f64; 2]) -> f64 {
        self.inside(
            p_m,
            t_s,
            [band_m[0].max(self.alt_lo_m), band_m[1].min(self.alt_hi_m)],
        )
    }
}

/// Perfect-knowledge replanning through the server's pipeline.
#[derive(Debug)]
pub struct Oracle {
    /// Replanning parameters (the server's).
    pub config: planner::ReplanConfig,
    /// Replanning period, seconds.
    pub period_s: f64,
    seed: u64,
    calls: u64,
    clock: super::TargetClock,
}

impl Oracle {
    /// A fresh oracle.
    pub fn new(seed: u64) -> Self {
        let mut config = planner::ReplanConfig::default();
        // Knowing the future, a verified wait is a real one: the ceiling may hold
        // (`PlanParams::hold`), which the prediction-based strategies do not.
        config.plan.hold = true;
        // The truth far ahead is a collision, not a spread that moves from one map to the
        // next: no stack is kept for being unclear only far ahead
        // (`PlanParams::keep_marginal_factor`).
        config.plan.keep_marginal_factor = 0.0;
        Self {
            config,
            period_s: 1.0,
            seed,
            calls: 0,
            clock: super::TargetClock::default(),
        }
    }
}

impl Strategy for Oracle {
    fn period_s(&self) -> f64 {
        self.period_s
    }

    fn decide(&mut self, view: &View<'_>) -> Command {
        self.calls += 1;
        let (mut lo, mut hi) = (view.own.p_m[2], view.own.p_m[2]);
        for it in view.stack.remaining() {
            lo = lo.min(it.alt_m);
            hi = hi.max(it.alt_m);
        }
        let truth = Truth {
            spheres: view.truth,
            buffer_m: self.config.map.buffer_m,
            alt_lo_m: lo,
            alt_hi_m: hi,
        };
        let seed = planner::plan::leg_seed(self.seed, self.calls as usize, 0);
        super::replan_command(
            view,
            planner::Dynamic::Field(&truth),
            &self.config,
            seed,
            &mut self.clock,
        )
    }
}
