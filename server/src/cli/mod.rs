//! The `jink` command line: `serve` and the offline subcommands.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod arenas;
pub mod compare;
pub mod demo;
pub mod interop;
pub mod openapi;
pub mod plan;
pub mod reactive;
pub mod serve;
pub mod sim_service;
pub mod simulate;
pub mod token;

/// jink: ground-station planning service for fixed-wing UAVs on SUAS-style missions.
#[derive(Debug, Parser)]
#[command(name = "jink", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
// Parsed once at start: the size of `serve`'s flags does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the HTTP service (SQLite file in the working directory by default).
    Serve(serve::ServeArgs),
    /// Print the OpenAPI 3.1 document (what `openapi/openapi.json` must hold).
    Openapi,
    /// Replay a recorded LiDAR scan file through the reactive avoider loop (offset -> pilot).
    Reactive(reactive::ReactiveArgs),
    /// Plan offline: print the plan JSON for a mission file and an observations file.
    Plan(plan::PlanArgs),
    /// Simulate the avoidance strategies in closed loop and score them as the judges did.
    Simulate(simulate::SimulateArgs),
    /// Start the service on a temporary SQLite database and fly a simulated aircraft
    /// against simulated moving obstacles through its API; prints the live page's URL.
    Demo(demo::DemoArgs),
    /// Create, list and revoke the bearer tokens of a database (`read`, `write`, `admin`).
    Token(token::TokenArgs),
    /// The judges' interop server: `status` (what the upstream link sees) and `pull`
    /// (fetch the mission once and store it).
    Interop(interop::InteropArgs),
    /// Compare two builds' `jink simulate` reports, runs paired by seed.
    ///
    /// One row per family and strategy: hits, waypoints, path ratio, mission time and team
    /// score (with standard errors), runs within 10 m, time out of the zone, replan CPU;
    /// then the seeds whose hits or waypoints changed.
    Compare(compare::CompareArgs),
    // jink:subcommands -- add a variant here and its arm in `run` below
}

/// Parses the command line and runs it.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Serve(args) => serve::run(args),
        Command::Openapi => openapi::run(),
        Command::Reactive(args) => reactive::run(args),
        Command::Plan(args) => plan::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Demo(args) => demo::run(args),
        Command::Token(args) => token::run(args),
        Command::Interop(args) => interop::run(args),
        Command::Compare(args) => compare::run(args),
        // jink:dispatch
    }
}

/// A flag's value, the range it must be in and its unit: `(flag, value, lo, hi, unit)`.
type FlagRange<'a> = (&'a str, f64, f64, f64, &'a str);

/// The simulated aircraft's speed flag (`--aircraft-speed`) with its accepted range, m/s.
fn aircraft_speed_flag(v: f64) -> FlagRange<'static> {
    ("--aircraft-speed", v, 5.0, 100.0, "m/s")
}

/// The simulated aircraft's bank flag (`--max-bank-deg`) with its accepted range, degrees.
fn max_bank_flag(v: f64) -> FlagRange<'static> {
    ("--max-bank-deg", v, 10.0, 70.0, "degrees")
}

/// The first flag whose value is not finite or out of its range, as
/// `"FLAG must be in [LO, HI] UNIT"`.
fn check_ranges(flags: &[FlagRange<'_>]) -> Result<(), String> {
    for &(flag, v, lo, hi, unit) in flags {
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            return Err(format!("{flag} must be in [{lo}, {hi}] {unit}"));
        }
    }
    Ok(())
}

/// Builds the async runtime `builder` describes (with I/O and timers), or says on stderr
/// why it cannot.
fn runtime(mut builder: tokio::runtime::Builder) -> Option<tokio::runtime::Runtime> {
    match builder.enable_all().build() {
        Ok(rt) => Some(rt),
        Err(e) => {
            eprintln!("jink: cannot start the async runtime: {e}");
            None
        }
    }
}
