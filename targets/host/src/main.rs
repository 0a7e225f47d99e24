//! The `hapticgen` command line: a thin shell over the host library's [`hapticgen_host::cli`].
//!
//! `check` validates a model, `generate` prints its Rust code, `eval` evaluates the derived
//! quantities of eq. (1)–(2) at one state, and `stats` counts the operations of each emitted
//! function, `simulate` runs a model in closed loop with the runtime's controllers and writes
//! a CSV trace and plots, and `paper` reproduces the experiments of the paper's section 6
//! with figures and a report (every command: `hapticgen --help`). This file only parses the
//! command line (the grammar is `hapticgen_host::cli::args`), runs the command
//! (`hapticgen_host::cli::run`) and prints its error. Exit code 0 on success; on failure a
//! diagnostic (with file, line and column for a model) on standard error and exit code 1 (2
//! for bad command-line usage, clap's).

use std::process::ExitCode;

use clap::Parser;
use hapticgen_host::cli::{self, Cli};

fn main() -> ExitCode {
    match cli::run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("{error}");
            ExitCode::from(error.exit_code())
        }
    }
}
