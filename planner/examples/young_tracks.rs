//! The first plans of a flight, as a profiler sees them: the Webster Field mission, ten
//! synthetic movers observed at 5 Hz for `AGE` seconds (default 2: young tracks, wide
//! spreads), the server's live map built from them, then `N` replans (default 20, seeds
//! 0..N) from the first waypoint through the replan seam on that map. Prints the map's
//! build time, the first plan's outcome and the plans' p50 and max. `MSEED` picks the
//! movers (default 42; 0, 20 and 29 give `no_safe_path` plans).
//!
//! ```sh
//! cargo build --release -p planner --example young_tracks
//! AGE=2 MSEED=0 target/release/examples/young_tracks
//! AGE=2 MSEED=0 N=3 valgrind --tool=callgrind --toggle-collect='planner::replan::replan' \
//!     target/release/examples/young_tracks   # instructions of the plans alone
//! ```
#[path = "../tests/common/mod.rs"]
mod common;

use planner::stack::mission_stack;
use planner::{Dynamic, ReplanConfig, Termination, replan};
use predictor::{Observation, Predictor, PredictorConfig};
use std::time::Instant;

/// Environment variable `name` parsed, or `default` when unset or unparsable.
fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let age: f64 = env_or("AGE", 2.0);
    let n: u64 = env_or("N", 20);
    let mseed: u64 = env_or("MSEED", 42);
    let mission = common::webster();
    let movers = common::synthetic_movers(&mission, 10, mseed);
    let stack = mission_stack(&mission);
    let state = common::state_at_first_waypoint(&mission);
    let mut p = Predictor::new(PredictorConfig::default());
    let steps = (age * 5.0).round() as i64;
    for k in -steps..=0 {
        let t = k as f64 / 5.0;
        for (i, b) in movers.0.iter().enumerate() {
            p.observe(
                &i.to_string(),
                Observation {
                    t_s: t,
                    p_m: [b.p0_m[0] + b.v_mps[0] * t, b.p0_m[1] + b.v_mps[1] * t],
                    alt_m: mission.waypoints[0].alt_m,
                    radius_m: b.radius_m,
                },
            );
        }
    }
    let cfg = ReplanConfig::default();
    let t = Instant::now();
    let live = planner::live_map(&p, &mission, &cfg).unwrap().unwrap();
    eprintln!("map {:.2} ms", t.elapsed().as_secs_f64() * 1e3);
    let summaries: Vec<_> = p.obstacles().collect();
    let mut times = vec![];
    for seed in 0..n {
        let r = common::replan_request(&mission, &stack, state, seed);
        let t = Instant::now();
        let out = replan(
            &r,
            Dynamic::Map {
                map: &live.map,
                obstacles: &summaries,
            },
            &cfg,
            &Termination::none(),
        )
        .unwrap();
        times.push(t.elapsed().as_secs_f64() * 1e3);
        if seed == 0 {
            eprintln!(
                "outcome {:?} evaluations {} added {}",
                out.plan.outcome, out.plan.evaluations, out.plan.added
            );
        }
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    eprintln!(
        "plan p50 {:.2} ms max {:.2} ms",
        times[times.len() / 2],
        times[times.len() - 1]
    );
}
