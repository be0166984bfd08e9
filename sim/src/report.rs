//! Reports: the Markdown summary table and the JSON report of a suite.

use std::fmt::Write;

use crate::suite::SuiteReport;

/// The summary as a Markdown table (one line per family and strategy).
pub fn markdown_table(r: &SuiteReport) -> String {
    let mut s = String::new();
    s.push_str("| family | strategy | runs | sphere score | cylinder score | clean runs | sphere hits | cylinder hits | waypoints | waypoint score, in order | path ratio mean / p50 | min clearance p50 (m) | wp added (reached / targeted) | route added / removed by replans (m a run) | out of zone (s) | replan p50 / p95 / max (ms) | replan CPU p95 / max (ms) | live map p50 / p95 (ms) | mission-min per core-s |\n");
    s.push_str(
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for row in &r.summary {
        let tp = if row.cpu_s > 0.0 {
            row.sim_s / 60.0 / row.cpu_s
        } else {
            0.0
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.3} | {:.3} | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.2} / {:.2} | {:.1} | {:.1} / {:.1} | {:.0} / {:.0} | {:.2} | {:.2} / {:.2} / {:.1} | {:.2} / {:.1} | {:.1} / {:.1} | {:.1} |",
            row.family.name(),
            row.strategy.name(),
            row.runs,
            row.sphere_score,
            row.cylinder_score,
            100.0 * row.clean_runs,
            100.0 * row.sphere_hit_rate,
            100.0 * row.cylinder_hit_rate,
            100.0 * row.waypoint_rate,
            100.0 * row.waypoint_score_rate,
            row.path_ratio,
            row.path_ratio_p50,
            row.min_clearance_p50_m,
            row.waypoints_added,
            row.avoid_targets,
            row.route_added_m,
            row.route_removed_m,
            row.boundary_violation_s,
            row.replan_p50_ms,
            row.replan_p95_ms,
            row.replan_max_ms,
            row.replan_cpu_p95_ms,
            row.replan_cpu_max_ms,
            row.live_p50_ms,
            row.live_p95_ms,
            tp,
        );
    }
    s
}

/// The whole report as pretty JSON.
///
/// # Errors
/// A serialisation failure (non-finite numbers are written as `null` by serde_json, so this
/// is not expected).
pub fn json(r: &SuiteReport) -> serde_json::Result<String> {
    serde_json::to_string_pretty(r)
}
