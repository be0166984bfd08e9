//! The interop gateway end to end (issue 15): the real `jink` binary over HTTP as the
//! judges' server for interop clients (the PyPI client unchanged, hand-made 2017/2018 and
//! 2019+ requests), and as a client of an upstream judges' server (another jink, or a
//! misbehaving fake).

#[allow(dead_code)]
#[path = "../e2e/support.rs"]
mod e2e_support;

mod chain;
mod cli;
mod faults;
mod no_panic;
mod python_client;
mod support;
mod surface;
