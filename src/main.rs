//! The `sinscal` binary: the command line (`cli`) over the numerical core
//! (`sinscal_core`) and the server (`sinscal_server`).

mod cli;

use clap::Parser;

/// A failed command prints its message and the chain of causes, one line,
/// and exits with 1. Not `main() -> Result`: that prints the error's Debug
/// form, which carries a backtrace whenever `RUST_BACKTRACE` is set, and a
/// user's mistake (a missing file, a bad flag value) is not a crash.
fn main() -> std::process::ExitCode {
    match cli::run(cli::Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
