//! Error reporting with exit codes (docs/cli.md "Exit status").

use std::process::ExitCode;

use crate::output;

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
/// bad input, 1 for other failures). A stdout closed by its reader ends the command
/// quietly with status 0.
pub fn report(err: &anyhow::Error) -> ExitCode {
    if output::stdout_closed() {
        return ExitCode::SUCCESS;
    }
    let mut msg = format!("error: {err}");
    for cause in err.chain().skip(1) {
        msg.push_str(&format!("\n  caused by: {cause}"));
    }
    output::note(&msg);
    if output::stdout_failed() || err.chain().any(|c| c.is::<Failure>()) {
        ExitCode::from(1)
    } else {
        ExitCode::from(2)
    }
}
