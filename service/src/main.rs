//! `meshlod`: the command line of meshlod — local commands, the gRPC server and its client.
//!
//! The binary holds the flags (`cli`), what each command prints (`commands`), the batch runner
//! (`batch`) and the training-sample generator (`samples`); the work itself is in the
//! `meshlod_service` library and the engine. Every command validates its input and prints a
//! summary for people or, with `--json`, one JSON object on stdout. Errors go to stderr with a
//! non-zero exit code.

mod batch;
mod cli;
mod commands;
mod samples;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    match commands::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of stdout went away (`| head`): nothing to tell, as for a process that
        // SIGPIPE stops.
        Err(err)
            if err.chain().any(|cause| {
                cause.downcast_ref::<std::io::Error>().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            ExitCode::from(141)
        }
        Err(err) => {
            eprintln!("meshlod: error: {}", with_flag(&err));
            ExitCode::FAILURE
        }
    }
}

/// The error for people: where a job's error names a request field that a flag sets, the flag
/// too (`--faces (options.target_faces): …`), whether the job ran here or on a server.
fn with_flag(err: &anyhow::Error) -> String {
    let text = format!("{err:#}");
    let job = err.chain().find_map(|e| e.downcast_ref::<meshlod_service::error::JobError>());
    match job.and_then(|job| job.flag().map(|flag| (job, flag))) {
        Some((job, flag)) => text.replacen(&job.to_string(), &format!("{flag} ({}): {}", job.field, job.reason), 1),
        None => text,
    }
}
