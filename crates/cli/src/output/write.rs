//! Atomic file writes: a temporary file beside the target, renamed into place by the
//! plan; devices and pipes are written in place.

use std::cell::Cell;
use std::ffi::OsString;
use std::fs::Permissions;
use std::io::{self, Write};
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::Path;

use super::Failure;
use super::parent_dir;

/// Whether `path` exists and is not a regular file or directory (a device, FIFO or
/// socket): such targets are written in place, never replaced.
pub(super) fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| {
        let t = m.file_type();
        t.is_char_device() || t.is_block_device() || t.is_fifo() || t.is_socket()
    })
}

/// Where a write of `path` lands: the file a symbolic link points to (so the link
/// keeps pointing at the new content, and the temporary file is made beside the real
/// file, on its file system), else `path`.
pub(super) fn real_path(path: &Path) -> std::path::PathBuf {
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
        && let Ok(real) = std::fs::canonicalize(path)
    {
        return real;
    }
    path.to_path_buf()
}

/// A temporary file next to `path`, created with the usual permissions (0666 less the
/// umask, like a plain create).
pub(super) fn temp_in(path: &Path) -> anyhow::Result<tempfile::NamedTempFile> {
    let mut prefix = OsString::from(".");
    prefix.push(path.file_name().unwrap_or_default());
    prefix.push(".");
    tempfile::Builder::new()
        .prefix(&prefix)
        .suffix(".tmp")
        .permissions(Permissions::from_mode(0o666))
        .tempfile_in(parent_dir(path))
        .map_err(|e| Failure(format!("cannot write {}: {e}", path.display())).into())
}

/// A temporary directory next to `path` (for staging a directory of outputs).
pub fn temp_dir_beside(path: &Path) -> anyhow::Result<tempfile::TempDir> {
    let mut prefix = OsString::from(".");
    prefix.push(path.file_name().unwrap_or_default());
    prefix.push(".");
    tempfile::Builder::new()
        .prefix(&prefix)
        .suffix(".tmp")
        .tempdir_in(parent_dir(path))
        .map_err(|e| Failure(format!("cannot write {}: {e}", path.display())).into())
}

/// Writes `path` with `body`: a device or pipe in place (returns `None`), anything else
/// into a complete temporary file beside it that the caller renames into place.
pub(super) fn write_file(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>,
) -> anyhow::Result<Option<tempfile::NamedTempFile>> {
    let name = path.display().to_string();
    let fail =
        |e: &dyn std::fmt::Display| anyhow::Error::new(Failure(format!("writing {name}: {e}")));
    if is_special(path) {
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| fail(&e))?;
        let mut w = Tracked::new(io::BufWriter::new(f));
        let result = body(&mut w).and_then(|()| w.flush().map_err(|e| fail(&e)));
        return w.explain(result, &name).map(|()| None);
    }
    let tmp = temp_in(path)?;
    let mut w = Tracked::new(io::BufWriter::new(tmp.as_file()));
    let result = body(&mut w).and_then(|()| w.flush().map_err(|e| fail(&e)));
    w.explain(result, &name)?;
    drop(w);
    tmp.as_file().sync_all().map_err(|e| fail(&e))?;
    Ok(Some(tmp))
}

/// A writer that remembers its first I/O error, so that a failure inside a library
/// writer is reported as what it is (exit status 1, the file named).
struct Tracked<W: Write> {
    inner: W,
    error: Cell<Option<String>>,
}

impl<W: Write> Tracked<W> {
    fn new(inner: W) -> Self {
        Self {
            inner,
            error: Cell::new(None),
        }
    }

    fn explain(&self, result: anyhow::Result<()>, name: &str) -> anyhow::Result<()> {
        match (result, self.error.take()) {
            (Ok(()), _) => Ok(()),
            (Err(_), Some(io)) => Err(Failure(format!("writing {name}: {io}")).into()),
            (Err(e), None) => Err(e),
        }
    }

    fn record<T>(&self, r: io::Result<T>) -> io::Result<T> {
        if let Err(e) = &r {
            let old = self.error.take();
            self.error.set(old.or_else(|| Some(e.to_string())));
        }
        r
    }
}

impl<W: Write> Write for Tracked<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let r = self.inner.write(buf);
        self.record(r)
    }

    fn flush(&mut self) -> io::Result<()> {
        let r = self.inner.flush();
        self.record(r)
    }
}
