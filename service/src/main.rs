//! `meshlod`: command-line front end of the meshlod engine.
//!
//! Every subcommand validates its input, calls the engine, and prints a human summary or, with
//! `--json`, one JSON object on stdout. Errors go to stderr with a non-zero exit code.

mod batch;
mod commands;
mod remote;
mod samples;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = commands::Cli::parse();
    match commands::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("meshlod: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
