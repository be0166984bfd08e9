//! `jink reactive --scans FILE`: replay a recorded LiDAR scan file through the onboard
//! reactive loop (Offset Algorithm -> Pilot, `planner::reactive::replay`) and print one line
//! per cycle and a summary.
//!
//! The file is JSON lines, one sweep per line:
//! `{"t_s": 0.05, "goal_distance_m": 60, "scan": [{"angle_deg": -60, "distance_m": 12.5}, {"angle_deg": -59, "distance_m": null}]}`
//! (`null` = no return; blank lines and `#` comments are skipped). An example is
//! `planner/tests/data/reactive_scans.jsonl`.

use std::io::{BufReader, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use planner::reactive::{LoopParams, ReplaySummary, replay};

/// Flags of `jink reactive`.
#[derive(Debug, Args)]
pub struct ReactiveArgs {
    /// The recorded scan file (JSON lines; `-` reads stdin).
    #[arg(long)]
    pub scans: PathBuf,

    /// Scan radii in metres, comma-separated (default 0.5,1,2,3,5,15,20).
    #[arg(long, value_delimiter = ',')]
    pub radii_m: Option<Vec<f64>>,

    /// Aggregate-score threshold T (default 5.0).
    #[arg(long)]
    pub threshold: Option<f64>,

    /// Window size N in beams (default 4).
    #[arg(long)]
    pub window: Option<usize>,

    /// Field of view in degrees (default 120).
    #[arg(long)]
    pub fov_deg: Option<f64>,

    /// Goal distance in metres for sweeps that carry none (default 50).
    #[arg(long)]
    pub goal_distance_m: Option<f64>,

    /// The pilot's scan range in metres (default: the largest scan radius).
    #[arg(long)]
    pub scan_range_m: Option<f64>,

    /// Print each cycle as a JSON object (decision, pilot plan, sampled points) instead of a
    /// text line; the summary is then the last line, also JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs the replay; exit code 1 with a message naming the line on bad input, 2 when the
/// file cannot be opened.
pub fn run(args: ReactiveArgs) -> ExitCode {
    let mut params = LoopParams::default();
    if let Some(r) = args.radii_m {
        params.offset.scan_radii_m = r;
    }
    if let Some(t) = args.threshold {
        params.offset.threshold = t;
    }
    if let Some(w) = args.window {
        params.offset.window = w;
    }
    if let Some(f) = args.fov_deg {
        params.offset.fov_deg = f;
    }
    if let Some(g) = args.goal_distance_m {
        params.goal_distance_m = g;
    }
    params.scan_range_m = args.scan_range_m;

    let result = if args.scans.as_os_str() == "-" {
        replay(std::io::stdin().lock(), &params)
    } else {
        match std::fs::File::open(&args.scans) {
            Ok(f) => replay(BufReader::new(f), &params),
            Err(e) => {
                eprintln!("jink reactive: cannot open {}: {e}", args.scans.display());
                return ExitCode::from(2);
            }
        }
    };
    let cycles = match result {
        Ok(c) => c,
        Err(e) => {
            eprintln!("jink reactive: {}: {e}", args.scans.display());
            return ExitCode::FAILURE;
        }
    };
    let summary = ReplaySummary::of(&cycles);
    let mut out = std::io::stdout().lock();
    let written = (|| -> std::io::Result<()> {
        for c in &cycles {
            if args.json {
                writeln!(
                    out,
                    "{}",
                    serde_json::to_string(c).map_err(std::io::Error::other)?
                )?;
            } else {
                writeln!(out, "{c}")?;
            }
        }
        if args.json {
            writeln!(out, "{}", serde_json::json!({ "summary": summary }))?;
        } else {
            writeln!(out, "summary: {summary}")?;
        }
        out.flush()
    })();
    match written {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("jink reactive: {e}");
            ExitCode::FAILURE
        }
    }
}
