use predictor::{Observation, Predictor, PredictorConfig, RiskMapConfig};
use sim::scenario::{Family, ScenarioParams, generate};
use sim::strategy::planner_adapter::*;
use sim::telemetry::{TelemetryParams, sample_streams};
use std::time::Instant;
fn main() {
    let s = generate(Family::Mixed, 3, &ScenarioParams::default());
    let streams = sample_streams(&s, &TelemetryParams::default());
    let mut p = Predictor::new(PredictorConfig::default());
    let (lo, hi) = s.mission.bounds_m();
    let env = |k: &str, d: f64| std::env::var(k).ok().map_or(d, |v| v.parse().unwrap());
    let cfg = RiskMapConfig::default()
        .cell_m(env("CELL", 8.0))
        .time(1.0, env("HOR", 30.0))
        .particles(env("PART", 128.0) as usize)
        .buffer_m(10.0)
        .bounds(
            [lo[0] - 100.0, lo[1] - 100.0],
            [hi[0] + 100.0, hi[1] + 100.0],
        );
    let mission = to_planner_mission(&s.mission);
    let stack = to_planner_stack(&s.mission.initial_stack());
    let (mut tf, mut tm, mut tp) = (0.0, 0.0, 0.0);
    let mut fed = vec![0; streams.len()];
    for sec in 0..60 {
        let t = sec as f64;
        let a = Instant::now();
        for (i, st) in streams.iter().enumerate() {
            let n = st.partition_point(|o| o.t_s <= t);
            for o in &st[fed[i]..n] {
                p.observe(
                    &i.to_string(),
                    Observation {
                        t_s: o.t_s,
                        p_m: [o.p_m[0], o.p_m[1]],
                        alt_m: o.p_m[2],
                        radius_m: o.radius_m,
                    },
                );
            }
            fed[i] = n;
        }
        let b = Instant::now();
        let path: Vec<[f64; 2]> = std::iter::once([s.mission.start_m[0], s.mission.start_m[1]])
            .chain(s.mission.waypoints_m.iter().map(|w| [w[0], w[1]]))
            .collect();
        let map = p.risk_map(&cfg, &path, t);
        let c = Instant::now();
        let req = planner::PlanRequest {
            mission: &mission,
            aircraft: planner::Aircraft::default(),
            stack: &stack,
            current_index: 0,
            state: planner::AircraftState {
                p_m: [s.mission.start_m[0], s.mission.start_m[1]],
                alt_m: 100.0,
                heading_rad: 0.0,
                speed_mps: 20.0,
                t_s: t,
            },
            params: planner::PlanParams::default().horizon_s(env("HOR", 30.0)),
            seed: 1,
        };
        let _ = planner::plan(&req, map);
        let d = Instant::now();
        tf += (b - a).as_secs_f64();
        tm += (c - b).as_secs_f64();
        tp += (d - c).as_secs_f64();
    }
    println!(
        "per call ms: feed {:.3} map {:.3} plan {:.3}",
        tf / 60.0 * 1e3,
        tm / 60.0 * 1e3,
        tp / 60.0 * 1e3
    );
}
