//! Path planning for fixed-wing UAVs on SUAS-style missions.
//!
//! Mission geometry is in the local ENU frame in metres. `reactive` holds the onboard
//! LiDAR avoiders (seeds 000, 001, 003).

#![warn(missing_docs)]

pub mod reactive;
