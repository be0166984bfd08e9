//! `jink demo --flights`: flights in real time over HTTP (interop obstacle snapshots and
//! telemetry at 5 Hz, a plan a second flown while the aircraft flies on), each scored the
//! judges' way, beside the simulator's strategies flown in process on the same scenarios.

use std::process::{Command, Output};

fn demo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_jink"))
        .arg("demo")
        .args(["--port", "0", "--exit"])
        .args(args)
        .env("RUST_LOG", "warn")
        .output()
        .unwrap()
}

/// The table row whose first cell is `client`, as its cells.
fn row<'a>(stdout: &'a str, client: &str) -> Vec<&'a str> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(&format!("| {client} |")))
        .unwrap_or_else(|| panic!("no row for {client} in\n{stdout}"));
    line.trim_matches('|').split('|').map(str::trim).collect()
}

#[test]
fn judged_flights_in_real_time_print_each_score_and_a_table_beside_the_oracle() {
    let out = demo(&[
        "--flights",
        "2",
        "--seed",
        "3",
        "--duration",
        "8",
        "--obstacles",
        "10",
        "--compare",
        "oracle",
        "--aircraft-speed",
        "18",
        "--max-bank-deg",
        "43.3",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for seed in [3, 4] {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("jink demo: seed {seed}, mission ")))
            .unwrap_or_else(|| panic!("no line for seed {seed} in\n{stdout}"));
        assert!(
            line.contains(", 0 failed requests,") && line.contains("; judged: "),
            "{line}"
        );
        // 8 s is a small part of the mission: no path ratio for a flight cut short.
        assert!(line.contains("path ratio - (not finished)"), "{line}");
    }
    let http = row(&stdout, "jink over HTTP, real time");
    let oracle = row(&stdout, "`oracle` (in process, same scenarios)");
    for r in [&http, &oracle] {
        assert_eq!(r[1], "2", "two flights: {r:?}");
        // Both flew the 8 s asked for (the in-process runs are cut to the same length),
        // scored on the Webster Field mission's 14 waypoints each.
        let mean_s: f64 = r[7].parse().unwrap();
        assert!((7.5..=9.5).contains(&mean_s), "{r:?}");
        assert!(r[5].ends_with("/ 28"), "{r:?}");
        assert_eq!(r[6], "-", "flights cut short have no path ratio: {r:?}");
    }
}

#[test]
fn a_bad_demo_flag_is_refused_naming_it() {
    for (args, names) in [
        (&["--compare", "warp-drive"][..], "warp-drive"),
        (&["--compare", "server"][..], "server"),
        (&["--aircraft-speed", "1"][..], "--aircraft-speed"),
        (&["--max-bank-deg", "80"][..], "--max-bank-deg"),
    ] {
        let out = demo(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(stderr.contains(names), "{args:?}: {stderr}");
    }
}
