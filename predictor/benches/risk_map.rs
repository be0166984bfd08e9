//! Risk-map speed targets (one core): incremental update after one observation <= 1 ms,
//! full rebuild of 10 obstacles <= 10 ms, >= 20 M `risk()` queries/s.
//!
//! Scenario: 10 moving obstacles (3 straight, 3 uniform random turners, 2 biased, 2
//! zigzag; 8-18 m/s; radius 30-150 ft) with 120 s of 10 Hz history each, automatic
//! staging, a 1.5 km x 1.5 km grid of 5 m cells (10 m after 15 s, 20 m after 40 s: the
//! default resolution schedule), dt 1 s, horizon 60 s, 256 particles.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{Behaviour, Generator};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use predictor::{Observation, Predictor, PredictorConfig, RiskField, RiskMapConfig};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::{Duration, Instant};

const N: usize = 10;

/// The default map (5 m cells, 256 particles, the default resolution schedule) unless
/// `JINK_BENCH_CELL_M` / `JINK_BENCH_PARTICLES` / `JINK_BENCH_SCHEDULE` say otherwise (to
/// measure the trade-off). The schedule is `fine_horizon_s,coarse_horizon_s,coarse_factor`,
/// e.g. `inf,inf,1` for `cell_m` in every slice. `JINK_BENCH_SPARSE=1` keeps the fine
/// slices out of the grid ([`RiskMapConfig::sparse_fine`]).
fn map_cfg() -> RiskMapConfig {
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let mut c = RiskMapConfig::default().bounds([-750.0, -750.0], [750.0, 750.0]);
    if let Some(cell) = env("JINK_BENCH_CELL_M") {
        c = c.cell_m(cell);
    }
    if let Some(n) = env("JINK_BENCH_PARTICLES") {
        c = c.particles(n as usize);
    }
    if let Ok(s) = std::env::var("JINK_BENCH_SCHEDULE") {
        let v: Vec<f64> = s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
        if let [fine_s, coarse_s, factor] = v[..] {
            c = c.resolution(fine_s, coarse_s, factor as u32);
        }
    }
    if std::env::var("JINK_BENCH_SPARSE").is_ok_and(|v| v == "1") {
        c = c.sparse_fine(true);
    }
    eprintln!("risk map: {c:?}");
    c
}

/// The predictor after 120 s, and each obstacle's next 100 s of observations.
fn scenario() -> (Predictor, Vec<Vec<Observation>>) {
    let w = 15f64.to_radians();
    let kinds = [
        Behaviour::Straight,
        Behaviour::Straight,
        Behaviour::Straight,
        Behaviour::Uniform { w },
        Behaviour::Uniform { w },
        Behaviour::Uniform { w },
        Behaviour::Biased { w },
        Behaviour::Biased { w },
        Behaviour::Zigzag { w },
        Behaviour::Zigzag { w },
    ];
    let radii_ft = [
        30.0, 50.0, 80.0, 100.0, 150.0, 30.0, 60.0, 120.0, 40.0, 90.0,
    ];
    let mut p = Predictor::new(PredictorConfig::default());
    let mut futures = Vec::new();
    for i in 0..N {
        let mut g = Generator::new(kinds[i], 8.0 + i as f64, 100 + i as u64);
        g.radius_m = radii_ft[i] * 0.3048;
        // Place each obstacle so that it is on a 400 m ring at t = 120 s (true speeds).
        let hist = g.track(120.0);
        let fut = g.track(100.0);
        let a = i as f64 / N as f64 * std::f64::consts::TAU;
        let last = hist[hist.len() - 1].p_m;
        let off = [400.0 * a.cos() - last[0], 400.0 * a.sin() - last[1]];
        let place = |mut o: Observation| {
            o.p_m = [o.p_m[0] + off[0], o.p_m[1] + off[1]];
            o
        };
        for o in hist {
            p.observe(&i.to_string(), place(o));
        }
        let fut: Vec<Observation> = fut.into_iter().skip(1).map(place).collect();
        futures.push(fut);
    }
    (p, futures)
}

fn bench(c: &mut Criterion) {
    let (base, futures) = scenario();
    let cfg = map_cfg();
    let mut g = c.benchmark_group("risk_map");
    {
        let mut p = base.clone();
        let m = p.risk_map(&cfg, &[], 120.0).clone();
        eprintln!("map heap: {} bytes", m.heap_bytes());
        for s in base.obstacles() {
            eprintln!(
                "obstacle {}: stage {:?}, speed {:.1} m/s, radius {:.1} m, {} cells over the horizon",
                s.id,
                s.stage,
                s.estimates.speed_mps,
                s.last_observation.radius_m,
                m.obstacle_cells(&s.id).unwrap_or(0)
            );
        }
    }

    // Full rebuild: every obstacle redone (the anchor time alternates so the cache cannot
    // be reused; the grid's allocation is).
    {
        let mut p = base.clone();
        p.risk_map(&cfg, &[], 120.0);
        let mut flip = false;
        g.bench_function("full_rebuild_10_obstacles_60s", |b| {
            b.iter(|| {
                flip = !flip;
                let t0 = if flip { 120.05 } else { 120.0 };
                black_box(p.risk_map(&cfg, &[], t0).t0_s());
            })
        });
    }

    // Incremental: one new observation of one obstacle (round-robin), then the map update.
    // The map is re-anchored (untimed) after every 10 rounds (1 s of telemetry), as a
    // server would, so that the particle part of the horizon never shrinks.
    {
        g.bench_function("incremental_update_one_observation", |b| {
            b.iter_custom(|iters| {
                let mut p = base.clone();
                let mut t0 = 120.0;
                p.risk_map(&cfg, &[], t0);
                let mut total = Duration::ZERO;
                let mut step = 0usize;
                for _ in 0..iters {
                    let (round, id) = (step / N, step % N);
                    if round >= futures[0].len() {
                        p = base.clone();
                        t0 = 120.0;
                        p.risk_map(&cfg, &[], t0);
                        step = 0;
                        continue;
                    }
                    if id == 0 && round > 0 && round % 10 == 0 {
                        t0 = futures[0][round - 1].t_s;
                        p.risk_map(&cfg, &[], t0);
                    }
                    let o = futures[id][round];
                    let start = Instant::now();
                    p.observe(&id.to_string(), o);
                    black_box(p.risk_map(&cfg, &[], t0).t0_s());
                    total += start.elapsed();
                    step += 1;
                }
                total
            })
        });
    }

    // Queries: planner-like (points along sampled paths, time advancing at 15 m/s) and
    // uniformly scattered over the grid and horizon.
    {
        let mut p = base.clone();
        let map = p.risk_map(&cfg, &[], 120.0).clone();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut path_pts = Vec::with_capacity(1 << 16);
        while path_pts.len() < 1 << 16 {
            let a = [
                rng.random_range(-700.0..700.0),
                rng.random_range(-700.0..700.0),
            ];
            let h: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let t = rng.random_range(120.0..170.0);
            for i in 0..64 {
                let d = f64::from(i) * 1.5;
                path_pts.push(([a[0] + d * h.cos(), a[1] + d * h.sin()], t + d / 15.0));
            }
        }
        let scattered: Vec<([f64; 2], f64)> = (0..1 << 16)
            .map(|_| {
                (
                    [
                        rng.random_range(-750.0..750.0),
                        rng.random_range(-750.0..750.0),
                    ],
                    rng.random_range(120.0..180.0),
                )
            })
            .collect();
        g.throughput(Throughput::Elements(1 << 16));
        let total_risk = |queries: &[([f64; 2], f64)]| -> f64 {
            queries.iter().map(|&(q, t)| map.risk(q, t)).sum()
        };
        g.bench_function("risk_queries_path_like", |b| {
            b.iter(|| black_box(total_risk(&path_pts)))
        });
        g.bench_function("risk_queries_scattered", |b| {
            b.iter(|| black_box(total_risk(&scattered)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
