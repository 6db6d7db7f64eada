//! Shared command-line helpers: error reporting with exit codes, angle lists.

use std::process::ExitCode;

/// A failure that is not the user's fault (exit status 1), for example an output file
/// that cannot be written. Every other error is bad usage or bad input (exit status 2).
#[derive(Debug)]
pub struct Failure(pub String);

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Failure {}

/// Print the error chain to stderr and pick the exit status (cli.md: 2 for bad usage or
/// bad input, 1 for other failures).
pub fn report(err: &anyhow::Error) -> ExitCode {
    let mut msg = format!("error: {err}");
    for cause in err.chain().skip(1) {
        msg.push_str(&format!("\n  caused by: {cause}"));
    }
    eprintln!("{msg}");
    if err.chain().any(|c| c.is::<Failure>()) {
        ExitCode::from(1)
    } else {
        ExitCode::from(2)
    }
}
