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
            eprintln!("meshlod: error: {}", with_flag(&format!("{err:#}")));
            ExitCode::FAILURE
        }
    }
}

/// The command-line flag of each request field an error can start with.
const FLAGS: [(&str, &str); 15] = [
    ("options.target_ratio", "--ratio"),
    ("options.target_faces", "--faces"),
    ("options.max_error", "--max-error"),
    ("options.w_search", "--w search"),
    ("options.w_auto", "--w auto"),
    ("options.w", "--w"),
    ("options.guard", "--guard"),
    ("options.distance_term", "--distance-term"),
    ("options.max_normal_change_degrees", "--max-normal-change"),
    ("target_ratio", "--ratio"),
    ("target_faces", "--faces"),
    ("etc_auto", "--etc auto"),
    ("etc", "--etc"),
    ("rounds", "--rounds"),
    ("mode", "--mode"),
];

/// An error that starts with a request field (as the jobs name them) also names the flag.
fn with_flag(message: &str) -> String {
    for (field, flag) in FLAGS {
        if let Some(rest) = message.strip_prefix(field).and_then(|r| r.strip_prefix(':')) {
            return format!("{flag} ({field}):{rest}");
        }
    }
    message.to_string()
}
