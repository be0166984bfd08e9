//! Paired comparison of two builds' suite reports (`jink compare BEFORE AFTER`).
//!
//! The team measures a planner change by flying the same seeds with the build before and
//! the build after (`jink simulate ... --out DIR`, which writes `DIR/report.json`) and
//! comparing the runs paired by seed: the same `(family, strategy, seed)` is the same
//! scenario and the same telemetry, so the difference of a pair is the change's alone, and
//! the standard error of the mean difference is much smaller than that of two unpaired
//! means.
//!
//! - [`load_side`] reads one side: a `report.json`, or every `report.json` under a
//!   directory (a block is often split over two processes);
//! - [`compare`] pairs the runs of both sides and computes each `(family, strategy)` row,
//!   the seeds whose hits changed and those whose captured waypoints changed;
//! - [`config_differences`] names the configuration fields that change the flights and
//!   differ between two reports (comparing different aircraft speeds by mistake is the
//!   common error);
//! - [`render_markdown`] and [`render_json`] print a [`Comparison`].
//!
//! Only the fields read here are parsed ([`RunFigures`]); the rest of a report (tracks,
//! the judges' detail, the summary, fields a later build adds) is ignored.
//!
//! # Example
//! ```
//! use sim::compare::{DEFAULT_HIT_COST_S, compare, parse_report};
//! use std::path::Path;
//!
//! let run = |seed: u64, time_s: f64, spheres_hit: usize| {
//!     serde_json::json!(["mixed", { "seed": seed, "strategy": "bisection_auto", "metrics": {
//!         "spheres_hit": spheres_hit, "cylinders_hit": 0, "waypoints_captured": 5,
//!         "waypoints": 5, "mission_time_s": time_s, "path_ratio": 1.2,
//!         "min_clearance_m": 30.0, "boundary_violation_s": 0.0, "replan_cpu_p95_ms": 2.0 } }])
//! };
//! let report = |runs: Vec<serde_json::Value>| {
//!     serde_json::json!({ "config": {}, "runs": runs }).to_string()
//! };
//! let before = report(vec![run(1, 300.0, 1), run(2, 400.0, 0)]);
//! let before = parse_report(Path::new("before.json"), &before)?;
//! let after = report(vec![run(1, 310.0, 0), run(2, 410.0, 0)]);
//! let after = parse_report(Path::new("after.json"), &after)?;
//! let c = compare(&[before], &[after], DEFAULT_HIT_COST_S)?;
//! let row = &c.groups[0];
//! assert_eq!(row.mission_time_s.mean, 10.0); // 10 s a run longer...
//! assert_eq!(row.team_score_s.mean, 10.0 - 900.0 / 2.0); // ...but one hit fewer in two runs
//! assert_eq!(c.hits_changed[0].seed, 1);
//! # Ok::<(), sim::compare::CompareError>(())
//! ```

use std::cmp::Ordering;
use std::collections::BTreeMap;
use std::fmt::{self, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize, Serializer};
use serde_json::Value;

use crate::scenario::Family;
use crate::strategy::StrategyKind;

/// Seconds a sphere or cylinder hit adds to a run's team score: a hit costs a team about
/// fifteen minutes of flight.
pub const DEFAULT_HIT_COST_S: f64 = 900.0;

/// A run whose least clearance is below this passed within it of an obstacle ("runs
/// within 10 m"), metres.
pub const NEAR_CLEARANCE_M: f64 = 10.0;

/// Configuration fields (dotted paths into a report's `config`) that do not change how a
/// run flies, left out of [`config_differences`]: which families, seeds and strategies were
/// flown (the pairing deals with those) and which tracks were recorded for plots.
pub const IGNORED_CONFIG_FIELDS: [&str; 5] = [
    "families",
    "seeds",
    "strategies",
    "plot_seeds",
    "run.record_track",
];

/// Why two sides cannot be compared.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CompareError {
    /// A file or directory could not be read: check the path and its permissions.
    #[error("cannot read {}: {source}", .path.display())]
    Read {
        /// The file or directory.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// A file is not a `jink simulate` report (or lacks a field the comparison reads): give
    /// the `report.json` that `jink simulate --out DIR` wrote.
    #[error("{}: not a `jink simulate` report.json: {source}", .path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where and why parsing failed.
        source: serde_json::Error,
    },
    /// A directory holds no `report.json` at any depth: give the `--out` directory of a
    /// finished `jink simulate`, or the report itself.
    #[error("no report.json under {}", .dir.display())]
    NoReports {
        /// The directory.
        dir: PathBuf,
    },
    /// One side holds the same run twice (two reports of one side flew the same seeds):
    /// give each side's runs once, e.g. by pointing at the directories of disjoint blocks.
    #[error(
        "{side} holds the run ({}, {}, seed {}) twice: in {} and in {}",
        .key.family.name(), .key.strategy.name(), .key.seed, .first.display(), .second.display()
    )]
    DuplicateRun {
        /// The side.
        side: Side,
        /// The run.
        key: RunKey,
        /// The report it was first read from.
        first: PathBuf,
        /// The report holding it again.
        second: PathBuf,
    },
    /// No `(family, strategy, seed)` is on both sides: fly the same families, strategies
    /// and seeds with both builds.
    #[error(
        "no run is on both sides ({before} runs before, {after} after): fly the same families, strategies and seeds with both builds"
    )]
    NothingPaired {
        /// Runs before.
        before: usize,
        /// Runs after.
        after: usize,
    },
}

/// One side of a comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The build before the change.
    Before,
    /// The build after it.
    After,
}

impl fmt::Display for Side {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Before => "before",
            Self::After => "after",
        })
    }
}

/// What identifies a run across builds: the same key is the same scenario and telemetry.
///
/// Ordered by family name, strategy name, then seed (the order of the rows and lists).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunKey {
    /// Scenario family.
    pub family: Family,
    /// Strategy.
    pub strategy: StrategyKind,
    /// Scenario seed.
    pub seed: u64,
}

impl Ord for RunKey {
    fn cmp(&self, other: &Self) -> Ordering {
        (self.family.name(), self.strategy.name(), self.seed).cmp(&(
            other.family.name(),
            other.strategy.name(),
            other.seed,
        ))
    }
}

impl PartialOrd for RunKey {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The figures of one run the comparison reads: a subset of
/// [`crate::run::RunMetrics`], as `report.json` holds it.
///
/// # Units
/// Seconds, metres and milliseconds, as the field names say.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct RunFigures {
    /// Spheres hit.
    pub spheres_hit: usize,
    /// Cylinders hit.
    pub cylinders_hit: usize,
    /// Mission waypoints captured within 100 ft.
    pub waypoints_captured: usize,
    /// Mission waypoints.
    pub waypoints: usize,
    /// The interop server's in-order waypoint score ([`crate::run::RunMetrics::waypoint_score`];
    /// absent from reports older than it).
    #[serde(default)]
    pub waypoint_score: Option<f64>,
    /// Flight time, seconds.
    pub mission_time_s: f64,
    /// Flown length / straight mission legs (`null` in the report when it is not a number).
    pub path_ratio: Option<f64>,
    /// Smallest clearance to any obstacle surface, metres, negative inside (`null` when
    /// there was no obstacle to measure from).
    pub min_clearance_m: Option<f64>,
    /// Seconds outside the fly zone or its altitude band.
    pub boundary_violation_s: f64,
    /// 95th percentile of the replan CPU time, ms (absent from reports older than it).
    #[serde(default)]
    pub replan_cpu_p95_ms: Option<f64>,
}

impl RunFigures {
    /// Sphere and cylinder hits.
    pub fn hits(&self) -> usize {
        self.spheres_hit + self.cylinders_hit
    }

    /// The run's team score: its flight time plus `hit_cost_s` a hit, seconds (lower is
    /// better).
    pub fn team_score_s(&self, hit_cost_s: f64) -> f64 {
        self.mission_time_s + hit_cost_s * self.hits() as f64
    }
}

/// A run as a report holds it (what is read of it).
#[derive(Debug, Clone, PartialEq, Deserialize)]
struct RunRecord {
    seed: u64,
    strategy: StrategyKind,
    metrics: RunFigures,
}

/// A report as read (see [`crate::suite::SuiteReport`]).
#[derive(Debug, Deserialize)]
struct ReportRecord {
    config: Value,
    runs: Vec<(Family, RunRecord)>,
}

/// One `report.json`, as far as the comparison reads it.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Where it was read from.
    pub path: PathBuf,
    /// Its `config` object, kept as JSON so that a field a later build adds is compared
    /// too.
    pub config: Value,
    /// Its runs.
    pub runs: Vec<(RunKey, RunFigures)>,
}

/// Parses a report's text; `path` names it in errors.
///
/// # Errors
/// [`CompareError::Parse`] when the text is not a report with the fields read here.
pub fn parse_report(path: &Path, text: &str) -> Result<Report, CompareError> {
    let r: ReportRecord = serde_json::from_str(text).map_err(|source| CompareError::Parse {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(Report {
        path: path.to_path_buf(),
        config: r.config,
        runs: r
            .runs
            .into_iter()
            .map(|(family, run)| {
                let key = RunKey {
                    family,
                    strategy: run.strategy,
                    seed: run.seed,
                };
                (key, run.metrics)
            })
            .collect(),
    })
}

/// The reports of one side: `path` itself if it is a file, else every file named
/// `report.json` under the directory `path`, at any depth, in path order.
///
/// # Errors
/// [`CompareError::Read`] when `path` or a directory under it cannot be read,
/// [`CompareError::NoReports`] when a directory holds no `report.json`.
pub fn report_files(path: &Path) -> Result<Vec<PathBuf>, CompareError> {
    let read_err = |p: &Path| {
        let p = p.to_path_buf();
        move |source| CompareError::Read { path: p, source }
    };
    let meta = std::fs::metadata(path).map_err(read_err(path))?;
    if !meta.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let mut found = Vec::new();
    let mut dirs = vec![path.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).map_err(read_err(&dir))? {
            let entry = entry.map_err(read_err(&dir))?;
            let p = entry.path();
            // Symbolic links to directories are not followed: a link back up would loop.
            let kind = entry.file_type().map_err(read_err(&p))?;
            if kind.is_dir() {
                dirs.push(p);
            } else if entry.file_name() == "report.json" {
                found.push(p);
            }
        }
    }
    if found.is_empty() {
        return Err(CompareError::NoReports {
            dir: path.to_path_buf(),
        });
    }
    found.sort();
    Ok(found)
}

/// Reads one side: the report `path`, or every `report.json` under the directory `path`
/// (see [`report_files`]).
///
/// # Errors
/// As [`report_files`], and [`CompareError::Read`] or [`CompareError::Parse`] naming the
/// first file that cannot be read or parsed.
pub fn load_side(path: &Path) -> Result<Vec<Report>, CompareError> {
    report_files(path)?
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).map_err(|source| CompareError::Read {
                path: p.clone(),
                source,
            })?;
            parse_report(&p, &text)
        })
        .collect()
}

/// A configuration field that differs between two reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfigDifference {
    /// Dotted path into `config`, e.g. `run.aircraft.speed_mps`.
    pub field: String,
    /// Its value in the first report (`None`: absent).
    pub before: Option<Value>,
    /// Its value in the second.
    pub after: Option<Value>,
}

impl fmt::Display for ConfigDifference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let show = |v: &Option<Value>| v.as_ref().map_or("absent".to_string(), Value::to_string);
        write!(
            f,
            "{} ({} -> {})",
            self.field,
            show(&self.before),
            show(&self.after)
        )
    }
}

/// The fields of two reports' `config` objects that differ, by dotted path, leaving out
/// [`IGNORED_CONFIG_FIELDS`]. Objects are compared field by field at any depth; anything
/// else (numbers, lists, ...) as a whole.
pub fn config_differences(before: &Value, after: &Value) -> Vec<ConfigDifference> {
    let mut out = Vec::new();
    diff_values("", Some(before), Some(after), &mut out);
    out
}

fn diff_values(
    path: &str,
    before: Option<&Value>,
    after: Option<&Value>,
    out: &mut Vec<ConfigDifference>,
) {
    if IGNORED_CONFIG_FIELDS.contains(&path) {
        return;
    }
    if let (Some(Value::Object(b)), Some(Value::Object(a))) = (before, after) {
        let mut keys: Vec<&String> = b.keys().chain(a.keys()).collect();
        keys.sort();
        keys.dedup();
        for k in keys {
            let p = if path.is_empty() {
                k.clone()
            } else {
                format!("{path}.{k}")
            };
            diff_values(&p, b.get(k), a.get(k), out);
        }
    } else if before != after {
        out.push(ConfigDifference {
            field: path.to_string(),
            before: before.cloned(),
            after: after.cloned(),
        });
    }
}

/// The reports of one side whose configuration differs from the first one's in fields that
/// change the flights: `(report, its differences from the first)`, in order.
pub fn config_differences_within(reports: &[Report]) -> Vec<(&Path, Vec<ConfigDifference>)> {
    let Some((first, rest)) = reports.split_first() else {
        return Vec::new();
    };
    rest.iter()
        .map(|r| {
            (
                r.path.as_path(),
                config_differences(&first.config, &r.config),
            )
        })
        .filter(|(_, d)| !d.is_empty())
        .collect()
}

/// A figure before and after.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BeforeAfter<T> {
    /// The build before.
    pub before: T,
    /// The build after.
    pub after: T,
}

/// `f` of each side's runs.
fn per_side<'a, R>(pairs: &[Pair<'a>], f: impl Fn(&[&'a RunFigures]) -> R) -> BeforeAfter<R> {
    let before: Vec<&RunFigures> = pairs.iter().map(|p| p.before).collect();
    let after: Vec<&RunFigures> = pairs.iter().map(|p| p.after).collect();
    BeforeAfter {
        before: f(&before),
        after: f(&after),
    }
}

/// `f` of a pair's run before and after.
fn each<T>(p: &Pair<'_>, f: impl Fn(&RunFigures) -> T) -> BeforeAfter<T> {
    BeforeAfter {
        before: f(p.before),
        after: f(p.after),
    }
}

/// The mean of paired differences (after minus before) and its standard error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PairedDifference {
    /// Mean of the differences.
    pub mean: f64,
    /// Standard error of the mean: the differences' sample standard deviation (`n - 1`)
    /// over `sqrt(n)`; `None` for a single pair.
    pub se: Option<f64>,
}

impl PairedDifference {
    /// Of the differences `d` (at least one).
    pub fn of(d: &[f64]) -> Self {
        let n = d.len() as f64;
        let mean = d.iter().sum::<f64>() / n;
        let se = (d.len() > 1).then(|| {
            let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (var / n).sqrt()
        });
        Self { mean, se }
    }
}

/// One `(family, strategy)` row: its paired runs before and after.
///
/// # Units
/// Seconds, milliseconds, as the field names say.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupComparison {
    /// Scenario family (its name, e.g. `mixed`).
    #[serde(serialize_with = "family_name")]
    pub family: Family,
    /// Strategy (its command-line name, e.g. `mc-auto`).
    #[serde(serialize_with = "strategy_name")]
    pub strategy: StrategyKind,
    /// Runs paired.
    pub runs: usize,
    /// Spheres hit over the runs.
    pub sphere_hits: BeforeAfter<usize>,
    /// Cylinders hit over the runs.
    pub cylinder_hits: BeforeAfter<usize>,
    /// Runs with fewer hits (spheres and cylinders) after than before.
    pub runs_fewer_hits: usize,
    /// Runs with more hits after than before.
    pub runs_more_hits: usize,
    /// The two-sided sign test of those two counts ([`sign_test_p`]): how often a split at
    /// least this uneven comes by chance if the change made no difference to hits.
    /// `None` when no run's hits changed.
    pub hits_sign_test_p: Option<f64>,
    /// Waypoints captured over the runs.
    pub waypoints_captured: BeforeAfter<usize>,
    /// Waypoints over the runs.
    pub waypoints: BeforeAfter<usize>,
    /// The interop server's in-order waypoint score summed over the runs that report it,
    /// over their waypoints: a fraction (`None`: no run reports one).
    pub waypoint_score: BeforeAfter<Option<f64>>,
    /// Runs with a path ratio (those with `null` are left out of the next two).
    pub path_ratio_runs: BeforeAfter<usize>,
    /// Mean path ratio (`None`: no run has one).
    pub path_ratio_mean: BeforeAfter<Option<f64>>,
    /// Median path ratio (the mean of the two middle ones for an even count).
    pub path_ratio_p50: BeforeAfter<Option<f64>>,
    /// Mission time, after minus before, seconds a run.
    pub mission_time_s: PairedDifference,
    /// Team score (mission time plus the hit cost a hit), after minus before, seconds a
    /// run.
    pub team_score_s: PairedDifference,
    /// Runs whose least clearance is below [`NEAR_CLEARANCE_M`] (hits included).
    pub runs_within_10_m: BeforeAfter<usize>,
    /// Seconds out of the fly zone, summed over the runs.
    pub out_of_zone_s: BeforeAfter<f64>,
    /// Median over the runs of their replan CPU p95, ms (`None`: no run reports one).
    pub replan_cpu_p95_ms_median: BeforeAfter<Option<f64>>,
}

/// A paired run whose hits changed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HitChange {
    /// Scenario family.
    #[serde(serialize_with = "family_name")]
    pub family: Family,
    /// Strategy.
    #[serde(serialize_with = "strategy_name")]
    pub strategy: StrategyKind,
    /// Scenario seed.
    pub seed: u64,
    /// Spheres hit.
    pub sphere_hits: BeforeAfter<usize>,
    /// Cylinders hit.
    pub cylinder_hits: BeforeAfter<usize>,
    /// Least clearance, metres (negative: inside).
    pub min_clearance_m: BeforeAfter<Option<f64>>,
}

/// A paired run whose captured waypoints changed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WaypointChange {
    /// Scenario family.
    #[serde(serialize_with = "family_name")]
    pub family: Family,
    /// Strategy.
    #[serde(serialize_with = "strategy_name")]
    pub strategy: StrategyKind,
    /// Scenario seed.
    pub seed: u64,
    /// Waypoints captured.
    pub waypoints_captured: BeforeAfter<usize>,
    /// Waypoints.
    pub waypoints: BeforeAfter<usize>,
}

/// The comparison of two sides.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Seconds a hit adds to a run's team score.
    pub hit_cost_s: f64,
    /// The strategy paired on each side (command-line names) when one strategy is compared
    /// with another ([`compare_strategies`]); `None`: each with itself.
    pub strategies: Option<BeforeAfter<String>>,
    /// Runs on one side only, left out.
    pub unpaired: BeforeAfter<usize>,
    /// Configuration fields that change the flights and differ between the sides' first
    /// reports (see [`config_differences`]).
    pub config_differences: Vec<ConfigDifference>,
    /// One row per `(family, strategy)` with paired runs.
    pub groups: Vec<GroupComparison>,
    /// Paired runs whose sphere or cylinder hits changed.
    pub hits_changed: Vec<HitChange>,
    /// Paired runs whose captured waypoints changed.
    pub waypoints_changed: Vec<WaypointChange>,
}

fn family_name<S: Serializer>(f: &Family, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(f.name())
}

fn strategy_name<S: Serializer>(k: &StrategyKind, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(k.name())
}

/// A run flown by both builds.
#[derive(Debug, Clone, Copy)]
struct Pair<'a> {
    key: RunKey,
    before: &'a RunFigures,
    after: &'a RunFigures,
}

/// The runs of one side by key, each with the report it came from.
///
/// # Errors
/// [`CompareError::DuplicateRun`] for a key read twice.
fn index_side(
    side: Side,
    reports: &[Report],
) -> Result<BTreeMap<RunKey, (&RunFigures, &Path)>, CompareError> {
    let mut runs = BTreeMap::new();
    for r in reports {
        for (key, figures) in &r.runs {
            if let Some((_, first)) = runs.insert(*key, (figures, r.path.as_path())) {
                return Err(CompareError::DuplicateRun {
                    side,
                    key: *key,
                    first: first.to_path_buf(),
                    second: r.path.clone(),
                });
            }
        }
    }
    Ok(runs)
}

/// Pairs the runs of `before` and `after` by `(family, strategy, seed)` and compares them;
/// a hit adds `hit_cost_s` seconds to a run's team score ([`DEFAULT_HIT_COST_S`]).
///
/// # Errors
/// [`CompareError::DuplicateRun`] when one side holds a run twice,
/// [`CompareError::NothingPaired`] when no run is on both sides.
pub fn compare(
    before: &[Report],
    after: &[Report],
    hit_cost_s: f64,
) -> Result<Comparison, CompareError> {
    compare_strategies(before, after, hit_cost_s, None)
}

/// [`compare`], or with `strategies` (before, after) one strategy against another: only
/// `before`'s runs of the first and `after`'s runs of the second, paired by family and
/// seed (a strategy against `oracle`, say, from one report given as both sides). The rows
/// and lists are then named by the strategy before, and [`Comparison::strategies`] says
/// which two were paired.
///
/// # Errors
/// As [`compare`].
pub fn compare_strategies(
    before: &[Report],
    after: &[Report],
    hit_cost_s: f64,
    strategies: Option<(StrategyKind, StrategyKind)>,
) -> Result<Comparison, CompareError> {
    let mut b = index_side(Side::Before, before)?;
    let mut a = index_side(Side::After, after)?;
    if let Some((sb, sa)) = strategies {
        b.retain(|k, _| k.strategy == sb);
        a = a
            .into_iter()
            .filter(|(k, _)| k.strategy == sa)
            .map(|(k, v)| (RunKey { strategy: sb, ..k }, v))
            .collect();
    }
    let pairs: Vec<Pair<'_>> = b
        .iter()
        .filter_map(|(key, &(before, _))| {
            a.get(key).map(|&(after, _)| Pair {
                key: *key,
                before,
                after,
            })
        })
        .collect();
    if pairs.is_empty() {
        return Err(CompareError::NothingPaired {
            before: b.len(),
            after: a.len(),
        });
    }
    // Keys are ordered by family, then strategy: a group's pairs are consecutive.
    let groups = pairs
        .chunk_by(|x, y| (x.key.family, x.key.strategy) == (y.key.family, y.key.strategy))
        .map(|g| compare_group(g, hit_cost_s))
        .collect();
    let hits_changed = pairs
        .iter()
        .filter(|p| {
            (p.before.spheres_hit, p.before.cylinders_hit)
                != (p.after.spheres_hit, p.after.cylinders_hit)
        })
        .map(|p| HitChange {
            family: p.key.family,
            strategy: p.key.strategy,
            seed: p.key.seed,
            sphere_hits: each(p, |r| r.spheres_hit),
            cylinder_hits: each(p, |r| r.cylinders_hit),
            min_clearance_m: each(p, |r| r.min_clearance_m),
        })
        .collect();
    let waypoints_changed = pairs
        .iter()
        .filter(|p| p.before.waypoints_captured != p.after.waypoints_captured)
        .map(|p| WaypointChange {
            family: p.key.family,
            strategy: p.key.strategy,
            seed: p.key.seed,
            waypoints_captured: each(p, |r| r.waypoints_captured),
            waypoints: each(p, |r| r.waypoints),
        })
        .collect();
    let config_differences = match (before.first(), after.first()) {
        (Some(b), Some(a)) => config_differences(&b.config, &a.config),
        _ => Vec::new(),
    };
    Ok(Comparison {
        hit_cost_s,
        strategies: strategies.map(|(b, a)| BeforeAfter {
            before: b.name().to_owned(),
            after: a.name().to_owned(),
        }),
        unpaired: BeforeAfter {
            before: b.len() - pairs.len(),
            after: a.len() - pairs.len(),
        },
        config_differences,
        groups,
        hits_changed,
        waypoints_changed,
    })
}

/// The row of one group's pairs (all of one family and strategy, at least one).
fn compare_group(pairs: &[Pair<'_>], hit_cost_s: f64) -> GroupComparison {
    let sum = |f: fn(&RunFigures) -> usize| {
        per_side(pairs, move |rs| rs.iter().map(|r| f(r)).sum::<usize>())
    };
    let ratios = |rs: &[&RunFigures]| -> Vec<f64> {
        rs.iter()
            .filter_map(|r| r.path_ratio.filter(|x| x.is_finite()))
            .collect()
    };
    let diffs = |f: &dyn Fn(&RunFigures) -> f64| -> Vec<f64> {
        pairs.iter().map(|p| f(p.after) - f(p.before)).collect()
    };
    let hits = |r: &RunFigures| r.spheres_hit + r.cylinders_hit;
    let runs_fewer_hits = pairs
        .iter()
        .filter(|p| hits(p.after) < hits(p.before))
        .count();
    let runs_more_hits = pairs
        .iter()
        .filter(|p| hits(p.after) > hits(p.before))
        .count();
    GroupComparison {
        family: pairs[0].key.family,
        strategy: pairs[0].key.strategy,
        runs: pairs.len(),
        sphere_hits: sum(|r| r.spheres_hit),
        cylinder_hits: sum(|r| r.cylinders_hit),
        runs_fewer_hits,
        runs_more_hits,
        hits_sign_test_p: sign_test_p(runs_fewer_hits, runs_more_hits),
        waypoints_captured: sum(|r| r.waypoints_captured),
        waypoints: sum(|r| r.waypoints),
        waypoint_score: per_side(pairs, |rs| {
            let scored: Vec<(f64, usize)> = rs
                .iter()
                .filter_map(|r| r.waypoint_score.map(|s| (s, r.waypoints)))
                .collect();
            let of: usize = scored.iter().map(|(_, n)| n).sum();
            (of > 0).then(|| scored.iter().map(|(s, _)| s).sum::<f64>() / of as f64)
        }),
        path_ratio_runs: per_side(pairs, |rs| ratios(rs).len()),
        path_ratio_mean: per_side(pairs, |rs| mean(&ratios(rs))),
        path_ratio_p50: per_side(pairs, |rs| median(&ratios(rs))),
        mission_time_s: PairedDifference::of(&diffs(&|r| r.mission_time_s)),
        team_score_s: PairedDifference::of(&diffs(&|r| r.team_score_s(hit_cost_s))),
        runs_within_10_m: sum(|r| {
            usize::from(r.min_clearance_m.is_some_and(|c| c < NEAR_CLEARANCE_M))
        }),
        out_of_zone_s: per_side(pairs, |rs| {
            rs.iter().map(|r| r.boundary_violation_s).sum::<f64>()
        }),
        replan_cpu_p95_ms_median: per_side(pairs, |rs| {
            let v: Vec<f64> = rs
                .iter()
                .filter_map(|r| r.replan_cpu_p95_ms.filter(|x| x.is_finite()))
                .collect();
            median(&v)
        }),
    }
}

/// The two-sided exact sign test: with `fewer` runs better and `more` worse (ties left
/// out), the probability under a fair coin of a split at least as uneven, `min(1, 2 *
/// P(X <= min(fewer, more)))` with `X ~ Binomial(fewer + more, 1/2)`. `None` for no
/// changed run. Summed in log space, so it holds for any count.
pub fn sign_test_p(fewer: usize, more: usize) -> Option<f64> {
    let n = fewer + more;
    if n == 0 {
        return None;
    }
    let k = fewer.min(more);
    // ln C(n, i) - n ln 2 for i = 0..=k, each from the one before.
    let (mut ln_term, mut sum) = (-(n as f64) * std::f64::consts::LN_2, 0.0);
    for i in 0..=k {
        if i > 0 {
            ln_term += ((n - i + 1) as f64).ln() - (i as f64).ln();
        }
        sum += ln_term.exp();
    }
    Some((2.0 * sum).min(1.0))
}

/// The mean (`None` for none).
fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The median, the mean of the two middle values for an even count (`None` for none).
pub fn median(v: &[f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    Some(if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    })
}

/// `x` with its sign and `decimals` decimals, never `-0.0`.
fn signed(x: f64, decimals: usize) -> String {
    let s = format!("{x:+.decimals$}");
    if s.bytes().skip(1).all(|c| c == b'0' || c == b'.') {
        format!("{:+.decimals$}", 0.0)
    } else {
        s
    }
}

/// `x` with `decimals` decimals, `n/a` for `None`.
fn fixed(x: Option<f64>, decimals: usize) -> String {
    x.map_or_else(|| "n/a".to_string(), |x| format!("{x:.decimals$}"))
}

/// `before -> after` of a figure.
fn arrow<T>(v: &BeforeAfter<T>, show: impl Fn(&T) -> String) -> String {
    format!("{} -> {}", show(&v.before), show(&v.after))
}

/// A paired difference as the README quotes it: `+2.4 s (1.6)`, the se in brackets.
fn paired_cell(d: &PairedDifference) -> String {
    format!(
        "{} s ({})",
        signed(d.mean, 1),
        d.se.map_or("n/a".to_string(), |se| format!("{se:.1}"))
    )
}

/// The row's path ratio cell: `mean / p50 -> mean / p50`, each side with the count of
/// runs it is over when some runs had none.
fn path_ratio_cell(g: &GroupComparison) -> String {
    let side = |mean: Option<f64>, p50: Option<f64>, n: usize| {
        if n == 0 {
            "n/a".to_string()
        } else if n < g.runs {
            format!("{} / {} ({n} runs)", fixed(mean, 3), fixed(p50, 3))
        } else {
            format!("{} / {}", fixed(mean, 3), fixed(p50, 3))
        }
    };
    format!(
        "{} -> {}",
        side(
            g.path_ratio_mean.before,
            g.path_ratio_p50.before,
            g.path_ratio_runs.before
        ),
        side(
            g.path_ratio_mean.after,
            g.path_ratio_p50.after,
            g.path_ratio_runs.after
        )
    )
}

/// "1 run", "2 runs".
fn runs(n: usize) -> String {
    if n == 1 {
        "1 run".to_owned()
    } else {
        format!("{n} runs")
    }
}

/// `captured -> captured of N`, or each side with its own count when they differ.
fn waypoints_cell(captured: &BeforeAfter<usize>, of: &BeforeAfter<usize>) -> String {
    if of.before == of.after {
        format!("{} -> {} of {}", captured.before, captured.after, of.before)
    } else {
        format!(
            "{} of {} -> {} of {}",
            captured.before, of.before, captured.after, of.after
        )
    }
}

/// The comparison as Markdown: the table of `(family, strategy)` rows, what its columns
/// mean, then the seeds whose hits changed and those whose captured waypoints changed.
/// Paths and warnings are not part of it (the caller reports those).
pub fn render_markdown(c: &Comparison) -> String {
    let mut s = String::new();
    if let Some(st) = &c.strategies {
        let _ = writeln!(
            s,
            "Strategy `{}` before against `{}` after, paired by family and seed; rows are named by the strategy before.\n",
            st.before, st.after
        );
    }
    s.push_str("| family | strategy | runs | sphere hits | cylinder hits | waypoints captured | waypoint score, in order | path ratio mean / p50 | mission time, a run (se) | team score, a run (se) | runs within 10 m | out of zone, s over the runs | replan CPU p95, median of runs (ms) |\n");
    s.push_str("|---|---|---:|---|---|---|---|---|---:|---:|---|---|---|\n");
    for g in &c.groups {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            g.family.name(),
            g.strategy.name(),
            g.runs,
            arrow(&g.sphere_hits, usize::to_string),
            arrow(&g.cylinder_hits, usize::to_string),
            waypoints_cell(&g.waypoints_captured, &g.waypoints),
            arrow(&g.waypoint_score, |x| {
                x.map_or_else(|| "n/a".to_string(), |x| format!("{:.1}%", 100.0 * x))
            }),
            path_ratio_cell(g),
            paired_cell(&g.mission_time_s),
            paired_cell(&g.team_score_s),
            arrow(&g.runs_within_10_m, usize::to_string),
            arrow(&g.out_of_zone_s, |x| format!("{x:.1}")),
            arrow(&g.replan_cpu_p95_ms_median, |x| fixed(*x, 2)),
        );
    }
    let _ = writeln!(
        s,
        "\nBefore -> after, runs paired by family, strategy and seed. Mission time and team score: \
         the mean of after minus before, seconds a run, with its standard error in brackets \
         (the differences' sample standard deviation over the square root of the runs). \
         Team score: mission time plus {} s a sphere or cylinder hit. Waypoint score: the \
         interop server's, waypoints graded by distance and counted in mission order, over \
         the waypoints (n/a: reports older than it).",
        c.hit_cost_s
    );
    if c.hits_changed.is_empty() {
        s.push_str("\nHits changed: none.\n");
    } else {
        let _ = writeln!(s, "\nHits changed ({}):\n", runs(c.hits_changed.len()));
        s.push_str(
            "| family | strategy | seed | sphere hits | cylinder hits | least clearance (m) |\n",
        );
        s.push_str("|---|---|---:|---|---|---|\n");
        for h in &c.hits_changed {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} |",
                h.family.name(),
                h.strategy.name(),
                h.seed,
                arrow(&h.sphere_hits, usize::to_string),
                arrow(&h.cylinder_hits, usize::to_string),
                arrow(&h.min_clearance_m, |x| fixed(*x, 1)),
            );
        }
    }
    for g in c.groups.iter().filter(|g| g.hits_sign_test_p.is_some()) {
        let _ = writeln!(
            s,
            "\n{} / {}: {} with fewer hits after, {} with more; two-sided sign test p = {} \
             (how often a split at least this uneven comes by chance if hits did not change).",
            g.family.name(),
            g.strategy.name(),
            runs(g.runs_fewer_hits),
            runs(g.runs_more_hits),
            fixed(g.hits_sign_test_p, 3),
        );
    }
    if c.waypoints_changed.is_empty() {
        s.push_str("\nWaypoints captured changed: none.\n");
    } else {
        let _ = writeln!(
            s,
            "\nWaypoints captured changed ({}):\n",
            runs(c.waypoints_changed.len())
        );
        s.push_str("| family | strategy | seed | waypoints captured |\n");
        s.push_str("|---|---|---:|---|\n");
        for w in &c.waypoints_changed {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                w.family.name(),
                w.strategy.name(),
                w.seed,
                waypoints_cell(&w.waypoints_captured, &w.waypoints),
            );
        }
    }
    s
}

/// The comparison as pretty JSON: the fields of [`Comparison`] by their names, a figure
/// before and after as `{"before": .., "after": ..}`, a paired difference as
/// `{"mean": .., "se": ..}`, families and strategies by their command-line names, and
/// `null` for a figure no run has.
///
/// # Errors
/// A serialisation failure (not expected: every key is a string).
pub fn render_json(c: &Comparison) -> serde_json::Result<String> {
    serde_json::to_string_pretty(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use serde_json::json;

    /// A run as `jink simulate` writes it (with a few fields the comparison does not read).
    #[derive(Clone, Copy)]
    struct R {
        strategy: &'static str,
        seed: u64,
        spheres_hit: usize,
        cylinders_hit: usize,
        captured: usize,
        time_s: f64,
        path_ratio: Option<f64>,
        clearance_m: f64,
        out_s: f64,
        cpu_ms: f64,
        score: Option<f64>,
    }

    /// An unremarkable run of `mc-auto`: 5 of 5 waypoints in 300 s, path ratio 1.2, clear
    /// by 30 m, never out of the zone, 2 ms replan CPU p95.
    fn r(seed: u64) -> R {
        R {
            strategy: "bisection_auto",
            seed,
            spheres_hit: 0,
            cylinders_hit: 0,
            captured: 5,
            time_s: 300.0,
            path_ratio: Some(1.2),
            clearance_m: 30.0,
            out_s: 0.0,
            cpu_ms: 2.0,
            score: None,
        }
    }

    impl R {
        fn strategy(self, strategy: &'static str) -> Self {
            Self { strategy, ..self }
        }
        fn time(self, time_s: f64) -> Self {
            Self { time_s, ..self }
        }
        fn hits(self, spheres_hit: usize, cylinders_hit: usize) -> Self {
            Self {
                spheres_hit,
                cylinders_hit,
                ..self
            }
        }
        fn captured(self, captured: usize) -> Self {
            Self { captured, ..self }
        }
        fn ratio(self, path_ratio: Option<f64>) -> Self {
            Self { path_ratio, ..self }
        }
        fn clearance(self, clearance_m: f64) -> Self {
            Self {
                clearance_m,
                ..self
            }
        }
        fn out(self, out_s: f64) -> Self {
            Self { out_s, ..self }
        }
        fn cpu(self, cpu_ms: f64) -> Self {
            Self { cpu_ms, ..self }
        }
        fn score(self, score: f64) -> Self {
            Self {
                score: Some(score),
                ..self
            }
        }
    }

    /// A `report.json` of `runs` (family `mixed`) flown at `speed_mps`.
    fn report_text(speed_mps: f64, runs: &[R]) -> String {
        let runs: Vec<Value> = runs
            .iter()
            .map(|r| {
                let mut run = json!(["mixed", {
                    "seed": r.seed,
                    "strategy": r.strategy,
                    "metrics": {
                        "sphere_score": 1.0,
                        "spheres_hit": r.spheres_hit,
                        "spheres": 6,
                        "cylinders_hit": r.cylinders_hit,
                        "waypoints_captured": r.captured,
                        "waypoints": 5,
                        "completed": true,
                        "mission_time_s": r.time_s,
                        "path_ratio": r.path_ratio,
                        "min_clearance_m": r.clearance_m,
                        "boundary_violation_s": r.out_s,
                        "replan_cpu_p95_ms": r.cpu_ms,
                        "replans": 300
                    },
                    "judge": {},
                    "track": []
                }]);
                // Reports older than the waypoint score have no such key.
                if let Some(score) = r.score {
                    run[1]["metrics"]["waypoint_score"] = json!(score);
                }
                run
            })
            .collect();
        json!({
            "config": {
                "seeds": runs.iter().map(|r| r[1]["seed"].clone()).collect::<Vec<_>>(),
                "run": { "aircraft": { "speed_mps": speed_mps }, "record_track": true },
                "plot_seeds": []
            },
            "summary": [],
            "runs": runs,
            "wall_s": 1.0,
            "threads": 2
        })
        .to_string()
    }

    fn report(name: &str, runs: &[R]) -> Report {
        parse_report(Path::new(name), &report_text(20.0, runs)).unwrap()
    }

    fn compared_at(before: &[R], after: &[R], hit_cost_s: f64) -> Comparison {
        let (b, a) = (report("before.json", before), report("after.json", after));
        compare(&[b], &[a], hit_cost_s).unwrap()
    }

    fn compared(before: &[R], after: &[R]) -> Comparison {
        compared_at(before, after, DEFAULT_HIT_COST_S)
    }

    #[test]
    fn mission_time_and_team_score_are_paired_means_with_their_standard_errors() {
        let before = [r(1).time(100.0), r(2).time(200.0), r(3).time(300.0)];
        // a sphere hit after only: 900 s on its team score
        let after = [
            r(1).time(110.0),
            r(2).time(190.0),
            r(3).time(330.0).hits(1, 0),
        ];
        let c = compared(&before, &after);
        assert_eq!(c.groups.len(), 1);
        let g = &c.groups[0];
        assert_eq!(g.runs, 3);
        assert_eq!(
            g.sphere_hits,
            BeforeAfter {
                before: 0,
                after: 1
            }
        );
        // differences 10, -10, 30: mean 10, deviations 0, -20, 20, sd sqrt(800 / 2) = 20
        let t = g.mission_time_s;
        assert_relative_eq!(t.mean, 10.0, epsilon = 1e-12);
        assert_relative_eq!(t.se.unwrap(), 20.0 / 3f64.sqrt(), epsilon = 1e-12);
        // team score differences 10, -10, 930: mean 310, deviations -300, -320, 620,
        // sd sqrt((90000 + 102400 + 384400) / 2)
        let s = g.team_score_s;
        assert_relative_eq!(s.mean, 310.0, epsilon = 1e-12);
        assert_relative_eq!(
            s.se.unwrap(),
            (576_800.0f64 / 2.0).sqrt() / 3f64.sqrt(),
            epsilon = 1e-9
        );
        // A cheaper hit moves the team score only: differences 10, -10, 120.
        let g = &compared_at(&before, &after, 90.0).groups[0];
        assert_relative_eq!(g.team_score_s.mean, 40.0, epsilon = 1e-12);
        assert_relative_eq!(g.mission_time_s.mean, 10.0, epsilon = 1e-12);
        assert!(render_markdown(&c).contains("| +10.0 s (11.5) | +310.0 s (310.1) |"));
    }

    #[test]
    fn the_waypoint_score_is_summed_over_the_runs_that_report_it() {
        // Before: 4 + 5 of 10 waypoints. After: run 2's report is older (no score), so
        // run 1 alone: 5 of 5.
        let before = [r(1).score(4.0), r(2).score(5.0)];
        let after = [r(1).score(5.0), r(2)];
        let g = &compared(&before, &after).groups[0];
        assert_relative_eq!(g.waypoint_score.before.unwrap(), 0.9, epsilon = 1e-12);
        assert_relative_eq!(g.waypoint_score.after.unwrap(), 1.0, epsilon = 1e-12);
        assert!(render_markdown(&compared(&before, &after)).contains("| 90.0% -> 100.0% |"));
        // Neither side reports one.
        let c = compared(&[r(1)], &[r(1)]);
        assert_eq!(c.groups[0].waypoint_score.before, None);
        assert!(render_markdown(&c).contains("| n/a -> n/a |"));
    }

    #[test]
    fn the_sign_test_is_the_binomial_tail_counted_by_hand() {
        // 8 runs cleared, 4 newly hit: 2 * (C(12,0) + C(12,1) + ... + C(12,4)) / 2^12
        // = 2 * (1 + 12 + 66 + 220 + 495) / 4096 = 1588 / 4096.
        assert_relative_eq!(sign_test_p(8, 4).unwrap(), 1588.0 / 4096.0, epsilon = 1e-12);
        assert_relative_eq!(sign_test_p(4, 8).unwrap(), 1588.0 / 4096.0, epsilon = 1e-12);
        // 5 against 0: 2 / 32; an even split is capped at 1; nothing changed: no test.
        assert_relative_eq!(sign_test_p(5, 0).unwrap(), 0.0625, epsilon = 1e-12);
        assert_eq!(sign_test_p(3, 3), Some(1.0));
        assert_eq!(sign_test_p(0, 0), None);
        // Large counts do not underflow: 0 against 2000 is tiny but positive, 1000 each 1.
        let tiny = sign_test_p(0, 2000).unwrap();
        assert!((0.0..1e-300).contains(&tiny), "{tiny}");
        assert_relative_eq!(sign_test_p(1000, 1000).unwrap(), 1.0, epsilon = 1e-9);

        // In a comparison: run 1 cleared, run 2 newly hit, run 3 hit on both sides (not
        // counted), run 4 hit twice before and once after (fewer).
        let before = [r(1).hits(1, 0), r(2), r(3).hits(1, 0), r(4).hits(1, 1)];
        let after = [r(1), r(2).hits(0, 1), r(3).hits(1, 0), r(4).hits(1, 0)];
        let c = compared(&before, &after);
        let g = &c.groups[0];
        assert_eq!((g.runs_fewer_hits, g.runs_more_hits), (2, 1));
        // 2 against 1: 2 * (C(3,0) + C(3,1)) / 8 = 1.
        assert_eq!(g.hits_sign_test_p, Some(1.0));
        assert!(
            render_markdown(&c).contains(
                "2 runs with fewer hits after, 1 run with more; two-sided sign test p = 1.000"
            ),
            "{}",
            render_markdown(&c)
        );
        assert_eq!(compared(&[r(1)], &[r(1)]).groups[0].hits_sign_test_p, None);
    }

    #[test]
    fn one_strategy_is_paired_with_another_by_seed_from_one_report() {
        // One report flown with `mc-auto` and `oracle` on seeds 1-2, and `none` on seed 1.
        let runs = [
            r(1).time(300.0).hits(1, 0),
            r(2).time(320.0),
            r(1).strategy("oracle").time(280.0),
            r(2).strategy("oracle").time(290.0),
            r(1).strategy("none").time(500.0),
        ];
        let both = [report("both.json", &runs)];
        let c = compare_strategies(
            &both,
            &both,
            DEFAULT_HIT_COST_S,
            Some((
                StrategyKind::parse("mc-auto").unwrap(),
                StrategyKind::Oracle,
            )),
        )
        .unwrap();
        assert_eq!(c.groups.len(), 1);
        let g = &c.groups[0];
        assert_eq!((g.runs, g.strategy.name()), (2, "mc-auto"));
        // differences -20 and -30: mean -25, sd sqrt(50), se sqrt(50 / 2) = 5
        assert_relative_eq!(g.mission_time_s.mean, -25.0, epsilon = 1e-12);
        assert_relative_eq!(g.mission_time_s.se.unwrap(), 5.0, epsilon = 1e-12);
        // team: -920 and -30
        assert_relative_eq!(g.team_score_s.mean, -475.0, epsilon = 1e-12);
        assert_eq!((g.runs_fewer_hits, g.runs_more_hits), (1, 0));
        // the other strategies of each side are not "unpaired": they were not asked for
        assert_eq!(
            c.unpaired,
            BeforeAfter {
                before: 0,
                after: 0
            }
        );
        let md = render_markdown(&c);
        assert!(
            md.starts_with("Strategy `mc-auto` before against `oracle` after"),
            "{md}"
        );
        // Without strategies, the same report against itself pairs each with itself.
        let same = compare(&both, &both, DEFAULT_HIT_COST_S).unwrap();
        assert_eq!(same.groups.len(), 3);
        assert!(same.strategies.is_none());
        assert_relative_eq!(same.groups[0].mission_time_s.mean, 0.0);
    }

    #[test]
    fn a_single_pair_has_no_standard_error() {
        let c = compared(&[r(1)], &[r(1).time(310.0)]);
        let g = &c.groups[0];
        assert_eq!(
            g.mission_time_s,
            PairedDifference {
                mean: 10.0,
                se: None
            }
        );
        assert!(render_markdown(&c).contains("| +10.0 s (n/a) |"));
    }

    #[test]
    fn a_run_whose_hits_changed_is_listed_with_its_least_clearances() {
        let before = [r(1), r(2).hits(0, 1).clearance(-4.0)];
        let after = [r(1).clearance(12.5), r(2).clearance(3.25)];
        let c = compared(&before, &after);
        assert_eq!(c.hits_changed.len(), 1);
        let h = &c.hits_changed[0];
        assert_eq!(
            (h.family, h.strategy, h.seed),
            (Family::Mixed, StrategyKind::BisectionAuto, 2)
        );
        assert_eq!(
            h.sphere_hits,
            BeforeAfter {
                before: 0,
                after: 0
            }
        );
        assert_eq!(
            h.cylinder_hits,
            BeforeAfter {
                before: 1,
                after: 0
            }
        );
        let clearance = BeforeAfter {
            before: Some(-4.0),
            after: Some(3.25),
        };
        assert_eq!(h.min_clearance_m, clearance);
        let g = &c.groups[0];
        // team score differences 0 and -900, over 2 runs
        assert_relative_eq!(g.team_score_s.mean, -450.0, epsilon = 1e-12);
        // within 10 m: seed 2 before (-4 m, a hit) and after (3.25 m); seed 1 never
        assert_eq!(
            g.runs_within_10_m,
            BeforeAfter {
                before: 1,
                after: 1
            }
        );
        let md = render_markdown(&c);
        assert!(
            md.contains("| mixed | mc-auto | 2 | 0 -> 0 | 1 -> 0 | -4.0 -> 3.2 |"),
            "{md}"
        );
        assert!(md.contains("Waypoints captured changed: none."), "{md}");
    }

    #[test]
    fn a_run_whose_captured_waypoints_changed_is_listed() {
        let c = compared(&[r(1), r(2)], &[r(1), r(2).captured(4)]);
        assert_eq!(c.waypoints_changed.len(), 1);
        assert_eq!(c.waypoints_changed[0].seed, 2);
        let captured = BeforeAfter {
            before: 10,
            after: 9,
        };
        assert_eq!(c.groups[0].waypoints_captured, captured);
        let md = render_markdown(&c);
        assert!(md.contains("| 10 -> 9 of 10 |"), "{md}");
        assert!(md.contains("| mixed | mc-auto | 2 | 5 -> 4 of 5 |"), "{md}");
        assert!(md.contains("Hits changed: none."), "{md}");
    }

    #[test]
    fn runs_on_one_side_only_are_counted_and_left_out() {
        let c = compared(
            &[r(1), r(2).time(1000.0)],
            &[r(2), r(3), r(4), r(2).strategy("oracle")],
        );
        assert_eq!(
            c.unpaired,
            BeforeAfter {
                before: 1,
                after: 3
            }
        );
        assert_eq!(c.groups.len(), 1);
        assert_eq!(c.groups[0].runs, 1);
        assert_eq!(c.groups[0].mission_time_s.mean, -700.0);
    }

    #[test]
    fn rows_are_per_family_and_strategy() {
        let c = compared(
            &[r(1), r(1).strategy("oracle"), r(1).strategy("none")],
            &[
                r(1),
                r(1).strategy("oracle").time(280.0),
                r(1).strategy("none"),
            ],
        );
        let rows: Vec<(&str, f64)> = c
            .groups
            .iter()
            .map(|g| (g.strategy.name(), g.mission_time_s.mean))
            .collect();
        assert_eq!(
            rows,
            vec![("mc-auto", 0.0), ("none", 0.0), ("oracle", -20.0)]
        );
    }

    #[test]
    fn nothing_paired_is_an_error() {
        let (b, a) = (report("b", &[r(1)]), report("a", &[r(2), r(3)]));
        let e = compare(&[b], &[a], 900.0).unwrap_err();
        assert!(
            matches!(
                e,
                CompareError::NothingPaired {
                    before: 1,
                    after: 2
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn the_same_run_twice_on_one_side_is_an_error_naming_both_files() {
        let before = [report("b.json", &[r(1)])];
        let after = [
            report("a1/report.json", &[r(1), r(2)]),
            report("a2/report.json", &[r(2)]),
        ];
        let e = compare(&before, &after, 900.0).unwrap_err();
        let msg = e.to_string();
        assert!(
            matches!(
                e,
                CompareError::DuplicateRun {
                    side: Side::After,
                    ..
                }
            ),
            "{msg}"
        );
        assert_eq!(
            msg,
            "after holds the run (mixed, mc-auto, seed 2) twice: in a1/report.json and in a2/report.json"
        );
    }

    #[test]
    fn a_null_path_ratio_is_left_out_of_the_path_ratio_column() {
        let before = [r(1), r(2).ratio(None), r(3).ratio(Some(1.5))];
        let after = [
            r(1).ratio(Some(1.1)),
            r(2).ratio(Some(1.3)),
            r(3).ratio(Some(2.0)),
        ];
        let c = compared(&before, &after);
        let g = &c.groups[0];
        assert_eq!(
            g.path_ratio_runs,
            BeforeAfter {
                before: 2,
                after: 3
            }
        );
        // before: 1.2 and 1.5 (seed 2 left out); after: 1.1, 1.3 and 2.0
        assert_relative_eq!(g.path_ratio_mean.before.unwrap(), 1.35, epsilon = 1e-12);
        assert_relative_eq!(g.path_ratio_p50.before.unwrap(), 1.35, epsilon = 1e-12);
        assert_relative_eq!(g.path_ratio_mean.after.unwrap(), 4.4 / 3.0, epsilon = 1e-12);
        assert_relative_eq!(g.path_ratio_p50.after.unwrap(), 1.3, epsilon = 1e-12);
        let md = render_markdown(&c);
        assert!(
            md.contains("| 1.350 / 1.350 (2 runs) -> 1.467 / 1.300 |"),
            "{md}"
        );
        // No ratio at all on one side.
        let c = compared(&[r(1).ratio(None)], &[r(1)]);
        assert_eq!(c.groups[0].path_ratio_mean.before, None);
        assert!(render_markdown(&c).contains("| n/a -> 1.200 / 1.200 |"));
    }

    #[test]
    fn out_of_zone_is_summed_and_replan_cpu_is_the_median_over_runs() {
        let before =
            [r(0).cpu(1.0), r(1).cpu(4.0), r(2).cpu(2.0), r(3).cpu(10.0)].map(|r| r.out(1.5));
        let after = [r(0), r(1).out(0.25), r(2).out(0.5), r(3).out(0.75)].map(|r| r.cpu(3.0));
        let g = &compared(&before, &after).groups[0];
        assert_eq!(
            g.out_of_zone_s,
            BeforeAfter {
                before: 6.0,
                after: 1.5
            }
        );
        // before, sorted: 1, 2, 4, 10, so (2 + 4) / 2
        let cpu = BeforeAfter {
            before: Some(3.0),
            after: Some(3.0),
        };
        assert_eq!(g.replan_cpu_p95_ms_median, cpu);
        assert_eq!(median(&[5.0, 1.0, 3.0]), Some(3.0));
        assert_eq!(median(&[]), None);
    }

    #[test]
    fn extra_fields_are_ignored_and_missing_ones_are_named() {
        let text = r#"{"config": {}, "runs": [["mixed", {"seed": 1, "strategy": "oracle", "metrics": {}}]]}"#;
        let e = parse_report(Path::new("x/report.json"), text).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.starts_with("x/report.json: not a `jink simulate` report.json"),
            "{msg}"
        );
        assert!(msg.contains("spheres_hit"), "{msg}");
        let e = parse_report(Path::new("y.json"), "{").unwrap_err();
        assert!(matches!(e, CompareError::Parse { .. }), "{e}");
        // A report older than the replan CPU time: the runs have none.
        let text = report_text(20.0, &[r(1)]).replace("\"replan_cpu_p95_ms\"", "\"other\"");
        let old = parse_report(Path::new("old.json"), &text).unwrap();
        assert_eq!(old.runs[0].1.replan_cpu_p95_ms, None);
    }

    #[test]
    fn config_differences_name_the_fields_that_change_the_flights() {
        let b = parse_report(Path::new("b"), &report_text(14.0, &[r(1)])).unwrap();
        let a = parse_report(Path::new("a"), &report_text(20.0, &[r(2), r(3)])).unwrap();
        // the seeds differ too, but they are what the pairing deals with
        let d = config_differences(&b.config, &a.config);
        let fields: Vec<String> = d.iter().map(ToString::to_string).collect();
        assert_eq!(fields, vec!["run.aircraft.speed_mps (14.0 -> 20.0)"]);
        let d = config_differences(
            &json!({"run": {"dt_s": 0.1}}),
            &json!({"run": {}, "threads": 2}),
        );
        let fields: Vec<String> = d.iter().map(ToString::to_string).collect();
        assert_eq!(
            fields,
            vec!["run.dt_s (0.1 -> absent)", "threads (absent -> 2)"]
        );
        assert!(config_differences(&a.config, &a.config).is_empty());
        let side = [a.clone(), b, a];
        let within = config_differences_within(&side);
        assert_eq!(within.len(), 1);
        assert_eq!(within[0].0, Path::new("b"));
    }

    #[test]
    fn paired_figures_never_print_minus_zero() {
        assert_eq!(signed(-0.01, 1), "+0.0");
        assert_eq!(signed(0.0, 1), "+0.0");
        assert_eq!(signed(-0.06, 1), "-0.1");
        assert_eq!(signed(2.44, 1), "+2.4");
    }

    /// A file of `tests/fixtures/compare`. Its reports were flown by `jink simulate --family
    /// mixed --strategies none,mc-auto --no-plot --quiet --threads 1` with `--aircraft-speed
    /// 14 --seeds 3 --first-seed 0` (`before/`) and with `--aircraft-speed 16
    /// --acceptance-radius 40`, `--seeds 2 --first-seed 1` (`after/seeds-1-2/`) and
    /// `--seeds 1 --first-seed 3` (`after/seed-3/`): partly overlapping seeds, one side split
    /// over two reports, settings that change hits and waypoints.
    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/fixtures/compare")
            .join(name)
    }

    /// `actual` must equal the golden file `name`; `JINK_BLESS=1` writes it.
    fn golden(name: &str, actual: &str) {
        let path = fixture(name);
        if std::env::var_os("JINK_BLESS").is_some() {
            std::fs::write(&path, actual).unwrap();
        }
        let expected = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (JINK_BLESS=1 writes it)", path.display()));
        assert_eq!(
            actual,
            expected,
            "{} differs; JINK_BLESS=1 cargo test -p sim --lib compare regenerates it",
            path.display()
        );
    }

    #[test]
    fn the_fixture_reports_compare_as_the_golden_files_say() {
        let before = load_side(&fixture("before")).unwrap();
        let after = load_side(&fixture("after")).unwrap();
        // after/ is one block split over two processes: both reports are merged
        assert_eq!(before.len(), 1);
        assert_eq!(after.len(), 2);
        let c = compare(&before, &after, DEFAULT_HIT_COST_S).unwrap();
        // before flew seeds 0-2, after 1-3, each with `none` and `mc-auto`
        assert_eq!(
            c.unpaired,
            BeforeAfter {
                before: 2,
                after: 2
            }
        );
        assert_eq!(c.groups.len(), 2);
        assert!(c.groups.iter().all(|g| g.runs == 2));
        // after flew 16 m/s with a 40 m acceptance radius, before 14 m/s and 10 m
        let fields: Vec<&str> = c
            .config_differences
            .iter()
            .map(|d| d.field.as_str())
            .collect();
        assert!(fields.contains(&"run.aircraft.speed_mps"), "{fields:?}");
        assert!(
            fields.contains(&"run.aircraft.acceptance_radius_m"),
            "{fields:?}"
        );
        assert!(config_differences_within(&after).is_empty());
        golden("expected.md", &render_markdown(&c));
        golden("expected.json", &(render_json(&c).unwrap() + "\n"));
    }

    #[test]
    fn a_directory_without_reports_and_a_missing_path_are_errors_naming_them() {
        let e = load_side(&fixture("no-such-dir")).unwrap_err();
        assert!(matches!(e, CompareError::Read { .. }), "{e}");
        assert!(e.to_string().contains("no-such-dir"), "{e}");
        // a directory with files but no report.json: the fixtures' golden files' own
        // directory holds them at depth, so look at a directory that has none
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/strategy");
        let e = load_side(&dir).unwrap_err();
        assert!(matches!(e, CompareError::NoReports { .. }), "{e}");
    }
}
