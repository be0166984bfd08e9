//! Runs many scenarios with many strategies in parallel (rayon, all cores) and summarises
//! them per family and strategy.
//!
//! Each `(family, seed)` scenario and its telemetry are drawn once and flown by every
//! strategy, so strategies are compared on identical obstacles and identical telemetry.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::run::{RunConfig, RunResult, percentile, run_with_streams};
use crate::scenario::{Family, Scenario, ScenarioParams, generate};
use crate::strategy::StrategyKind;
use crate::telemetry::sample_streams;

/// What to run. Defaults: family `mixed`, seeds 0..200, every strategy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SuiteConfig {
    /// Scenario families.
    pub families: Vec<Family>,
    /// Seeds (each family uses every seed).
    pub seeds: Vec<u64>,
    /// Strategies.
    pub strategies: Vec<StrategyKind>,
    /// Scenario generation.
    pub scenario: ScenarioParams,
    /// Run parameters (`record_track` is only honoured for `plot_seeds`).
    pub run: RunConfig,
    /// Seeds whose tracks are kept for plotting.
    pub plot_seeds: Vec<u64>,
}

impl Default for SuiteConfig {
    fn default() -> Self {
        Self {
            families: vec![Family::Mixed],
            seeds: (0..200).collect(),
            strategies: StrategyKind::ALL.to_vec(),
            scenario: ScenarioParams::default(),
            run: RunConfig::default(),
            plot_seeds: vec![],
        }
    }
}

/// One family-and-strategy line of the summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    /// Family.
    pub family: Family,
    /// Strategy.
    pub strategy: StrategyKind,
    /// Runs.
    pub runs: usize,
    /// Mean judges' sphere score.
    pub sphere_score: f64,
    /// Mean judges' cylinder score.
    pub cylinder_score: f64,
    /// Fraction of runs without any hit.
    pub clean_runs: f64,
    /// Spheres hit over all runs / spheres over all runs.
    pub sphere_hit_rate: f64,
    /// Cylinders hit over all runs / cylinders over all runs.
    pub cylinder_hit_rate: f64,
    /// Waypoints captured / waypoints.
    pub waypoint_rate: f64,
    /// The interop server's in-order waypoint score over all runs / waypoints
    /// ([`crate::run::RunMetrics::waypoint_score`]).
    #[serde(default)]
    pub waypoint_score_rate: f64,
    /// Fraction of runs finishing the stack in time.
    pub completed: f64,
    /// Mean path-length ratio.
    pub path_ratio: f64,
    /// Median path-length ratio (the target is on the median).
    #[serde(default)]
    pub path_ratio_p50: f64,
    /// Median of the runs' minimum clearance, metres.
    pub min_clearance_p50_m: f64,
    /// Mean avoid waypoints reached.
    pub waypoints_added: f64,
    /// Mean distinct avoid waypoints flown toward.
    pub avoid_targets: f64,
    /// Mean route added by replans a run, metres ([`crate::run::RunMetrics::route_added_m`]).
    #[serde(default)]
    pub route_added_m: f64,
    /// Mean route removed by replans a run, metres.
    #[serde(default)]
    pub route_removed_m: f64,
    /// Mean seconds outside the fly zone.
    pub boundary_violation_s: f64,
    /// Median strategy latency over all calls, ms.
    pub replan_p50_ms: f64,
    /// 95th percentile, ms.
    pub replan_p95_ms: f64,
    /// Maximum, ms.
    pub replan_max_ms: f64,
    /// 95th percentile of the strategy's CPU time over all calls (the work itself,
    /// [`crate::cpu::thread_cpu_ms`]), ms.
    #[serde(default)]
    pub replan_cpu_p95_ms: f64,
    /// Maximum, the same way, ms.
    #[serde(default)]
    pub replan_cpu_max_ms: f64,
    /// Median live-state update before a replan (feeding the predictor, building the live
    /// map: the server's work per telemetry batch, not per plan), ms.
    #[serde(default)]
    pub live_p50_ms: f64,
    /// 95th percentile, ms.
    #[serde(default)]
    pub live_p95_ms: f64,
    /// Simulated mission seconds.
    pub sim_s: f64,
    /// Wall seconds spent in these runs (summed over threads).
    pub cpu_s: f64,
}

/// A finished suite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SuiteReport {
    /// What was run.
    pub config: SuiteConfig,
    /// Per family and strategy.
    pub summary: Vec<SummaryRow>,
    /// Every run (tracks only for plot seeds).
    pub runs: Vec<(Family, RunResult)>,
    /// Wall-clock seconds of the whole suite.
    pub wall_s: f64,
    /// Worker threads.
    pub threads: usize,
}

/// Runs the suite; `progress(done, total)` is called after each run (from worker threads).
pub fn run_suite(cfg: &SuiteConfig, progress: &(dyn Fn(usize, usize) + Sync)) -> SuiteReport {
    run_suite_on(cfg, progress, |family, seed| {
        generate(family, seed, &cfg.scenario)
    })
}

/// As [`run_suite`] with a custom scenario source (e.g. a real mission with generated
/// moving obstacles).
pub fn run_suite_on(
    cfg: &SuiteConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
    make: impl Fn(Family, u64) -> Scenario + Sync,
) -> SuiteReport {
    let start = Instant::now();
    let jobs: Vec<(Family, u64)> = cfg
        .families
        .iter()
        .flat_map(|f| cfg.seeds.iter().map(move |s| (*f, *s)))
        .collect();
    let total = jobs.len() * cfg.strategies.len();
    let done = AtomicUsize::new(0);
    let per_job: Vec<Vec<(Family, RunResult, f64)>> = jobs
        .par_iter()
        .map(|&(family, seed)| {
            let scenario = make(family, seed);
            let streams = sample_streams(&scenario, &cfg.run.telemetry);
            let mut rc = cfg.run.clone();
            rc.record_track = cfg.plot_seeds.contains(&seed);
            cfg.strategies
                .iter()
                .map(|&k| {
                    let t0 = Instant::now();
                    let r = run_with_streams(&scenario, &streams, k, &rc);
                    let cpu = t0.elapsed().as_secs_f64();
                    progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
                    (family, r, cpu)
                })
                .collect()
        })
        .collect();
    let flat: Vec<(Family, RunResult, f64)> = per_job.into_iter().flatten().collect();
    let mut summary = Vec::new();
    for &family in &cfg.families {
        for &strategy in &cfg.strategies {
            let rs: Vec<&(Family, RunResult, f64)> = flat
                .iter()
                .filter(|(f, r, _)| *f == family && r.strategy == strategy)
                .collect();
            if !rs.is_empty() {
                summary.push(summarise(family, strategy, &rs));
            }
        }
    }
    SuiteReport {
        config: cfg.clone(),
        summary,
        runs: flat.into_iter().map(|(f, r, _)| (f, r)).collect(),
        wall_s: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
    }
}

fn summarise(
    family: Family,
    strategy: StrategyKind,
    rs: &[&(Family, RunResult, f64)],
) -> SummaryRow {
    let n = rs.len() as f64;
    let mean = |f: &dyn Fn(&RunResult) -> f64| rs.iter().map(|(_, r, _)| f(r)).sum::<f64>() / n;
    let ratio = |num: &dyn Fn(&RunResult) -> usize, den: &dyn Fn(&RunResult) -> usize| {
        let d: usize = rs.iter().map(|(_, r, _)| den(r)).sum();
        if d == 0 {
            0.0
        } else {
            rs.iter().map(|(_, r, _)| num(r)).sum::<usize>() as f64 / d as f64
        }
    };
    let lat: Vec<f64> = rs
        .iter()
        .flat_map(|(_, r, _)| r.latencies_ms.iter().copied())
        .collect();
    let live: Vec<f64> = rs
        .iter()
        .flat_map(|(_, r, _)| r.live_ms.iter().copied())
        .collect();
    let cpu: Vec<f64> = rs
        .iter()
        .flat_map(|(_, r, _)| r.cpu_ms.iter().copied())
        .collect();
    let clear: Vec<f64> = rs
        .iter()
        .map(|(_, r, _)| r.metrics.min_clearance_m)
        .collect();
    SummaryRow {
        family,
        strategy,
        runs: rs.len(),
        sphere_score: mean(&|r| r.metrics.sphere_score),
        cylinder_score: mean(&|r| r.metrics.cylinder_score),
        clean_runs: mean(&|r| {
            f64::from(u8::from(
                r.metrics.spheres_hit + r.metrics.cylinders_hit == 0,
            ))
        }),
        sphere_hit_rate: ratio(&|r| r.metrics.spheres_hit, &|r| r.metrics.spheres),
        cylinder_hit_rate: ratio(&|r| r.metrics.cylinders_hit, &|r| r.metrics.cylinders),
        waypoint_rate: ratio(&|r| r.metrics.waypoints_captured, &|r| r.metrics.waypoints),
        waypoint_score_rate: {
            let waypoints: usize = rs.iter().map(|(_, r, _)| r.metrics.waypoints).sum();
            let score: f64 = rs.iter().map(|(_, r, _)| r.metrics.waypoint_score).sum();
            if waypoints == 0 {
                0.0
            } else {
                score / waypoints as f64
            }
        },
        completed: mean(&|r| f64::from(u8::from(r.metrics.completed))),
        path_ratio: mean(&|r| r.metrics.path_ratio),
        path_ratio_p50: percentile(
            &rs.iter()
                .map(|(_, r, _)| r.metrics.path_ratio)
                .collect::<Vec<_>>(),
            0.5,
        ),
        min_clearance_p50_m: percentile(&clear, 0.5),
        waypoints_added: mean(&|r| r.metrics.waypoints_added as f64),
        avoid_targets: mean(&|r| r.metrics.avoid_targets as f64),
        route_added_m: mean(&|r| r.metrics.route_added_m),
        route_removed_m: mean(&|r| r.metrics.route_removed_m),
        boundary_violation_s: mean(&|r| r.metrics.boundary_violation_s),
        replan_p50_ms: percentile(&lat, 0.5),
        replan_p95_ms: percentile(&lat, 0.95),
        replan_max_ms: lat.iter().copied().fold(0.0, f64::max),
        replan_cpu_p95_ms: percentile(&cpu, 0.95),
        replan_cpu_max_ms: cpu.iter().copied().fold(0.0, f64::max),
        live_p50_ms: percentile(&live, 0.5),
        live_p95_ms: percentile(&live, 0.95),
        sim_s: rs.iter().map(|(_, r, _)| r.metrics.mission_time_s).sum(),
        cpu_s: rs.iter().map(|(_, _, c)| c).sum(),
    }
}

impl SuiteReport {
    /// Simulated mission-minutes per wall-second per core for one strategy (over its runs).
    pub fn throughput(&self, strategy: StrategyKind) -> Option<f64> {
        let rows: Vec<&SummaryRow> = self
            .summary
            .iter()
            .filter(|r| r.strategy == strategy)
            .collect();
        let sim: f64 = rows.iter().map(|r| r.sim_s).sum();
        let cpu: f64 = rows.iter().map(|r| r.cpu_s).sum();
        (cpu > 0.0).then(|| sim / 60.0 / cpu)
    }
}
