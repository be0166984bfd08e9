//! Reactive LiDAR avoiders usable onboard at 20-50 Hz (seeds 000, 001, 003).
//!
//! Everything here is sensor-relative and stateless per call, so it runs the same onboard,
//! behind the HTTP API and inside the simulator:
//!
//! - [`offset`]: the Offset Algorithm (seeds 000/001): multi-radius binary frames, scan
//!   windows stepping outward from the heading, exponential frame weights, threshold
//!   decision; answers a direction, a lateral deviation and a heading change.
//! - [`scan_box`]: the seed's "scan box mechanics" variant on a 2-D occupancy image.
//! - [`pilot`]: the BlackFly Pilot (seed 001): a two-segment quadratic Bezier path out to
//!   the offset and back to the goal line, with max-deviation, snap-back and goal-funnel
//!   heuristics.
//! - [`sectors`]: the 8-region sector avoider (seed 003).
//! - [`control_loop`]: a `DataHandler` trait and the sensor -> offset -> pilot -> command
//!   loop with a start-up self-check; [`replay`] (feature `serde`) runs it on a recorded
//!   JSON-lines scan file.
//!
//! # Conventions
//!
//! Angles are degrees, 0 straight ahead, counter-clockwise positive, so *left is positive*.
//! Lateral coordinates (`x_m`, `deviation_m`) follow the same sign: positive = left.
//! `y_m` is forward. Distances are metres.
//!
//! # Example: one control cycle
//!
//! ```
//! use planner::reactive::{Beam, OffsetParams, OffsetWorkspace, PilotInput, PilotParams, Side, pilot_plan};
//!
//! // 61 beams from -60 to +60 degrees; an obstacle 1.5 m away covers -20..+8 degrees.
//! let scan: Vec<Beam> = (0..61)
//!     .map(|i| {
//!         let angle_deg = -60.0 + 2.0 * i as f64;
//!         let distance_m = if (-20.0..=8.0).contains(&angle_deg) { 1.5 } else { f64::INFINITY };
//!         Beam::new(angle_deg, distance_m)
//!     })
//!     .collect();
//! let params = OffsetParams::default().with_scan_radii_m(vec![1.0, 2.0, 5.0]);
//! let mut ws = OffsetWorkspace::new();
//! let decision = ws.decide(&scan, &params).unwrap();
//! assert_eq!(decision.direction, Some(Side::Left));
//! assert!(decision.deviation_m > 0.0);
//!
//! let input = PilotInput::new(decision.deviation_m, 5.0, 40.0);
//! let plan = pilot_plan(&input, &PilotParams::default()).unwrap();
//! let mut path = Vec::new();
//! plan.sample_into(16, &mut path);
//! assert_eq!(path.first().unwrap().y_m, 0.0);
//! ```

pub mod control_loop;
pub mod offset;
pub mod pilot;
#[cfg(feature = "serde")]
pub mod replay;
pub mod scan_box;
pub mod sectors;

pub use control_loop::{
    ControlLoop, CycleResult, DataHandler, LoopError, LoopParams, LoopReport, ScanMeta,
    SelfCheckFailure,
};
pub use offset::{
    OffsetDecision, OffsetError, OffsetParams, OffsetWorkspace, ScanWindow, frame_weight,
    offset_decide,
};
pub use pilot::{
    PathPoint, PilotError, PilotInput, PilotLimit, PilotParams, PilotPlan, pilot_plan,
};
#[cfg(feature = "serde")]
pub use replay::{ReplayError, ReplaySummary, replay};
pub use scan_box::{OccupancyGrid, ScanBoxDecision, ScanBoxError, ScanBoxParams, scan_box_decide};
pub use sectors::{SectorDecision, SectorError, SectorParams, sectors_decide};

/// One LiDAR return: bearing and measured distance.
///
/// `distance_m` may be `f64::INFINITY` or `NaN` for "no return"; each avoider documents how
/// it treats non-finite and out-of-range readings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Beam {
    /// Bearing in degrees, 0 straight ahead, counter-clockwise (left) positive.
    pub angle_deg: f64,
    /// Measured range in metres (`INFINITY`/`NaN` = no return).
    pub distance_m: f64,
}

impl Beam {
    /// A beam at `angle_deg` with range `distance_m`.
    pub const fn new(angle_deg: f64, distance_m: f64) -> Self {
        Self {
            angle_deg,
            distance_m,
        }
    }
}

/// A side of the aircraft. Left is counter-clockwise (positive angles).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Side {
    /// Counter-clockwise, positive angles and positive lateral offsets.
    Left,
    /// Clockwise, negative angles and negative lateral offsets.
    Right,
}

impl Side {
    /// `+1.0` for left, `-1.0` for right.
    pub const fn sign(self) -> f64 {
        match self {
            Side::Left => 1.0,
            Side::Right => -1.0,
        }
    }

    /// `"left"` or `"right"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
        }
    }
}

impl std::fmt::Display for Side {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Wrap an angle in degrees into `(-180, 180]`.
pub(crate) fn wrap_deg_pm180(angle_deg: f64) -> f64 {
    // fast path: most sweeps are already in range, and fmod is slow in a 360-beam loop
    if angle_deg > -180.0 && angle_deg <= 180.0 {
        return angle_deg;
    }
    let a = angle_deg.rem_euclid(360.0);
    if a > 180.0 { a - 360.0 } else { a }
}
