//! Replay a recorded scan file through the control loop (seed 001 section 5's loop, offline;
//! feature `serde`). The `jink reactive --scans FILE` CLI calls [`replay`].
//!
//! # File format: JSON lines
//!
//! One sweep per line, in time order:
//!
//! ```text
//! {"t_s": 0.05, "goal_distance_m": 60.0, "scan": [{"angle_deg": -60.0, "distance_m": 12.5}, {"angle_deg": -59.0, "distance_m": null}]}
//! ```
//!
//! - `t_s` (number, seconds, required): the sweep's time;
//! - `scan` (array, required): beams `{angle_deg, distance_m}`, bearings in degrees, 0 straight
//!   ahead, counter-clockwise (left) positive; `distance_m` in metres, or `null` for "no
//!   return" (JSON has no `inf`/`NaN`), which the Offset Algorithm treats as free;
//! - `goal_distance_m` (number, optional): distance to the goal; else the loop's default.
//!
//! Blank lines and lines whose first non-blank character is `#` are skipped. The replay is
//! unpaced (`rate_hz` is ignored); `max_cycles` is honoured.
//!
//! # Example
//! ```
//! use planner::reactive::{LoopParams, replay};
//! let file = "# two sweeps\n\
//!     {\"t_s\": 0.0, \"scan\": [{\"angle_deg\": -2, \"distance_m\": null}, {\"angle_deg\": 0, \"distance_m\": null}, {\"angle_deg\": 2, \"distance_m\": null}, {\"angle_deg\": 4, \"distance_m\": null}, {\"angle_deg\": 6, \"distance_m\": null}, {\"angle_deg\": -4, \"distance_m\": null}, {\"angle_deg\": -6, \"distance_m\": null}]}\n";
//! let cycles = replay(file.as_bytes(), &LoopParams::default()).unwrap();
//! assert_eq!(cycles.len(), 1);
//! assert!(cycles[0].decision.way_ahead_clear);
//! ```

use std::io::BufRead;

use super::control_loop::{LoopEnd, StepError};
use super::{
    Beam, ControlLoop, CycleResult, DataHandler, LoopError, LoopParams, ScanMeta, SelfCheckFailure,
    Side,
};

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct WireBeam {
    angle_deg: f64,
    distance_m: Option<f64>,
}

#[derive(serde::Deserialize)]
struct WireSweep {
    t_s: f64,
    scan: Vec<WireBeam>,
    #[serde(default)]
    goal_distance_m: Option<f64>,
}

/// Why a replay failed. Line numbers are 1-based.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReplayError {
    /// Reading the file failed.
    #[error("reading the scan file: {0}")]
    Io(#[from] std::io::Error),
    /// A line is not a valid sweep: fix the line.
    #[error("line {line}: {message}")]
    Parse {
        /// Line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The loop's self-check failed (bad parameters, or the first sweep is empty or has a
    /// non-finite bearing).
    #[error("self-check failed: {0}")]
    SelfCheck(#[from] SelfCheckFailure),
    /// The avoider or pilot rejected the sweep on this line.
    #[error("line {line} (cycle {cycle}): {source}")]
    Step {
        /// Line number.
        line: usize,
        /// Cycle number.
        cycle: u64,
        /// The failure.
        source: StepError,
    },
}

#[derive(Debug, thiserror::Error)]
enum HandlerError {
    #[error(transparent)]
    Io(std::io::Error),
    #[error("line {line}: {message}")]
    Parse { line: usize, message: String },
}

struct FileHandler<R> {
    reader: R,
    buf: String,
    line: usize,
    lines_of_cycles: Vec<usize>,
    out: Vec<CycleResult>,
}

impl<R: BufRead> DataHandler for FileHandler<R> {
    type Error = HandlerError;

    fn read_scan(&mut self, scan: &mut Vec<Beam>) -> Result<Option<ScanMeta>, Self::Error> {
        loop {
            self.buf.clear();
            if self
                .reader
                .read_line(&mut self.buf)
                .map_err(HandlerError::Io)?
                == 0
            {
                return Ok(None);
            }
            self.line += 1;
            let text = self.buf.trim();
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            let sweep: WireSweep = serde_json::from_str(text).map_err(|e| HandlerError::Parse {
                line: self.line,
                message: e.to_string(),
            })?;
            if !sweep.t_s.is_finite() {
                return Err(HandlerError::Parse {
                    line: self.line,
                    message: "t_s is not finite".into(),
                });
            }
            scan.clear();
            scan.extend(
                sweep
                    .scan
                    .iter()
                    .map(|b| Beam::new(b.angle_deg, b.distance_m.unwrap_or(f64::INFINITY))),
            );
            self.lines_of_cycles.push(self.line);
            return Ok(Some(ScanMeta {
                t_s: sweep.t_s,
                goal_distance_m: sweep.goal_distance_m,
            }));
        }
    }

    fn send_command(&mut self, result: &CycleResult) -> Result<(), Self::Error> {
        self.out.push(result.clone());
        Ok(())
    }
}

/// Run every sweep of a JSON-lines scan file (format in the module docs) through the
/// control loop: self-check, then offset -> pilot per line. Unpaced.
///
/// # Errors
/// [`ReplayError`] naming the line of the first unreadable or rejected sweep.
pub fn replay<R: BufRead>(reader: R, params: &LoopParams) -> Result<Vec<CycleResult>, ReplayError> {
    let mut params = params.clone();
    params.rate_hz = 0.0;
    let mut control = ControlLoop::new(params)?;
    let mut handler = FileHandler {
        reader,
        buf: String::new(),
        line: 0,
        lines_of_cycles: Vec::new(),
        out: Vec::new(),
    };
    match control.run(&mut handler, None) {
        Ok(report) => {
            debug_assert!(matches!(
                report.end,
                LoopEnd::EndOfData | LoopEnd::MaxCycles
            ));
            Ok(handler.out)
        }
        Err(LoopError::SelfCheck(f)) => Err(ReplayError::SelfCheck(f)),
        Err(LoopError::Step { cycle, source }) => Err(ReplayError::Step {
            line: handler
                .lines_of_cycles
                .get(cycle as usize)
                .copied()
                .unwrap_or(handler.line),
            cycle,
            source,
        }),
        Err(LoopError::Handler(HandlerError::Io(e))) => Err(ReplayError::Io(e)),
        Err(LoopError::Handler(HandlerError::Parse { line, message })) => {
            Err(ReplayError::Parse { line, message })
        }
    }
}

/// Totals over a replay, for the CLI's last line.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct ReplaySummary {
    /// Cycles replayed.
    pub cycles: usize,
    /// Decisions left (including clear-ahead cycles).
    pub left: usize,
    /// Decisions right.
    pub right: usize,
    /// Cycles with no path.
    pub no_path: usize,
    /// Cycles where the way ahead was clear.
    pub way_ahead_clear: usize,
    /// Largest `|deviation_m|` the offset asked for, metres.
    pub max_abs_deviation_m: f64,
    /// Time span of the sweeps, seconds (last `t_s` - first `t_s`).
    pub duration_s: f64,
}

impl ReplaySummary {
    /// Summarise replayed cycles.
    pub fn of(cycles: &[CycleResult]) -> Self {
        let count = |s: Option<Side>| cycles.iter().filter(|c| c.decision.direction == s).count();
        Self {
            cycles: cycles.len(),
            left: count(Some(Side::Left)),
            right: count(Some(Side::Right)),
            no_path: count(None),
            way_ahead_clear: cycles.iter().filter(|c| c.decision.way_ahead_clear).count(),
            max_abs_deviation_m: cycles
                .iter()
                .map(|c| c.decision.deviation_m.abs())
                .fold(0.0, f64::max),
            duration_s: match (cycles.first(), cycles.last()) {
                (Some(a), Some(b)) => b.t_s - a.t_s,
                _ => 0.0,
            },
        }
    }
}

impl std::fmt::Display for ReplaySummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} cycles over {:.3} s: {} left ({} clear ahead), {} right, {} no path; max |deviation| {:.2} m",
            self.cycles,
            self.duration_s,
            self.left,
            self.way_ahead_clear,
            self.right,
            self.no_path,
            self.max_abs_deviation_m
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(t: f64, dist: impl Fn(i32) -> Option<f64>) -> String {
        let beams: Vec<String> = (-30..=30)
            .map(|i| {
                let a = 2 * i;
                match dist(a) {
                    Some(d) => format!("{{\"angle_deg\": {a}, \"distance_m\": {d}}}"),
                    None => format!("{{\"angle_deg\": {a}, \"distance_m\": null}}"),
                }
            })
            .collect();
        format!("{{\"t_s\": {t}, \"scan\": [{}]}}", beams.join(", "))
    }

    #[test]
    fn replays_lines_and_skips_comments() {
        let text = format!(
            "# header\n\n{}\n{}\n{}\n",
            line(0.0, |_| None),
            line(0.05, |a| (-20..=4).contains(&a).then_some(1.0)),
            line(0.1, |_| Some(0.3)),
        );
        let cycles = replay(text.as_bytes(), &LoopParams::default()).unwrap();
        let dirs: Vec<_> = cycles.iter().map(|c| c.decision.direction).collect();
        assert_eq!(dirs, vec![Some(Side::Left), Some(Side::Left), None]);
        let s = ReplaySummary::of(&cycles);
        assert_eq!(
            (s.cycles, s.left, s.right, s.no_path, s.way_ahead_clear),
            (3, 2, 0, 1, 1)
        );
        assert!((s.duration_s - 0.1).abs() < 1e-12);
    }

    #[test]
    fn errors_name_the_line() {
        let text = format!("{}\n\nnot json\n", line(0.0, |_| None));
        match replay(text.as_bytes(), &LoopParams::default()) {
            Err(ReplayError::Parse { line: 3, .. }) => {}
            other => panic!("unexpected {other:?}"),
        }
        // a sweep with every beam outside the field of view is rejected by the avoider
        let text = format!(
            "{}\n{{\"t_s\": 1, \"scan\": [{{\"angle_deg\": 170, \"distance_m\": 1}}]}}\n",
            line(0.0, |_| None)
        );
        match replay(text.as_bytes(), &LoopParams::default()) {
            Err(ReplayError::Step {
                line: 2, cycle: 1, ..
            }) => {}
            other => panic!("unexpected {other:?}"),
        }
        // an empty first sweep fails the self-check
        match replay(
            "{\"t_s\": 0, \"scan\": []}\n".as_bytes(),
            &LoopParams::default(),
        ) {
            Err(ReplayError::SelfCheck(SelfCheckFailure::EmptyFirstScan)) => {}
            other => panic!("unexpected {other:?}"),
        }
    }
}
