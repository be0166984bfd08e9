//! The BlackFly control loop (seed 001, section 5 "System Integration & Real-Time Loop"):
//! sensor -> offset -> pilot -> command at a fixed rate, behind a user-implemented
//! [`DataHandler`], with the seed's start-up "checksum" as [`ControlLoop::self_check`].
//!
//! Each cycle: [`DataHandler::read_scan`] fills the reusable scan buffer, the Offset
//! Algorithm ([`super::offset`]) picks a deviation, the Pilot ([`super::pilot`]) turns it
//! into a sampled Bezier path, and [`DataHandler::send_command`] receives the
//! [`CycleResult`]. After the first cycle nothing is allocated (buffers are reused).
//!
//! Start-up self-check, before the first command is sent:
//! 1. the parameters validate;
//! 2. the avoider answers two synthetic sweeps correctly (right half blocked -> LEFT, left
//!    half blocked -> RIGHT) and the pilot's path starts at the aircraft and ends on the goal
//!    line;
//! 3. the first sweep from the handler is non-empty and every bearing is finite.
//!
//! The loop ends at `max_cycles`, when the handler reports the end of its data, or when the
//! caller's stop flag is set. A sweep the avoider rejects stops the loop with the cycle
//! number ([`LoopError::Step`]); a handler that must tolerate bad sweeps filters them in
//! `read_scan`.
//!
//! # Example
//! ```
//! use planner::reactive::{Beam, ControlLoop, CycleResult, DataHandler, LoopParams, ScanMeta};
//!
//! /// A fake sensor: an obstacle ahead and to the right, forever.
//! struct Fake { sent: Vec<f64> }
//! impl DataHandler for Fake {
//!     type Error = std::convert::Infallible;
//!     fn read_scan(&mut self, scan: &mut Vec<Beam>) -> Result<Option<ScanMeta>, Self::Error> {
//!         scan.clear();
//!         scan.extend((0..61).map(|i| {
//!             let a = -60.0 + 2.0 * i as f64;
//!             Beam::new(a, if (-30.0..=2.0).contains(&a) { 1.0 } else { f64::INFINITY })
//!         }));
//!         Ok(Some(ScanMeta { t_s: 0.0, goal_distance_m: None }))
//!     }
//!     fn send_command(&mut self, r: &CycleResult) -> Result<(), Self::Error> {
//!         self.sent.push(r.decision.deviation_m);
//!         Ok(())
//!     }
//! }
//!
//! let mut params = LoopParams::default();
//! params.rate_hz = 0.0; // unpaced for the example
//! params.max_cycles = Some(3);
//! let mut fake = Fake { sent: vec![] };
//! let report = ControlLoop::new(params).unwrap().run(&mut fake, None).unwrap();
//! assert_eq!(report.cycles, 3);
//! assert!(fake.sent.iter().all(|&d| d > 0.0)); // left
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::{
    Beam, OffsetDecision, OffsetError, OffsetParams, OffsetWorkspace, PathPoint, PilotError,
    PilotInput, PilotParams, PilotPlan, Side, pilot_plan,
};

/// What the handler knows about a sweep besides the beams.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ScanMeta {
    /// Time of the sweep, seconds (any epoch; reported back).
    pub t_s: f64,
    /// Distance to the goal along the goal line, metres, if known (else the loop's default).
    pub goal_distance_m: Option<f64>,
}

/// The platform side of the loop (PX4, ROS, ArduPilot, a simulator, a recorded file).
pub trait DataHandler {
    /// The handler's own failure type.
    type Error: std::error::Error + Send + Sync + 'static;
    /// Replace `scan`'s contents with the latest sweep. `Ok(None)` = no more data; the loop
    /// ends normally.
    ///
    /// # Errors
    /// The handler's error ends the loop with [`LoopError::Handler`].
    fn read_scan(&mut self, scan: &mut Vec<Beam>) -> Result<Option<ScanMeta>, Self::Error>;
    /// Deliver one cycle's decision and path to the flight controller.
    ///
    /// # Errors
    /// The handler's error ends the loop with [`LoopError::Handler`].
    fn send_command(&mut self, result: &CycleResult) -> Result<(), Self::Error>;
}

/// Loop parameters.
///
/// Defaults: default [`OffsetParams`] and [`PilotParams`], scan range = the largest scan
/// radius, goal distance 50 m when the handler gives none, 16 samples per Bezier segment,
/// 20 Hz, no cycle limit.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct LoopParams {
    /// Offset Algorithm parameters.
    pub offset: OffsetParams,
    /// Pilot parameters.
    pub pilot: PilotParams,
    /// The pilot's scan range `l`, metres; `None` = the largest scan radius.
    pub scan_range_m: Option<f64>,
    /// Goal distance when the handler's [`ScanMeta`] has none, metres.
    pub goal_distance_m: f64,
    /// Points per Bezier segment in [`CycleResult::points`].
    pub samples_per_segment: usize,
    /// Loop rate, Hz; 0 = as fast as possible (replays, tests).
    pub rate_hz: f64,
    /// Stop after this many cycles.
    pub max_cycles: Option<u64>,
}

impl Default for LoopParams {
    fn default() -> Self {
        Self {
            offset: OffsetParams::default(),
            pilot: PilotParams::default(),
            scan_range_m: None,
            goal_distance_m: 50.0,
            samples_per_segment: 16,
            rate_hz: 20.0,
            max_cycles: None,
        }
    }
}

/// One cycle's output: the offset decision, the pilot plan and its sampled path.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct CycleResult {
    /// Cycle number, from 0.
    pub cycle: u64,
    /// The sweep's time.
    pub t_s: f64,
    /// The Offset Algorithm's decision.
    pub decision: OffsetDecision,
    /// The pilot plan (with the deviation after the heuristics; straight when there is no
    /// path, since the offset gives no deviation then).
    pub plan: PilotPlan,
    /// The sampled path, aircraft-relative.
    pub points: Vec<PathPoint>,
}

impl std::fmt::Display for CycleResult {
    /// One line: `cycle 3 t=0.150s left clear=no window_cycle=3 A_L=0.00 A_R=100.00 heading=+9.0deg deviation=+3.13m pilot_deviation=+3.13m`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = &self.decision;
        write!(
            f,
            "cycle {} t={:.3}s {} clear={} window_cycle={} A_L={:.2} A_R={:.2} heading={:+.1}deg deviation={:+.2}m pilot_deviation={:+.2}m",
            self.cycle,
            self.t_s,
            d.direction.map_or("none", Side::as_str),
            if d.way_ahead_clear { "yes" } else { "no" },
            d.cycle,
            d.aggregate_left,
            d.aggregate_right,
            d.heading_change_deg,
            d.deviation_m,
            self.plan.deviation_m,
        )
    }
}

/// Why one cycle failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StepError {
    /// The Offset Algorithm rejected the sweep or its parameters.
    #[error(transparent)]
    Offset(#[from] OffsetError),
    /// The pilot rejected its input or parameters.
    #[error(transparent)]
    Pilot(#[from] PilotError),
}

/// A failed start-up self-check. Each variant says which part misbehaved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SelfCheckFailure {
    /// The parameters are invalid.
    #[error("parameters: {0}")]
    Parameters(StepError),
    /// A parameter of the loop itself is invalid.
    #[error("loop parameter {name} = {value} is out of range")]
    LoopParameter {
        /// Field name.
        name: &'static str,
        /// The bad value.
        value: f64,
    },
    /// The avoider gave the wrong answer on a synthetic sweep.
    #[error("offset avoider answered {got:?} on a synthetic sweep, expected {expected}")]
    OffsetAnswer {
        /// Expected side.
        expected: Side,
        /// What it said.
        got: Option<Side>,
    },
    /// The pilot's path does not start at the aircraft or end on the goal line.
    #[error("pilot path does not run from the aircraft to the goal line")]
    PilotEnds,
    /// The first sweep is empty: is the sensor connected?
    #[error("the first sweep is empty")]
    EmptyFirstScan,
    /// The first sweep has a non-finite bearing.
    #[error("the first sweep's beam {index} has a non-finite bearing")]
    NonFiniteFirstScan {
        /// Beam index.
        index: usize,
    },
}

/// Why the loop stopped early.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoopError<E: std::error::Error + 'static> {
    /// The start-up self-check failed; no command was sent.
    #[error("self-check failed: {0}")]
    SelfCheck(SelfCheckFailure),
    /// A cycle failed.
    #[error("cycle {cycle}: {source}")]
    Step {
        /// Cycle number.
        cycle: u64,
        /// The failure.
        source: StepError,
    },
    /// The data handler failed.
    #[error("data handler: {0}")]
    Handler(#[source] E),
}

/// How the loop ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopEnd {
    /// `max_cycles` reached.
    MaxCycles,
    /// The handler had no more data.
    EndOfData,
    /// The stop flag was set.
    Stopped,
}

/// Counts over a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoopReport {
    /// Cycles completed (commands sent).
    pub cycles: u64,
    /// Decisions to the left (including clear-ahead first-cycle ties).
    pub left: u64,
    /// Decisions to the right.
    pub right: u64,
    /// Cycles with no path.
    pub no_path: u64,
    /// Cycles where the way ahead was clear.
    pub way_ahead_clear: u64,
    /// Cycles that took longer than the period (0 when unpaced).
    pub overruns: u64,
    /// Why the loop ended.
    pub end: LoopEnd,
}

/// The control loop with its reusable buffers.
#[derive(Debug, Clone)]
pub struct ControlLoop {
    params: LoopParams,
    offset_ws: OffsetWorkspace,
    scan: Vec<Beam>,
    result: CycleResult,
}

impl ControlLoop {
    /// A loop with these parameters, after the self-check of its own parts (steps 1-2 in the
    /// module docs).
    ///
    /// # Errors
    /// [`SelfCheckFailure`] when a parameter is invalid or a part answers wrongly.
    pub fn new(params: LoopParams) -> Result<Self, SelfCheckFailure> {
        let mut this = Self {
            params,
            offset_ws: OffsetWorkspace::new(),
            scan: Vec::new(),
            result: CycleResult {
                cycle: 0,
                t_s: 0.0,
                decision: OffsetDecision {
                    direction: None,
                    cycle: 0,
                    cycles_evaluated: 0,
                    aggregate_left: 0.0,
                    aggregate_right: 0.0,
                    window: None,
                    way_ahead_clear: false,
                    heading_change_deg: 0.0,
                    deviation_m: 0.0,
                },
                plan: PilotPlan {
                    requested_deviation_m: 0.0,
                    deviation_m: 0.0,
                    limited_by: None,
                    p0: PathPoint::default(),
                    p1: PathPoint::default(),
                    p: PathPoint::default(),
                    q: PathPoint::default(),
                    p2: PathPoint::default(),
                    cost: 0.0,
                },
                points: Vec::new(),
            },
        };
        this.self_check()?;
        Ok(this)
    }

    /// The parameters.
    pub fn params(&self) -> &LoopParams {
        &self.params
    }

    /// Check the parameters and run the avoider and pilot on synthetic inputs with known
    /// answers.
    ///
    /// # Errors
    /// The first [`SelfCheckFailure`] found.
    pub fn self_check(&mut self) -> Result<(), SelfCheckFailure> {
        let p = &self.params;
        p.offset
            .validate()
            .map_err(|e| SelfCheckFailure::Parameters(e.into()))?;
        p.pilot
            .validate()
            .map_err(|e| SelfCheckFailure::Parameters(e.into()))?;
        if !(p.goal_distance_m.is_finite() && p.goal_distance_m > 0.0) {
            return Err(SelfCheckFailure::LoopParameter {
                name: "goal_distance_m",
                value: p.goal_distance_m,
            });
        }
        if let Some(l) = p.scan_range_m
            && !(l.is_finite() && l > 0.0)
        {
            return Err(SelfCheckFailure::LoopParameter {
                name: "scan_range_m",
                value: l,
            });
        }
        if !(p.rate_hz.is_finite() && p.rate_hz >= 0.0) {
            return Err(SelfCheckFailure::LoopParameter {
                name: "rate_hz",
                value: p.rate_hz,
            });
        }

        // Synthetic sweep: 4N + 1 beams across the field of view; every beam at or right of
        // the centre is blocked in every frame (half the nearest radius away). The left
        // window at cycle 1 is clear and no right window ever is, so the answer is LEFT for
        // any threshold (T >= 100 makes cycle 0 a tie, which is LEFT too).
        let n = p.offset.window;
        let beams = 4 * n + 1;
        let centre = beams / 2;
        let half = 0.45 * p.offset.fov_deg.min(359.0);
        // half the nearest radius (and within the sensor's max range): blocked in every
        // frame, either as a reading <= every radius or as one below range_min
        let near = 0.5
            * p.offset
                .scan_radii_m
                .iter()
                .copied()
                .fold(p.offset.range_max_m, f64::min);
        let angle = |i: usize| -half + 2.0 * half * i as f64 / (beams - 1) as f64;
        let checks: &[(Side, bool)] = if p.offset.threshold < 100.0 {
            &[(Side::Left, true), (Side::Right, false)]
        } else {
            &[(Side::Left, true)]
        };
        for &(expected, block_right) in checks {
            self.scan.clear();
            self.scan.extend((0..beams).map(|i| {
                let blocked = if block_right {
                    i <= centre
                } else {
                    i >= centre
                };
                Beam::new(angle(i), if blocked { near } else { f64::INFINITY })
            }));
            let got = self
                .offset_ws
                .decide(&self.scan, &p.offset)
                .map_err(|e| SelfCheckFailure::Parameters(e.into()))?;
            if got.direction != Some(expected) {
                return Err(SelfCheckFailure::OffsetAnswer {
                    expected,
                    got: got.direction,
                });
            }
        }
        let goal = p.goal_distance_m;
        let plan = pilot_plan(&PilotInput::new(1.0, goal / 4.0, goal), &p.pilot)
            .map_err(|e| SelfCheckFailure::Parameters(e.into()))?;
        let end = plan.point_at(2.0);
        if plan.point_at(0.0) != PathPoint::new(0.0, 0.0) || end.x_m.abs() > 1e-9 || end.y_m <= 0.0
        {
            return Err(SelfCheckFailure::PilotEnds);
        }
        self.scan.clear();
        Ok(())
    }

    /// One cycle on `scan`: offset, then pilot. The result borrows the loop's buffers.
    ///
    /// # Errors
    /// [`StepError`] when the avoider or the pilot rejects the input.
    pub fn step(
        &mut self,
        cycle: u64,
        scan: &[Beam],
        meta: ScanMeta,
    ) -> Result<&CycleResult, StepError> {
        let p = &self.params;
        let decision = self.offset_ws.decide(scan, &p.offset)?;
        let scan_range_m = p
            .scan_range_m
            .unwrap_or_else(|| self.offset_ws.radii_m().last().copied().unwrap_or(1.0));
        let goal = meta.goal_distance_m.unwrap_or(p.goal_distance_m);
        let plan = pilot_plan(
            &PilotInput::new(decision.deviation_m, scan_range_m, goal),
            &p.pilot,
        )?;
        self.result.cycle = cycle;
        self.result.t_s = meta.t_s;
        self.result.decision = decision;
        self.result.plan = plan;
        plan.sample_into(p.samples_per_segment, &mut self.result.points);
        Ok(&self.result)
    }

    /// Run the loop against `handler` until `max_cycles`, the end of the handler's data, or
    /// `stop` is set. Paced at `rate_hz` (unpaced at 0).
    ///
    /// # Errors
    /// [`LoopError`]: a failed self-check of the first sweep, a rejected sweep, or the
    /// handler's own error.
    pub fn run<H: DataHandler>(
        &mut self,
        handler: &mut H,
        stop: Option<&AtomicBool>,
    ) -> Result<LoopReport, LoopError<H::Error>> {
        let period =
            (self.params.rate_hz > 0.0).then(|| Duration::from_secs_f64(1.0 / self.params.rate_hz));
        let mut report = LoopReport {
            cycles: 0,
            left: 0,
            right: 0,
            no_path: 0,
            way_ahead_clear: 0,
            overruns: 0,
            end: LoopEnd::EndOfData,
        };
        let start = Instant::now();
        let mut scan = std::mem::take(&mut self.scan);
        let outcome = loop {
            if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                break Ok(LoopEnd::Stopped);
            }
            if self.params.max_cycles.is_some_and(|m| report.cycles >= m) {
                break Ok(LoopEnd::MaxCycles);
            }
            let meta = match handler.read_scan(&mut scan) {
                Ok(Some(meta)) => meta,
                Ok(None) => break Ok(LoopEnd::EndOfData),
                Err(e) => break Err(LoopError::Handler(e)),
            };
            if report.cycles == 0 {
                if scan.is_empty() {
                    break Err(LoopError::SelfCheck(SelfCheckFailure::EmptyFirstScan));
                }
                if let Some(index) = scan.iter().position(|b| !b.angle_deg.is_finite()) {
                    break Err(LoopError::SelfCheck(SelfCheckFailure::NonFiniteFirstScan {
                        index,
                    }));
                }
            }
            let cycle = report.cycles;
            let result = match self.step(cycle, &scan, meta) {
                Ok(r) => r,
                Err(source) => break Err(LoopError::Step { cycle, source }),
            };
            match result.decision.direction {
                Some(Side::Left) => report.left += 1,
                Some(Side::Right) => report.right += 1,
                None => report.no_path += 1,
            }
            if result.decision.way_ahead_clear {
                report.way_ahead_clear += 1;
            }
            if let Err(e) = handler.send_command(result) {
                break Err(LoopError::Handler(e));
            }
            report.cycles += 1;
            if let Some(period) = period {
                let due = start + period.mul_f64(report.cycles as f64);
                let now = Instant::now();
                if now < due {
                    std::thread::sleep(due - now);
                } else {
                    report.overruns += 1;
                }
            }
        };
        self.scan = scan;
        outcome.map(|end| LoopReport { end, ..report })
    }
}

#[cfg(test)]
mod tests;
