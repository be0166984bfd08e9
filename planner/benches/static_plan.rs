//! Static-only planning on the Webster Field mission (14 waypoints) with 5, 10 and 20
//! cylinders placed on its legs (no moving obstacles). Target: 10 cylinders, median <= 1 ms
//! on one core. Also prints the waypoints added (a tangent-graph A* adds ~40 for 10).

#[path = "../tests/common/mod.rs"]
mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use planner::stack::mission_stack;
use planner::{Aircraft, PlanParams, PlanRequest, plan};
use predictor::NoRisk;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let base = common::webster();
    let mut g = c.benchmark_group("static_plan");
    for n in [5usize, 10, 20] {
        let mut m = base.clone();
        m.cylinders = common::cylinders_on_legs(&base, n, 11);
        let stack = mission_stack(&m);
        let st = common::state_at_first_waypoint(&m);
        let req = PlanRequest {
            mission: &m,
            aircraft: Aircraft {
                speed_mps: 20.0,
                turn_radius_m: 40.0,
            },
            stack: &stack,
            current_index: 1,
            state: st,
            params: PlanParams::default(),
            seed: 1,
        };
        let p = plan(&req, &NoRisk).unwrap();
        println!(
            "static_plan/{n}: {} cylinders placed, outcome {:?}, waypoints added {}, turn violations {}, length {:.0} m",
            m.cylinders.len(),
            p.outcome,
            p.added,
            p.turn_violations.len(),
            p.length_m
        );
        g.bench_function(format!("cylinders_{n}"), |b| {
            b.iter(|| plan(black_box(&req), &NoRisk).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
