//! End-to-end tests: the real `jink` binary on a free port, over HTTP, against SQLite and
//! PostgreSQL (`name::sqlite`, `name::postgres`).

mod support;

mod compare;
mod demo;
mod durability;
mod errors;
mod live;
mod missions;
mod operator;
mod plans;
mod predictor;
mod reactive;
mod service;
mod simulate;
mod telemetry;
mod walkthrough;
