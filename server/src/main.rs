//! The `jink` binary; everything lives in the library.

fn main() -> std::process::ExitCode {
    server::run()
}
