//! Obstacle characterization and risk prediction (seed 002, "Obstacle characterization").
//!
//! Everything here works in the mission's local East-North-Up frame, in metres and
//! mission seconds. The crate knows nothing of HTTP or databases.
//!
//! - [`track`]: observations in timestamp order, duplicates, flagged jumps.
//! - [`estimate`]: velocity, heading, speed, turn samples, tightest turn radius.
//! - [`stage`]: the four stages and the tests between them.
//! - [`motion`]: each stage's motion model and particle propagation.
//! - [`replay`]: manoeuvre replay, the future drawn from stretches of the obstacle's own past.
//! - [`young`]: a young track's quadratic in time, before replay has enough past.
//! - [`leg`]: a spline tour's present leg, the cubic in time it flies to its next knot.
//! - [`risk_map`]: the time-indexed, incrementally updated risk map.
//! - [`predictor`]: the multi-obstacle [`Predictor`] tying them together.
//! - [`stats`]: chi-square and divergence helpers.

#![warn(missing_docs)]

pub mod estimate;
pub mod field;
pub mod leg;
pub mod motion;
pub mod periodic;
pub mod predictor;
pub mod replay;
pub mod risk_map;
pub mod stage;
pub mod stats;
pub mod track;
pub mod young;

pub use estimate::{Estimates, EstimatorConfig};
pub use field::{NO_BAND_HINT, NoRisk, RiskField};
pub use motion::{MotionModel, ReplayModel};
pub use periodic::{Lap, LapKind, LapPoint, PeriodicConfig};
pub use predictor::{
    ConstantVelocityField, ObstacleSummary, Predictor, PredictorConfig, RECENT_SPEED_CHORD_S,
    RECENT_SPEED_WINDOW_S, RULES_MAX_OBSTACLE_SPEED_MPS,
};
pub use replay::ReplayConfig;
pub use risk_map::{AltitudeView, Layer, RiskMap, RiskMapConfig, RiskMapError, SliceView};
pub use stage::{Stage, StageChange, StageConfig};
pub use track::{Observation, ObserveOutcome};
