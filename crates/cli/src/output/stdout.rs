//! Stdout and stderr: results go through a writer whose errors end the command (a
//! closed pipe quietly, anything else as a failure naming stdout); notes and warnings
//! on stderr never end it.

use std::io::{self, Write};
use std::sync::atomic::{AtomicU8, Ordering};

use crate::common::Failure;

/// State of stdout: 0 fine, 1 closed by the reader, 2 failed otherwise.
static STDOUT_STATE: AtomicU8 = AtomicU8::new(0);

/// Whether stdout was closed by its reader (`| head -1`): the command then ends quietly
/// with exit status 0.
pub fn stdout_closed() -> bool {
    STDOUT_STATE.load(Ordering::Relaxed) == 1
}

/// Whether a write to stdout failed for another reason (exit status 1).
pub fn stdout_failed() -> bool {
    STDOUT_STATE.load(Ordering::Relaxed) == 2
}

/// Stdout for results: buffered; its errors are remembered (see [`stdout_closed`]) and
/// name "stdout".
pub(super) fn stdout() -> impl Write {
    StdoutWriter(io::BufWriter::new(io::stdout()))
}

struct StdoutWriter(io::BufWriter<io::Stdout>);

fn remember(e: &io::Error) {
    let state = if e.kind() == io::ErrorKind::BrokenPipe {
        1
    } else {
        2
    };
    let _ = STDOUT_STATE.compare_exchange(0, state, Ordering::Relaxed, Ordering::Relaxed);
}

impl Write for StdoutWriter {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0.write(buf).inspect_err(remember)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.0.flush().inspect_err(remember)
    }
}

impl Drop for StdoutWriter {
    fn drop(&mut self) {
        // Errors at this point were already reported by an explicit flush, or the
        // command is failing anyway.
        let _ = self.0.flush().inspect_err(remember);
    }
}

/// The error for a failed stdout write: not the user's fault (exit status 1).
pub(super) fn stdout_error(e: &io::Error) -> anyhow::Error {
    remember(e);
    Failure(format!("writing stdout: {e}")).into()
}

/// Writes `text` to stdout (results: tables, JSON), with the errors of [`stdout`].
pub fn print(text: &str) -> anyhow::Result<()> {
    let mut out = stdout();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(|e| stdout_error(&e))
}

/// Pretty JSON on stdout, one trailing newline.
pub fn print_json(value: &serde_json::Value) -> anyhow::Result<()> {
    print(&(serde_json::to_string_pretty(value)? + "\n"))
}

/// A line on stderr (warnings, notes, progress); a stderr that cannot be written is
/// ignored rather than ending the command.
pub fn note(line: &str) {
    let _ = writeln!(io::stderr().lock(), "{line}");
}

/// `warning: ...` on stderr.
pub fn warn(msg: &str) {
    note(&format!("warning: {msg}"));
}
