//! Stdout and stderr: results go through a writer whose errors end the command (a
//! closed pipe quietly, anything else as a failure naming stdout); notes and warnings
//! on stderr never end it.

use std::io::{self, Write};
use std::sync::atomic::{AtomicU8, Ordering};

use super::Failure;

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

/// Pretty JSON on stdout, one trailing newline, every object's keys in sorted order (the
/// order serde_json keeps by itself unless its `preserve_order` feature is on, which
/// the `zarrs` crate turns on for the whole build: the outputs stay as they were).
pub fn print_json(value: &serde_json::Value) -> anyhow::Result<()> {
    let mut value = value.clone();
    value.sort_all_objects();
    print(&(serde_json::to_string_pretty(&value)? + "\n"))
}

/// [`print_json`] of an object whose entry `key` is written by `rows`: its value as JSON
/// text at the indentation of a top-level entry (e.g. a [`crate::tables::JsonText`]
/// table), and it may set the entries that come after `key` in the object's order (what
/// is learnt while the rows are written, such as warnings). The rows of a large grid are
/// streamed to stdout, never held as text or as a `Value` tree. Nothing is written
/// before `rows` writes, so an error before its first rows leaves stdout untouched.
/// Without an entry `key`, this is [`print_json`] (`rows` is not called).
pub fn print_json_with(
    value: serde_json::Value,
    key: &str,
    rows: impl FnOnce(&mut dyn Write, &mut serde_json::Value) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut value = value;
    value.sort_all_objects();
    if !value.as_object().is_some_and(|m| m.contains_key(key)) {
        return print_json(&value);
    }
    let mut stdout = stdout();
    // Small writes (the entries around the rows) are copies into this buffer.
    let mut out = io::BufWriter::with_capacity(1 << 16, &mut stdout);
    write_json_with(&mut out, value, key, rows).map_err(|e| match e {
        Written::Io(e) => stdout_error(&e),
        Written::Rows(e) if stdout_failed() || stdout_closed() => {
            anyhow::Error::from(Failure(format!("writing stdout: {e:#}")))
        }
        Written::Rows(e) => e,
    })
}

/// Why [`write_json_with`] failed: writing around the rows, or the rows.
enum Written {
    Io(io::Error),
    Rows(anyhow::Error),
}

/// [`print_json_with`] to `out` (an object with an entry `key`), flushed.
fn write_json_with(
    out: &mut impl Write,
    mut value: serde_json::Value,
    key: &str,
    rows: impl FnOnce(&mut dyn Write, &mut serde_json::Value) -> anyhow::Result<()>,
) -> Result<(), Written> {
    let keys: Vec<String> = value
        .as_object()
        .map(|m| m.keys().cloned().collect())
        .unwrap_or_default();
    let at = keys.iter().position(|k| k == key).unwrap_or(keys.len());
    let mut head = b"{".to_vec();
    for (i, k) in keys[..at].iter().enumerate() {
        push_entry(&mut head, k, &value[k], i == 0);
    }
    head.extend_from_slice(if at == 0 { b"\n  " } else { b",\n  " });
    push_key(&mut head, key);
    let mut lazy = Lazy {
        head: Some(head),
        out: &mut *out,
    };
    rows(&mut lazy, &mut value).map_err(Written::Rows)?;
    // Entries the rows set are in key order too (see `print_json`).
    value.sort_all_objects();
    let mut tail = lazy.head.take().unwrap_or_default();
    for k in keys.iter().skip(at + 1) {
        push_entry(&mut tail, k, &value[k], false);
    }
    tail.extend_from_slice(b"\n}\n");
    out.write_all(&tail)
        .and_then(|()| out.flush())
        .map_err(Written::Io)
}

/// A JSON object key, quoted and escaped as `serde_json` writes it, and `: `.
fn push_key(out: &mut Vec<u8>, key: &str) {
    // Writing a string to memory cannot fail.
    let _ = serde_json::to_writer(&mut *out, key);
    out.extend_from_slice(b": ");
}

/// One entry of a pretty top-level object as `serde_json` writes it: `value`'s own
/// pretty text indented one level (a JSON text has line breaks only between its tokens,
/// never inside a string, so each gets the two spaces of the level).
fn push_entry(out: &mut Vec<u8>, key: &str, value: &serde_json::Value, first: bool) {
    out.extend_from_slice(if first { b"\n  " } else { b",\n  " });
    push_key(out, key);
    // Serialising a `Value` to memory cannot fail.
    let text = serde_json::to_vec_pretty(value).unwrap_or_default();
    for &c in &text {
        out.push(c);
        if c == b'\n' {
            out.extend_from_slice(b"  ");
        }
    }
}

/// A writer that writes `head` before the first bytes written to it.
struct Lazy<'a, W: Write> {
    head: Option<Vec<u8>>,
    out: &'a mut W,
}

impl<W: Write> Write for Lazy<'_, W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if let Some(head) = self.head.take() {
            self.out.write_all(&head)?;
        }
        self.out.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        if self.head.is_some() {
            return Ok(());
        }
        self.out.flush()
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
    use super::write_json_with;
    use serde_json::json;

    /// The streamed object is the text `serde_json` writes for the same object with the
    /// entry in place (its own pretty writer of the whole tree), entries the rows set
    /// afterwards included; nothing is written when the rows fail before writing.
    #[test]
    fn a_streamed_entry_keeps_its_place_and_the_text() {
        let value = json!({"b": 1, "rows": null, "a": [1.5, null], "z": {"k": "v"}, "w": [], "e\"sc": "x\ny"});
        let rows = json!([{"x": 1.0, "y": [2.5e-7, {}]}, {"x": -0.0}]);
        let mut streamed = Vec::new();
        let written = write_json_with(&mut streamed, value.clone(), "rows", |out, v| {
            let text = serde_json::to_string_pretty(&rows)
                .unwrap()
                .replace('\n', "\n  ");
            out.write_all(text.as_bytes())?;
            v["z"] = json!({"k": ["late", 2]});
            Ok(())
        });
        assert!(written.is_ok());
        let mut whole = value.clone();
        whole["rows"] = rows.clone();
        whole["z"] = json!({"k": ["late", 2]});
        assert_eq!(
            String::from_utf8(streamed).unwrap(),
            serde_json::to_string_pretty(&whole).unwrap() + "\n"
        );
        // The entry first or last among the keys.
        for key in ["a", "z"] {
            let mut streamed = Vec::new();
            let written = write_json_with(&mut streamed, value.clone(), key, |out, _| {
                Ok(out.write_all(b"7")?)
            });
            assert!(written.is_ok());
            let mut whole = value.clone();
            whole[key] = json!(7);
            assert_eq!(
                String::from_utf8(streamed).unwrap(),
                serde_json::to_string_pretty(&whole).unwrap() + "\n"
            );
        }
        let mut streamed = Vec::new();
        let failed = write_json_with(&mut streamed, value, "rows", |_, _| {
            Err(anyhow::anyhow!("no rows"))
        });
        assert!(failed.is_err());
        assert!(streamed.is_empty());
    }
}
