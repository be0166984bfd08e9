//! jink's service: HTTP API, wire formats, geodesy, storage and the CLI.
//!
//! Layout: `api/` (one module per resource: router, handlers, wire types), `store/`
//! (SQL behind one type), `interop` and `mission` (formats and validation), `geodesy`
//! (WGS84 <-> local ENU), `cli/` (subcommands).

pub mod api;
pub mod app;
pub mod cli;
pub mod error;
pub mod extract;
pub mod geodesy;
pub mod interop;
pub mod metrics;
pub mod mission;
pub mod predict;
pub mod store;
pub mod time;
