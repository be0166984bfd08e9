//! `jink compare BEFORE AFTER`: two builds' `jink simulate` reports paired by seed
//! (`sim::compare`).
//!
//! Each side is a `report.json` or a directory whose `report.json` files (at any depth) are
//! merged. Prints the Markdown table (or `--json`) on stdout; warns on stderr about runs on
//! one side only and about configuration fields that change the flights and differ
//! between the sides. Exit code 2 when a side cannot be read or nothing pairs.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use sim::compare::{
    Comparison, DEFAULT_HIT_COST_S, Report, compare_strategies, config_differences_within,
    load_side, render_json, render_markdown,
};
use sim::strategy::StrategyKind;

/// Flags of `jink compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The build before the change: a `report.json` of `jink simulate --out DIR`, or a
    /// directory whose `report.json` files (at any depth) are merged.
    pub before: PathBuf,

    /// The build after the change, the same way.
    pub after: PathBuf,

    /// Seconds a sphere or cylinder hit adds to a run's team score (its flight time plus
    /// this a hit): a hit costs a team about fifteen minutes of flight.
    #[arg(long, default_value_t = DEFAULT_HIT_COST_S)]
    pub hit_cost_s: f64,

    /// Print the comparison as JSON (for scripts) instead of Markdown.
    #[arg(long)]
    pub json: bool,

    /// Compare one strategy with another, `BEFORE,AFTER` (command-line names, e.g.
    /// `mc-auto,oracle`): BEFORE's runs of the first against AFTER's runs of the second,
    /// paired by family and seed. One report flown with both may be given as both sides.
    #[arg(long, value_delimiter = ',', value_name = "BEFORE,AFTER")]
    pub strategies: Option<Vec<String>>,
}

/// Runs the subcommand.
pub fn run(args: CompareArgs) -> ExitCode {
    match execute(&args) {
        Ok(out) => {
            print!("{out}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("jink compare: {e}");
            ExitCode::from(2)
        }
    }
}

/// The text to print, the warnings written on stderr on the way.
fn execute(args: &CompareArgs) -> Result<String, String> {
    super::check_ranges(&[("--hit-cost-s", args.hit_cost_s, 0.0, 1e6, "s")])?;
    let before = load_side(&args.before).map_err(|e| e.to_string())?;
    let after = load_side(&args.after).map_err(|e| e.to_string())?;
    for (name, side, path) in [
        ("before", &before, &args.before),
        ("after", &after, &args.after),
    ] {
        eprintln!("jink compare: {name}: {}", describe(side, path));
        for w in side_warnings(name, side) {
            eprintln!("jink compare: warning: {w}");
        }
    }
    let strategies = strategy_pair(args.strategies.as_deref())?;
    let c = compare_strategies(&before, &after, args.hit_cost_s, strategies)
        .map_err(|e| e.to_string())?;
    for w in warnings(&c) {
        eprintln!("jink compare: warning: {w}");
    }
    if args.json {
        render_json(&c)
            .map(|s| s + "\n")
            .map_err(|e| format!("cannot write the JSON: {e}"))
    } else {
        Ok(render_markdown(&c))
    }
}

/// `--strategies BEFORE,AFTER` as two strategies; `None` when not given.
fn strategy_pair(names: Option<&[String]>) -> Result<Option<(StrategyKind, StrategyKind)>, String> {
    let Some(names) = names else {
        return Ok(None);
    };
    let [b, a] = names else {
        return Err(format!(
            "--strategies takes two names, BEFORE,AFTER (e.g. mc-auto,oracle), not {}",
            names.join(",")
        ));
    };
    let parse = |n: &str| {
        StrategyKind::parse(n.trim()).ok_or_else(|| {
            format!("--strategies: no strategy is named {n:?} (see jink simulate --help)")
        })
    };
    Ok(Some((parse(b)?, parse(a)?)))
}

/// `N runs from K reports under PATH`.
fn describe(side: &[Report], path: &Path) -> String {
    let runs: usize = side.iter().map(|r| r.runs.len()).sum();
    let reports = if side.len() == 1 { "report" } else { "reports" };
    format!(
        "{runs} runs from {} {reports} ({})",
        side.len(),
        path.display()
    )
}

/// Reports of one side that were flown with a different configuration than its first.
fn side_warnings(name: &str, side: &[Report]) -> Vec<String> {
    let Some(first) = side.first() else {
        return Vec::new();
    };
    config_differences_within(side)
        .into_iter()
        .map(|(path, diffs)| {
            let fields: Vec<String> = diffs.iter().map(ToString::to_string).collect();
            format!(
                "the {name} reports were not flown alike: {} differs from {} in {}",
                path.display(),
                first.path.display(),
                fields.join(", ")
            )
        })
        .collect()
}

/// What the comparison left out or may have mixed up.
fn warnings(c: &Comparison) -> Vec<String> {
    let mut out = Vec::new();
    if c.unpaired.before + c.unpaired.after > 0 {
        out.push(format!(
            "{} runs only before and {} only after are left out (not flown by both builds)",
            c.unpaired.before, c.unpaired.after
        ));
    }
    if !c.config_differences.is_empty() {
        let fields: Vec<String> = c
            .config_differences
            .iter()
            .map(ToString::to_string)
            .collect();
        out.push(format!(
            "the two sides were flown with different settings, so the differences are not the build's alone: {}",
            fields.join(", ")
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        args: CompareArgs,
    }

    fn parse(argv: &[&str]) -> Result<CompareArgs, clap::Error> {
        use clap::Parser;
        Cli::try_parse_from(std::iter::once("compare").chain(argv.iter().copied())).map(|c| c.args)
    }

    #[test]
    fn a_hit_costs_fifteen_minutes_unless_told_otherwise() {
        let a = parse(&["a", "b"]).unwrap();
        assert_eq!(a.hit_cost_s, 900.0);
        assert!(!a.json);
        let a = parse(&["a", "b", "--hit-cost-s", "600", "--json"]).unwrap();
        assert_eq!((a.hit_cost_s, a.json), (600.0, true));
        assert!(parse(&["a"]).is_err());
    }

    #[test]
    fn strategies_are_two_known_names() {
        let a = parse(&["a", "b", "--strategies", "mc-auto,oracle"]).unwrap();
        assert_eq!(
            strategy_pair(a.strategies.as_deref()).unwrap(),
            Some((
                StrategyKind::parse("mc-auto").unwrap(),
                StrategyKind::Oracle
            ))
        );
        assert_eq!(strategy_pair(None).unwrap(), None);
        for bad in ["mc-auto", "mc-auto,oracle,none"] {
            let a = parse(&["a", "b", "--strategies", bad]).unwrap();
            let e = strategy_pair(a.strategies.as_deref()).unwrap_err();
            assert!(e.contains("two names"), "{e}");
        }
        let a = parse(&["a", "b", "--strategies", "mc-auto,orakel"]).unwrap();
        let e = strategy_pair(a.strategies.as_deref()).unwrap_err();
        assert!(e.contains("\"orakel\""), "{e}");
    }

    #[test]
    fn a_negative_hit_cost_is_refused() {
        let a = parse(&["a", "b", "--hit-cost-s=-1"]).unwrap();
        let e = execute(&a).unwrap_err();
        assert!(e.contains("--hit-cost-s"), "{e}");
    }
}
