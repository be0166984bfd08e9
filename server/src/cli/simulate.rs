//! `jink simulate`: closed-loop simulation of the avoidance strategies against moving
//! obstacles, scored the way the competition judges did (`sim` crate).
//!
//! Runs every chosen `(family, seed)` scenario with every chosen strategy on all cores,
//! shows a progress bar, prints the Markdown summary, and writes `report.json`,
//! `summary.md` and, for `--plot` seeds, one SVG per family, seed and strategy into `--out`.
//! `--mission FILE` flies a real mission (native, interop 2017/2018 or 2019+ JSON, parsed as
//! `POST /api/v1/missions` does, converted to the mission's ENU frame) with generated moving
//! spheres instead of generated missions.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use sim::scenario::{Family, Scenario, generate, with_moving_spheres};
use sim::strategy::StrategyKind;
use sim::suite::{SuiteConfig, run_suite_on};

/// The seeds to plot: `--plot`'s, none with `--no-plot`, else the first seed (a picture of
/// one run is what a person looks at first).
fn plot_seeds(args: &SimulateArgs) -> Vec<u64> {
    if args.no_plot {
        Vec::new()
    } else if args.plot.is_empty() {
        vec![args.first_seed]
    } else {
        args.plot.clone()
    }
}

/// Flags of `jink simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Scenario families, comma-separated: mixed, straight, random, biased, patterned,
    /// spline, static.
    #[arg(long, value_delimiter = ',', default_value = "mixed")]
    pub family: Vec<String>,

    /// Seeds per family (seeds `first_seed .. first_seed + N`).
    #[arg(long, default_value_t = 200)]
    pub seeds: u64,

    /// First seed.
    #[arg(long, default_value_t = 0)]
    pub first_seed: u64,

    /// Strategies, comma-separated (default: all but `server`): none, insertion, tangent, cv,
    /// mc-nofly, mc-random, mc-advanced, mc-memory, mc-auto, offset, sectors, oracle, and
    /// `server` (`mc-auto` asked of an in-process `jink serve` over HTTP), `server-bare`
    /// (the same client sending no speed and no aircraft parameters) and `server-mission`
    /// (the same client keeping no revision: no `base_revision`, `current_index` the next
    /// mission waypoint's index).
    #[arg(long, value_delimiter = ',')]
    pub strategies: Option<Vec<String>>,

    /// Output directory (created).
    #[arg(long, default_value = "sim-out")]
    pub out: PathBuf,

    /// Seeds to plot as SVG (one file per family, seed and strategy). Default: the first
    /// seed.
    #[arg(long, num_args = 1..)]
    pub plot: Vec<u64>,

    /// Write no SVG plot at all.
    #[arg(long, conflicts_with = "plot")]
    pub no_plot: bool,

    /// Fly this mission file (native or interop JSON) with generated moving spheres.
    #[arg(long)]
    pub mission: Option<PathBuf>,

    /// Moving spheres generated for `--mission` (at most 10).
    #[arg(long, default_value_t = 6)]
    pub spheres: usize,

    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,

    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,

    /// Speed of the simulated aircraft, m/s (constant; its turn radius follows from
    /// `--max-bank-deg`: 58 m at the defaults).
    #[arg(long, default_value_t = 20.0)]
    pub aircraft_speed: f64,

    /// Largest bank of the simulated aircraft, degrees.
    #[arg(long, default_value_t = 35.0)]
    pub max_bank_deg: f64,

    /// Waypoint acceptance radius of the simulated aircraft's autopilot, metres (it goes on
    /// to the next item within this distance, or on passing the item). ArduPlane's
    /// `WP_RADIUS` defaults to 90.
    #[arg(long, default_value_t = 10.0)]
    pub acceptance_radius: f64,

    /// L1 period of the simulated aircraft's path following, seconds (ArduPlane's
    /// `NAVL1_PERIOD`; longer is gentler and slower to converge onto a leg).
    #[arg(long, default_value_t = 17.0)]
    pub l1_period: f64,

    /// Standard deviation of the noise on the aircraft's heading as the strategies see it
    /// (its telemetry), degrees; the flown aircraft and the scoring keep the true state.
    #[arg(long, default_value_t = 0.0)]
    pub own_heading_noise_deg: f64,

    /// Standard deviation of the noise on each horizontal coordinate of the aircraft's
    /// position as the strategies see it, metres.
    #[arg(long, default_value_t = 0.0)]
    pub own_position_noise_m: f64,

    /// Obstacle telemetry received before the aircraft starts, seconds: the spheres are
    /// watched this long before take-off, as a ground station polling the judges' server
    /// before the flight would (0 = first seen at take-off, the hardest case). The flight
    /// from take-off on is the same scenario whatever the lead-in.
    #[arg(long, default_value_t = 0.0)]
    pub lead_in_s: f64,

    /// Obstacle telemetry samples per second (the judges' server answers each poll with
    /// every sphere's exact position; a team polls it at 5 Hz or so).
    #[arg(long, default_value_t = 2.0)]
    pub obstacle_rate_hz: f64,

    /// Standard deviation of the noise on each coordinate of an obstacle sample, metres
    /// (the judges' server sends exact positions: 0).
    #[arg(long, default_value_t = 1.0)]
    pub obstacle_noise_m: f64,

    /// Probability that an obstacle sample is lost.
    #[arg(long, default_value_t = 0.05)]
    pub obstacle_dropout: f64,

    /// Also write the prediction report (stages vs constant velocity per behaviour) over
    /// this many seeds per behaviour (0 = skip), on the obstacle feed above.
    #[arg(long, default_value_t = 0)]
    pub prediction_seeds: u64,
}

/// Loads a mission file into the simulator's ENU mission (origin at home, or at the first
/// fly-zone vertex; the aircraft starts at home at the first waypoint's altitude).
///
/// # Errors
/// A message naming the problem.
pub fn load_mission(path: &Path) -> Result<(sim::mission::Mission, [f64; 3]), String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let m = wire::domain::read_mission_text(&text, "simulate")
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let start = m
        .home_start()
        .ok_or_else(|| format!("{}: the mission has no waypoints to fly", path.display()))?;
    Ok((m.to_planner(), start))
}

/// Runs the subcommand.
pub fn run(args: SimulateArgs) -> ExitCode {
    let mut families = Vec::new();
    for f in &args.family {
        match Family::parse(f) {
            Some(f) => families.push(f),
            None => {
                eprintln!("jink simulate: unknown family {f:?}");
                return ExitCode::FAILURE;
            }
        }
    }
    let strategies = match &args.strategies {
        None => StrategyKind::ALL.to_vec(),
        Some(names) => {
            let mut out = Vec::new();
            for n in names {
                match StrategyKind::parse(n) {
                    Some(k) => out.push(k),
                    None => {
                        eprintln!("jink simulate: unknown strategy {n:?}");
                        return ExitCode::FAILURE;
                    }
                }
            }
            out
        }
    };
    let mission = match args.mission.as_deref().map(load_mission).transpose() {
        Ok(m) => m,
        Err(e) => {
            eprintln!("jink simulate: {e}");
            return ExitCode::FAILURE;
        }
    };
    // The `server` strategy flies against the real service, started here for the runs.
    let service = if strategies.iter().any(|k| {
        matches!(
            k,
            StrategyKind::Server | StrategyKind::ServerBare | StrategyKind::ServerMission
        )
    }) {
        match super::sim_service::start() {
            Ok(s) => Some(s),
            Err(e) => {
                eprintln!("jink simulate: {e}");
                return ExitCode::FAILURE;
            }
        }
    } else {
        None
    };
    if let Some(n) = args.threads {
        // the global pool can only be built once per process: fine for a CLI
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global();
    }
    // The simulated aircraft's and feed's flags: value, accepted range, unit.
    if let Err(e) = super::check_ranges(&[
        super::aircraft_speed_flag(args.aircraft_speed),
        super::max_bank_flag(args.max_bank_deg),
        (
            "--acceptance-radius",
            args.acceptance_radius,
            1.0,
            500.0,
            "m",
        ),
        ("--l1-period", args.l1_period, 5.0, 60.0, "s"),
        (
            "--own-heading-noise-deg",
            args.own_heading_noise_deg,
            0.0,
            30.0,
            "degrees",
        ),
        (
            "--own-position-noise-m",
            args.own_position_noise_m,
            0.0,
            50.0,
            "m",
        ),
        ("--lead-in-s", args.lead_in_s, 0.0, 3600.0, "s"),
        ("--obstacle-rate-hz", args.obstacle_rate_hz, 0.2, 50.0, "Hz"),
        ("--obstacle-noise-m", args.obstacle_noise_m, 0.0, 50.0, "m"),
        (
            "--obstacle-dropout",
            args.obstacle_dropout,
            0.0,
            0.9,
            "(a probability)",
        ),
    ]) {
        eprintln!("jink simulate: {e}");
        return ExitCode::FAILURE;
    }
    let mut cfg = SuiteConfig {
        families,
        seeds: (args.first_seed..args.first_seed + args.seeds).collect(),
        strategies,
        plot_seeds: plot_seeds(&args),
        ..SuiteConfig::default()
    };
    cfg.run.aircraft = cfg
        .run
        .aircraft
        .speed_mps(args.aircraft_speed)
        .max_bank_deg(args.max_bank_deg)
        .acceptance_radius_m(args.acceptance_radius)
        .l1_period_s(args.l1_period);
    cfg.scenario.aircraft_speed_mps = args.aircraft_speed;
    cfg.run.own_noise = sim::run::OwnNoise {
        heading_deg: args.own_heading_noise_deg,
        position_m: args.own_position_noise_m,
    };
    cfg.run.telemetry = obstacle_feed(&args);
    let cfg = cfg;
    let make = |family: Family, seed: u64| -> Scenario {
        match &mission {
            Some((m, start_m)) => with_moving_spheres(
                m.clone(),
                *start_m,
                family,
                seed,
                args.spheres,
                cfg.run.aircraft.speed_mps,
            ),
            None => generate(family, seed, &cfg.scenario),
        }
    };
    let total = cfg.families.len() * cfg.seeds.len() * cfg.strategies.len();
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} runs, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let report = run_suite_on(&cfg, &|done, _| bar.set_position(done as u64), make);
    bar.finish_and_clear();
    let table = sim::report::markdown_table(&report);
    println!("{table}");
    println!(
        "{} runs in {:.1} s on {} threads",
        report.runs.len(),
        report.wall_s,
        report.threads
    );
    if let Some(s) = &service {
        println!(
            "  server: every run flew against the service at {} over HTTP; {} requests failed",
            s.base(),
            s.failures()
        );
    }
    for k in &cfg.strategies {
        if let Some(tp) = report.throughput(*k) {
            println!(
                "  {:12} {:8.1} simulated mission-minutes per wall-second per core",
                k.name(),
                tp
            );
        }
    }
    if let Err(e) = write_outputs(&args.out, &report, &table, &make) {
        eprintln!("jink simulate: {e}");
        return ExitCode::from(2);
    }
    if args.prediction_seeds > 0 {
        let params = prediction_params(&args);
        let rows = sim::prediction::prediction_report(&sim::behaviour::BehaviourKind::ALL, &params);
        let md = sim::prediction::prediction_markdown(&rows);
        println!("\nPrediction (NLL in nats, 95% region coverage):\n{md}");
        let json = serde_json::to_string_pretty(&rows).unwrap_or_default();
        let res = std::fs::write(args.out.join("prediction.md"), &md)
            .and_then(|()| std::fs::write(args.out.join("prediction.json"), json));
        if let Err(e) = res {
            eprintln!("jink simulate: cannot write the prediction report: {e}");
            return ExitCode::from(2);
        }
    }
    println!("wrote {}", args.out.display());
    if service.as_ref().is_some_and(|s| s.failures() > 0) {
        eprintln!(
            "jink simulate: requests to the service failed (above): the `server` rows are not the service's own flights"
        );
        return ExitCode::from(3);
    }
    ExitCode::SUCCESS
}

fn write_outputs(
    out: &Path,
    report: &sim::suite::SuiteReport,
    table: &str,
    make: &dyn Fn(Family, u64) -> Scenario,
) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let json = sim::report::json(report).map_err(|e| e.to_string())?;
    let write = |name: &str, body: &str| {
        let p = out.join(name);
        std::fs::write(&p, body).map_err(|e| format!("cannot write {}: {e}", p.display()))
    };
    write("report.json", &json)?;
    write("summary.md", table)?;
    for (family, r) in &report.runs {
        if r.track.is_empty() {
            continue;
        }
        let s = make(*family, r.seed);
        let svg = sim::svg::plot_run(&s, r);
        write(
            &format!("{}_{}_{}.svg", family.name(), r.seed, r.strategy.name()),
            &svg,
        )?;
    }
    Ok(())
}

/// The obstacles' telemetry as the flights receive it.
fn obstacle_feed(args: &SimulateArgs) -> sim::telemetry::TelemetryParams {
    sim::telemetry::TelemetryParams {
        rate_hz: args.obstacle_rate_hz,
        noise_sigma_m: args.obstacle_noise_m,
        dropout_prob: args.obstacle_dropout,
        lead_in_s: args.lead_in_s,
    }
}

/// The prediction report's parameters: the flights' obstacle feed, without a lead-in (the
/// report scores tracks from their start).
fn prediction_params(args: &SimulateArgs) -> sim::prediction::PredictionParams {
    sim::prediction::PredictionParams {
        seeds: args.prediction_seeds,
        telemetry: sim::telemetry::TelemetryParams {
            lead_in_s: 0.0,
            ..obstacle_feed(args)
        },
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim::geometry::point_in_polygon;
    use sim::mission::{altitude_band_m, bounds_m, fly_zone};

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        args: SimulateArgs,
    }

    /// `jink simulate`'s arguments from `argv`.
    fn parse(argv: &[&str]) -> Result<SimulateArgs, clap::Error> {
        use clap::Parser;
        Cli::try_parse_from(std::iter::once("simulate").chain(argv.iter().copied())).map(|c| c.args)
    }

    #[test]
    fn the_first_seed_is_plotted_unless_told_otherwise() {
        let seeds = |argv: &[&str]| plot_seeds(&parse(argv).unwrap());
        assert_eq!(seeds(&["--first-seed", "5"]), vec![5]);
        assert_eq!(seeds(&["--plot", "7", "9"]), vec![7, 9]);
        assert!(seeds(&["--no-plot"]).is_empty());
        assert!(parse(&["--no-plot", "--plot", "3"]).is_err());
    }

    #[test]
    fn the_prediction_report_is_scored_on_the_flights_obstacle_feed() {
        let judges = parse(&[
            "--lead-in-s",
            "900",
            "--obstacle-noise-m",
            "0.3",
            "--obstacle-rate-hz",
            "10",
            "--obstacle-dropout",
            "0.1",
            "--prediction-seeds",
            "3",
        ])
        .unwrap();
        let p = prediction_params(&judges);
        assert_eq!(p.seeds, 3);
        assert_eq!(
            (
                p.telemetry.rate_hz,
                p.telemetry.noise_sigma_m,
                p.telemetry.dropout_prob
            ),
            (10.0, 0.3, 0.1)
        );
        // The flights keep their lead-in; the report scores tracks from their start.
        assert_eq!(obstacle_feed(&judges).lead_in_s, 900.0);
        assert_eq!(p.telemetry.lead_in_s, 0.0);
        // By default, the simulator's default feed.
        let p = prediction_params(&parse(&[]).unwrap());
        assert_eq!(p.telemetry, sim::telemetry::TelemetryParams::default());
    }

    #[test]
    fn the_webster_field_fixture_loads_into_the_simulators_enu_mission() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/fixtures/interop/mission_2021_webster_field.json");
        let (m, _start) = load_mission(&path).unwrap();
        assert_eq!(m.waypoints.len(), 14);
        assert_eq!(m.cylinders.len(), 6);
        assert_eq!(fly_zone(&m).len(), 12);
        // 100-750 ft band, waypoint altitudes 200-400 ft
        let (lo_m, hi_m) = altitude_band_m(&m);
        assert!((lo_m - 30.48).abs() < 1e-9 && (hi_m - 228.6).abs() < 1e-9);
        assert!(
            m.waypoints
                .iter()
                .all(|w| w.alt_m >= 60.9 && w.alt_m <= 121.93)
        );
        // every waypoint inside the zone, the field about 1.2 km across
        assert!(
            m.waypoints
                .iter()
                .all(|w| point_in_polygon(w.p_m, fly_zone(&m)))
        );
        let (lo, hi) = bounds_m(&m);
        assert!(
            hi[0] - lo[0] > 800.0 && hi[0] - lo[0] < 2000.0,
            "{lo:?} {hi:?}"
        );
    }

    #[test]
    fn a_missing_mission_file_is_a_clear_error() {
        let e = load_mission(Path::new("/nonexistent/mission.json")).unwrap_err();
        assert!(e.contains("cannot read"), "{e}");
    }
}
