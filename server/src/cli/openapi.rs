//! `jink openapi`: print the OpenAPI document.

use std::io::Write;
use std::process::ExitCode;

/// Prints the document to stdout.
pub fn run() -> ExitCode {
    let mut out = std::io::stdout().lock();
    match out.write_all(crate::api::openapi_json().as_bytes()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("jink openapi: {e}");
            ExitCode::FAILURE
        }
    }
}
