//! Full replan on the Webster Field mission (14 waypoints, its 6 cylinders) with 10
//! moving obstacles and a 60 s horizon. The risk map uses 10 m cells and 1 s slices over
//! the fly zone's box plus 100 m, as the server does.
//!
//! Variants:
//! - `riskmap_incremental_update_and_plan`: one new observation of one obstacle, the
//!   predictor's incremental `RiskMap` update, then `plan` on that map (the replan loop);
//! - `riskmap_rebuild_and_plan`: a full rebuild of the map for all 10 obstacles, then `plan`;
//! - `plan_on_riskmap`: `plan` alone on a built map;
//! - `plan_on_synthetic_field`: `plan` on moving Gaussian blobs (analytic field).
//!
//! Besides criterion's report, a plain loop records every iteration's time and prints
//! p50 / p99 (criterion reports means and medians of batches, not tail latencies).

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use planner::stack::mission_stack;
use planner::{Aircraft, AircraftState, Plan, PlanParams, PlanRequest, plan};
use predictor::{Observation, Predictor, PredictorConfig, RiskMapConfig};

struct Setup {
    mission: planner::Mission,
    stack: Vec<planner::StackItem>,
    state: AircraftState,
    movers: common::Blobs,
    cfg: RiskMapConfig,
    path: Vec<[f64; 2]>,
}

fn setup() -> Setup {
    let mission = common::webster();
    let movers = common::synthetic_movers(&mission, 10, 42);
    let stack = mission_stack(&mission);
    let state = common::state_at_first_waypoint(&mission);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &mission.fly_zones[0].boundary_m {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    let cfg = RiskMapConfig::default()
        .bounds(
            [lo[0] - 100.0, lo[1] - 100.0],
            [hi[0] + 100.0, hi[1] + 100.0],
        )
        .time(1.0, 60.0);
    let path = std::iter::once(state.p_m)
        .chain(stack[1..].iter().map(|i| i.p_m))
        .collect();
    Setup {
        mission,
        stack,
        state,
        movers,
        cfg,
        path,
    }
}

/// Ten seconds of 1 Hz observations of every mover, ending at t = 0.
fn predictor_with_history(s: &Setup) -> Predictor {
    let mut p = Predictor::new(PredictorConfig::default());
    for k in -10..=0 {
        observe_all(&mut p, s, f64::from(k));
    }
    p
}

fn observe_all(p: &mut Predictor, s: &Setup, t: f64) {
    for (i, b) in s.movers.0.iter().enumerate() {
        observe(p, &i.to_string(), b, t);
    }
}

fn observe(p: &mut Predictor, id: &str, b: &common::Blob, t: f64) {
    let pos = [b.p0_m[0] + b.v_mps[0] * t, b.p0_m[1] + b.v_mps[1] * t];
    p.observe(
        id,
        Observation {
            t_s: t,
            p_m: pos,
            alt_m: 60.0,
            radius_m: b.radius_m,
        },
    );
}

fn request<'a>(s: &'a Setup, seed: u64) -> PlanRequest<'a> {
    PlanRequest {
        mission: &s.mission,
        aircraft: Aircraft {
            speed_mps: 20.0,
            turn_radius_m: 40.0,
        },
        stack: &s.stack,
        current_index: 1,
        state: s.state,
        params: PlanParams::default().horizon_s(60.0),
        seed,
    }
}

fn percentiles(name: &str, mut f: impl FnMut(u64)) {
    let mut v: Vec<Duration> = Vec::with_capacity(300);
    for i in 0..300 {
        let t = Instant::now();
        f(i as u64);
        v.push(t.elapsed());
    }
    report(name, v);
}

fn report(name: &str, mut v: Vec<Duration>) {
    let n = v.len();
    v.sort_unstable();
    let q = |p: f64| v[((n as f64 - 1.0) * p).round() as usize].as_secs_f64() * 1e3;
    println!(
        "{name}: n = {n}, p50 = {:.3} ms, p99 = {:.3} ms, max = {:.3} ms",
        q(0.5),
        q(0.99),
        q(1.0)
    );
}

fn describe(name: &str, p: &Plan) {
    println!(
        "{name}: outcome {:?}, waypoints added {}, risk {:.4} (stack {:.4}), turn violations {}, evaluations {}",
        p.outcome,
        p.added,
        p.risk,
        p.base_risk,
        p.turn_violations.len(),
        p.evaluations
    );
}

fn bench(c: &mut Criterion) {
    let s = setup();
    let mut pred = predictor_with_history(&s);
    let _ = &mut pred;
    let map = pred.build_risk_map(&s.cfg, &s.path, 0.0).unwrap();
    describe("plan_on_riskmap", &plan(&request(&s, 1), &map).unwrap());
    describe(
        "plan_on_synthetic_field",
        &plan(&request(&s, 1), &s.movers).unwrap(),
    );

    // Tail latencies, one thread. The incremental case starts each iteration from the same
    // predictor (cloned outside the timed part, with its cached map) and times: one new
    // observation of one obstacle, the incremental map update, the plan.
    let _ = pred.risk_map(&s.cfg, &s.path, 0.0);
    let mut v = Vec::with_capacity(300);
    for i in 0..300u64 {
        let mut p = pred.clone();
        let k = (i % 10) as usize;
        let t = Instant::now();
        observe(&mut p, &k.to_string(), &s.movers.0[k], 1.0);
        let m = p.risk_map(&s.cfg, &s.path, 0.0);
        black_box(plan(&request(&s, i), m).unwrap());
        v.push(t.elapsed());
    }
    report("replan/riskmap_incremental_update_and_plan", v);
    let fresh = predictor_with_history(&s);
    percentiles("replan/riskmap_rebuild_and_plan", |i| {
        let m = fresh.build_risk_map(&s.cfg, &s.path, 0.0).unwrap();
        black_box(plan(&request(&s, i), &m).unwrap());
    });
    percentiles("replan/plan_on_riskmap", |i| {
        black_box(plan(&request(&s, i), &map).unwrap());
    });
    percentiles("replan/plan_on_synthetic_field", |i| {
        black_box(plan(&request(&s, i), &s.movers).unwrap());
    });

    let mut g = c.benchmark_group("replan");
    g.bench_function("riskmap_incremental_update_and_plan", |b| {
        b.iter_batched(
            || pred.clone(),
            |mut p| {
                observe(&mut p, "3", &s.movers.0[3], 1.0);
                let m = p.risk_map(&s.cfg, &s.path, 0.0);
                black_box(plan(&request(&s, 1), m).unwrap());
                p
            },
            criterion::BatchSize::PerIteration,
        )
    });
    g.bench_function("plan_on_riskmap", |b| {
        b.iter(|| black_box(plan(&request(&s, 1), &map).unwrap()))
    });
    g.bench_function("plan_on_synthetic_field", |b| {
        b.iter(|| black_box(plan(&request(&s, 1), &s.movers).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
