use sim::run::{RunConfig, run};
use sim::scenario::{Family, ScenarioParams, generate};
use sim::strategy::StrategyKind;
fn main() {
    let cfg = RunConfig {
        record_track: false,
        ..Default::default()
    };
    let seeds: u64 = std::env::args().nth(1).map_or(5, |s| s.parse().unwrap());
    for k in StrategyKind::ALL {
        let t0 = std::time::Instant::now();
        let mut sim_s = 0.0;
        let (mut sh, mut ch, mut sp, mut cy, mut wc, mut wt, mut comp, mut pr) =
            (0, 0, 0, 0, 0, 0, 0, 0.0);
        for seed in 0..seeds {
            let s = generate(Family::Mixed, seed, &ScenarioParams::default());
            let r = run(&s, k, &cfg);
            let m = r.metrics;
            sim_s += m.mission_time_s;
            sh += m.spheres_hit;
            sp += m.spheres;
            ch += m.cylinders_hit;
            cy += m.cylinders;
            wc += m.waypoints_captured;
            wt += m.waypoints;
            comp += m.completed as usize;
            pr += m.path_ratio;
        }
        let w = t0.elapsed().as_secs_f64();
        println!(
            "{:12} spheres {sh}/{sp} cyl {ch}/{cy} wp {wc}/{wt} completed {comp}/{seeds} ratio {:.3} sim/wall {:.0}",
            k.name(),
            pr / seeds as f64,
            sim_s / w
        );
    }
}
