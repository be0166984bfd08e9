//! jink's service: HTTP API, wire formats, geodesy, storage and the CLI.
//!
//! Layout: `api/` (one module per resource: router, handlers, wire types), `store/`
//! (SQL behind one type), `cli/` (subcommands). The wire formats, their validation, wire
//! timestamps and geodesy live in the `wire` crate (re-exported here as `interop`,
//! `mission`, `time`, `geodesy`).

pub mod api;
pub mod app;
pub mod cli;
pub mod error;
pub mod extract;
pub mod live;
pub mod metrics;
mod page;
mod render;
pub mod store;

pub use wire::{geodesy, interop, mission, time};
