//! End-to-end tests of issue 12 (security and overload): the real `jink` binary, its
//! tokens, TLS, limits and shutdown.

#[allow(dead_code)]
#[path = "../e2e/support.rs"]
mod support;

mod access;
mod overload;
mod server;
mod shutdown;
mod tls;
