//! Closed-loop throughput: one whole run of a generated mixed scenario per strategy.
//! Divide the scenario's mission time by the median to get simulated seconds per second.

use criterion::{Criterion, criterion_group, criterion_main};
use sim::run::{RunConfig, run_with_streams};
use sim::scenario::{Family, ScenarioParams, generate};
use sim::strategy::StrategyKind;
use sim::telemetry::sample_streams;

fn bench(c: &mut Criterion) {
    let s = generate(Family::Mixed, 1, &ScenarioParams::default());
    let cfg = RunConfig {
        record_track: false,
        ..RunConfig::default()
    };
    let streams = sample_streams(&s, &cfg.telemetry);
    let mut g = c.benchmark_group("run_mixed_seed1");
    g.sample_size(10);
    for k in [
        StrategyKind::Tangent,
        StrategyKind::ConstantVelocity,
        StrategyKind::BisectionAuto,
        StrategyKind::ReactiveSectors,
    ] {
        let mission_s = run_with_streams(&s, &streams, k, &cfg)
            .metrics
            .mission_time_s;
        g.bench_function(format!("{} ({mission_s:.0} s mission)", k.name()), |b| {
            b.iter(|| run_with_streams(&s, &streams, k, &cfg));
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
