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

/// [`print_json`] of an object whose entry `key` is `rows` instead of what `value`
/// holds there (a placeholder that fixes its place among the sorted keys), streamed to
/// stdout: the rows of a large grid are never held as text or as a `Value` tree.
pub fn print_json_with(
    value: &serde_json::Value,
    key: &str,
    rows: &impl serde::Serialize,
) -> anyhow::Result<()> {
    let Some(map) = value.as_object() else {
        return print_json(value);
    };
    let mut stdout = stdout();
    // serde_json writes in small pieces: a buffer in front keeps each one a copy.
    let mut out = io::BufWriter::with_capacity(1 << 16, &mut stdout);
    let written = serde_json::to_writer_pretty(&mut out, &Substituted { map, key, rows })
        .map_err(|e| {
            io::Error::new(
                e.io_error_kind().unwrap_or(io::ErrorKind::Other),
                e.to_string(),
            )
        })
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    written.map_err(|e| stdout_error(&e))
}

/// A JSON object with one entry's value replaced, in the object's own key order.
struct Substituted<'a, T> {
    map: &'a serde_json::Map<String, serde_json::Value>,
    key: &'a str,
    rows: &'a T,
}

impl<T: serde::Serialize> serde::Serialize for Substituted<'_, T> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = serializer.serialize_map(Some(self.map.len()))?;
        for (k, v) in self.map {
            if k == self.key {
                m.serialize_entry(k, self.rows)?;
            } else {
                m.serialize_entry(k, v)?;
            }
        }
        m.end()
    }
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

#[cfg(test)]
mod tests {
    use super::Substituted;
    use serde_json::json;

    /// The substituted object is the text of the same object with the entry replaced
    /// in a `Value` (serde_json's own writer of the whole tree).
    #[test]
    fn a_substituted_entry_keeps_its_place_and_the_text() {
        let mut value = json!({"b": 1, "rows": null, "a": [1.5, null], "z": {"k": "v"}});
        let rows = vec![json!({"x": 1.0}), json!({"x": 2.5e-7})];
        let map = value.as_object().unwrap().clone();
        let streamed = serde_json::to_string_pretty(&Substituted {
            map: &map,
            key: "rows",
            rows: &rows,
        })
        .unwrap();
        value["rows"] = serde_json::Value::Array(rows);
        assert_eq!(streamed, serde_json::to_string_pretty(&value).unwrap());
    }
}
