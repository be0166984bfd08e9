//! `jink compare BEFORE AFTER`, the real binary, on the fixture reports of
//! `tests/fixtures/compare` (flown by `jink simulate`; `after/` is one block split over two
//! processes): the table it prints is the golden file's, and what it cannot compare exits
//! with code 2 naming the problem.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Output;

use serde_json::Value;

/// `jink compare ARGS`, the real binary.
fn compare<A: AsRef<OsStr>>(args: &[A]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_jink"))
        .arg("compare")
        .args(args)
        .output()
        .unwrap()
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/compare")
        .join(name)
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn compare_prints_the_paired_table_of_the_fixture_reports() {
    let out = compare(&[&fixture("before"), &fixture("after")]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{stdout}\n{stderr}");
    // The library's golden file, so the binary prints what the library renders.
    let golden = std::fs::read_to_string(fixture("expected.md")).unwrap();
    assert_eq!(stdout, golden, "stderr: {stderr}");
    // A figure: `mc-auto` flew seeds 1 and 2 on both sides, with no hit either way.
    assert!(
        stdout.contains("| mixed | mc-auto | 2 | 0 -> 0 | 0 -> 0 |"),
        "{stdout}"
    );
    // Seeds 0 (before only) and 3 (after only), two strategies each, are left out; the
    // sides flew different aircraft speeds.
    assert!(
        stderr.contains("2 runs only before and 2 only after are left out"),
        "{stderr}"
    );
    assert!(
        stderr.contains("run.aircraft.speed_mps (14.0 -> 16.0)"),
        "{stderr}"
    );
    assert!(stderr.contains("6 runs from 2 reports"), "{stderr}");
}

#[test]
fn compare_json_has_the_same_figures_for_scripts() {
    let (before, after) = (fixture("before/report.json"), fixture("after"));
    let out = compare(&[
        before.as_os_str(),
        after.as_os_str(),
        "--json".as_ref(),
        "--hit-cost-s".as_ref(),
        "900".as_ref(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let golden: Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("expected.json")).unwrap()).unwrap();
    assert_eq!(v, golden);
    assert_eq!(v["hit_cost_s"], 900.0);
    let row = v["groups"]
        .as_array()
        .unwrap()
        .iter()
        .find(|g| g["strategy"] == "mc-auto")
        .unwrap();
    assert_eq!(row["family"], "mixed");
    assert_eq!(row["runs"], 2);
    assert!(row["mission_time_s"]["se"].as_f64().unwrap() > 0.0, "{row}");
}

#[test]
fn a_missing_report_exits_2_naming_it() {
    let missing = fixture("no-such-dir/report.json");
    let out = compare(&[&fixture("before"), &missing]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains(&format!("cannot read {}", missing.display())),
        "{stderr}"
    );
    assert!(out.stdout.is_empty());
}

#[test]
fn an_invalid_report_exits_2_naming_it() {
    // A golden file is JSON, but not a report.
    let wrong = fixture("expected.json");
    let out = compare(&[&wrong, &fixture("after")]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains(&format!(
            "{}: not a `jink simulate` report.json",
            wrong.display()
        )),
        "{stderr}"
    );
}

#[test]
fn reports_without_a_common_run_exit_2() {
    // before flew seeds 0-2, after/seed-3 seed 3 only.
    let out = compare(&[&fixture("before"), &fixture("after/seed-3")]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("no run is on both sides (6 runs before, 2 after)"),
        "{stderr}"
    );
}

#[test]
fn one_strategy_against_another_from_one_report() {
    // before/report.json flew `none` and `mc-auto` on seeds 0-2. Paired by seed, `mc-auto`
    // flies 23.0, 10.0 and 38.7 s longer (mean 23.9 s, standard error 8.3, read off the
    // report by hand) and clears all three runs `none` hit (1, 1 and 4 hits).
    let report = fixture("before/report.json");
    let out = compare(&[
        report.as_os_str(),
        report.as_os_str(),
        "--strategies".as_ref(),
        "none,mc-auto".as_ref(),
    ]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.starts_with("Strategy `none` before against `mc-auto` after"),
        "{stdout}"
    );
    assert!(stdout.contains("| mixed | none | 3 |"), "{stdout}");
    assert!(stdout.contains("| +23.9 s (8.3) |"), "{stdout}");
    assert!(
        stdout.contains("3 runs with fewer hits after, 0 runs with more"),
        "{stdout}"
    );
    // An unknown name exits 2 naming it.
    let out = compare(&[
        report.as_os_str(),
        report.as_os_str(),
        "--strategies".as_ref(),
        "none,orakel".as_ref(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("\"orakel\""),
        "{}",
        text(&out.stderr)
    );
}
