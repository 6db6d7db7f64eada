//! Error reporting with exit codes (docs/cli.md "Exit status").

use std::process::ExitCode;

use crate::output::{self, Failure};

/// Print the error chain to stderr and pick the exit status (cli.md: 2 for bad usage or
/// bad input, 1 for other failures). A stdout closed by its reader ends the command
/// quietly with status 0. A cause already said by an outer message is not repeated.
pub fn report(err: &anyhow::Error) -> ExitCode {
    if output::stdout_closed() {
        return ExitCode::SUCCESS;
    }
    let mut msg = format!("error: {err}");
    for cause in err.chain().skip(1) {
        // A cause whose text an outer message already holds is said once.
        let text = cause.to_string();
        if !msg.contains(&text) {
            msg.push_str(&format!("\n  caused by: {text}"));
        }
    }
    output::note(&msg);
    if output::stdout_failed() || err.chain().any(|c| c.is::<Failure>()) {
        ExitCode::from(1)
    } else {
        ExitCode::from(2)
    }
}

/// clap's own ends: help and version text (`--help`, `-h`, `--version`, `help CMD`) go
/// to stdout through the output layer, so a failed write is exit status 1 with a
/// message naming stdout and a closed pipe ends quietly with 0, as for every output;
/// usage errors go to stderr with clap's status (2).
pub fn clap_exit(e: &clap::Error) -> ExitCode {
    if e.use_stderr() {
        let _ = e.print();
        return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
    }
    let rendered = e.render();
    let text = if std::io::IsTerminal::is_terminal(&std::io::stdout()) {
        rendered.ansi().to_string()
    } else {
        rendered.to_string()
    };
    match output::print(&text) {
        Ok(()) => ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(0)),
        Err(err) => report(&err),
    }
}
