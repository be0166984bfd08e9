use sim::run::{RunConfig, run};
use sim::scenario::{Family, ScenarioParams, generate};
use sim::strategy::StrategyKind;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let k = StrategyKind::parse(&a[1]).unwrap();
    let seeds: u64 = a[2].parse().unwrap();
    for seed in 0..seeds {
        let s = generate(Family::Mixed, seed, &ScenarioParams::default());
        let r = run(&s, k, &RunConfig::default());
        if r.metrics.cylinders_hit + r.metrics.spheres_hit > 0 {
            println!(
                "seed {seed} sph {} cyl {}",
                r.metrics.spheres_hit, r.metrics.cylinders_hit
            );
            std::fs::write(
                format!("/tmp/sim_{}_{seed}.svg", k.name()),
                sim::svg::plot_run(&s, &r),
            )
            .unwrap();
        }
    }
}
