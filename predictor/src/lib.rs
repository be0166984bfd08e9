//! Obstacle characterization and risk prediction (seed 002, "Obstacle characterization").
//!
//! Everything here works in the mission's local East-North-Up frame, in metres and
//! mission seconds. The crate knows nothing of HTTP or databases.

#![warn(missing_docs)]

pub mod field;

pub use field::RiskField;
