//! Closed-loop simulation of missions against moving obstacles, scored as the judges did.

#![warn(missing_docs)]
