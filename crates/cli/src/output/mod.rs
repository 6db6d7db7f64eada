//! The one output layer every subcommand writes through (docs/cli.md "Outputs").
//!
//! * [`Plan`] is filled before any work starts: the inputs a command reads and the
//!   outputs it will write. [`Plan::check`] refuses an output that is an input (same
//!   file by canonical path or by device and inode, so `./a`, `a`, symbolic and hard
//!   links are all caught), two outputs naming the same file, two outputs on stdout, a
//!   directory where a file is wanted, a missing parent directory and an unknown
//!   extension for plots and maps.
//! * Files are written atomically: into a temporary file in the target's directory,
//!   renamed into place when complete, so a failure leaves nothing behind and a crash
//!   never leaves half a file. Devices and pipes (`/dev/null`, `/dev/full`, a FIFO) are
//!   written in place.
//! * Stdout is written through [`stdout`], whose errors end the command: a closed pipe
//!   (`| head -1`) ends it quietly with exit status 0, any other error (a full disk) is
//!   exit status 1 with a message naming "stdout".
//! * [`Plan::finish`] prints one line on stderr naming the files written
//!   (`wrote out.csv (1405 rows), plot.png`).

mod check;
mod stdout;
mod write;

use std::io::Write;
use std::path::{Path, PathBuf};

pub use stdout::{note, print, print_json, print_json_with, stdout_closed, stdout_failed, warn};
use stdout::{stdout, stdout_error};
pub use write::temp_dir_beside;
use write::{is_special, temp_in, write_file};

use crate::common::Failure;

/// What kind of file an output is, for the extension check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A table (CSV) or text: any name.
    Table,
    /// A plot: `.svg` or `.png`.
    Plot,
    /// A height or intensity map: `.x3p` or `.txt`.
    Map,
    /// A height map written by `convert`: `.x3p`, `.sdf` or `.txt`.
    ConvertedMap,
    /// A confocal z-stack: `.tif` or `.tiff` (multi-page TIFF).
    Stack,
}

/// Where an output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Dest {
    /// Standard output.
    Stdout,
    /// A file.
    File(PathBuf),
}

impl Dest {
    /// The name used in messages: `stdout` or the path as given.
    pub fn name(&self) -> String {
        match self {
            Self::Stdout => "stdout".into(),
            Self::File(p) => p.display().to_string(),
        }
    }
}

/// The directory a file path lives in (`.` for a bare name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// One registered output.
#[derive(Debug)]
struct Output {
    flag: String,
    dest: Dest,
    kind: Kind,
    dir: bool,
}

/// The inputs and outputs of one command, checked before any work starts.
#[derive(Debug, Default)]
pub struct Plan {
    inputs: Vec<(String, PathBuf)>,
    outputs: Vec<Output>,
    stdout_users: Vec<String>,
    wrote: Vec<String>,
    /// Complete temporary files, renamed into place by [`Plan::finish`].
    staged: Vec<(tempfile::NamedTempFile, PathBuf)>,
    /// Complete temporary directories, renamed into place by [`Plan::finish`].
    staged_dirs: Vec<(tempfile::TempDir, PathBuf)>,
}

impl Plan {
    /// An empty plan.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers an input file (named by its flag, e.g. `--measured` or `MAP`).
    pub fn input(&mut self, flag: &str, path: &Path) {
        self.inputs.push((flag.to_owned(), path.to_path_buf()));
    }

    /// Registers an optional output file (`-` = stdout) and returns where it goes.
    pub fn output(&mut self, flag: &str, path: Option<&Path>, kind: Kind) -> Option<Dest> {
        let path = path?;
        let dest = if path.as_os_str() == "-" {
            Dest::Stdout
        } else {
            Dest::File(path.to_path_buf())
        };
        if dest == Dest::Stdout {
            self.stdout_users.push(format!("{flag} -"));
        }
        self.outputs.push(Output {
            flag: flag.to_owned(),
            dest: dest.clone(),
            kind,
            dir: false,
        });
        Some(dest)
    }

    /// Registers an output directory (`reproduce --out DIR`).
    pub fn output_dir(&mut self, flag: &str, path: &Path) {
        self.outputs.push(Output {
            flag: flag.to_owned(),
            dest: Dest::File(path.to_path_buf()),
            kind: Kind::Table,
            dir: true,
        });
    }

    /// The table of a command whose table goes to stdout unless `--out FILE` or `--json`
    /// is given: `--out -`, or neither `--out` nor `--json`, is stdout.
    pub fn table(&mut self, flag: &str, out: Option<&Path>, json: bool) -> Option<Dest> {
        match out {
            Some(p) => self.output(flag, Some(p), Kind::Table),
            None if json => None,
            None => {
                self.stdout_users.push("the table".into());
                Some(Dest::Stdout)
            }
        }
    }

    /// Registers a use of stdout other than a file flag (`--json`, a printed table).
    pub fn stdout(&mut self, what: &str) {
        self.stdout_users.push(what.to_owned());
    }

    /// Writes `dest` with `body`: stdout through [`stdout`], a file atomically. `detail`
    /// (e.g. `1405 rows`) goes into the "wrote" line.
    pub fn write(
        &mut self,
        dest: &Dest,
        body: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>,
        detail: Option<String>,
    ) -> anyhow::Result<()> {
        match dest {
            Dest::Stdout => {
                let mut out = stdout();
                body(&mut out).map_err(|e| {
                    if stdout_failed() || stdout_closed() {
                        anyhow::Error::from(Failure(format!("writing stdout: {e:#}")))
                    } else {
                        e
                    }
                })?;
                out.flush().map_err(|e| stdout_error(&e))
            }
            Dest::File(path) => {
                if let Some(tmp) = write_file(path, body)? {
                    self.staged.push((tmp, path.clone()));
                }
                self.wrote(path, detail);
                Ok(())
            }
        }
    }

    /// Writes the file `path` by a function that takes a path (library writers that
    /// open the file themselves): it is given a temporary path in the same directory,
    /// renamed into place when the function succeeds.
    pub fn write_via_path(
        &mut self,
        path: &Path,
        body: impl FnOnce(&Path) -> anyhow::Result<()>,
        detail: Option<String>,
    ) -> anyhow::Result<()> {
        let name = path.display();
        if is_special(path) {
            body(path)?;
        } else {
            let tmp = temp_in(path)?;
            body(tmp.path()).map_err(|e| match e.downcast::<Failure>() {
                Ok(f) => anyhow::Error::from(f),
                Err(e) => anyhow::Error::from(Failure(format!("writing {name}: {e:#}"))),
            })?;
            self.staged.push((tmp, path.to_path_buf()));
        }
        self.wrote(path, detail);
        Ok(())
    }

    /// Writes the files `(path relative to dir, bytes)` into the directory `dir`
    /// (registered with [`Plan::output_dir`]): a new directory is built whole beside it
    /// and renamed into place by [`Plan::finish`]; into an existing one each file is
    /// written atomically (subdirectories created as needed), other files left as they
    /// are. `detail` goes into the "wrote" line.
    pub fn write_dir(
        &mut self,
        dir: &Path,
        files: &[(PathBuf, Vec<u8>)],
        detail: Option<String>,
    ) -> anyhow::Result<()> {
        let fail = |p: &Path, e: &dyn std::fmt::Display| {
            anyhow::Error::from(Failure(format!("cannot write {}: {e}", p.display())))
        };
        if dir.is_dir() {
            for (rel, bytes) in files {
                let path = dir.join(rel);
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| fail(parent, &e))?;
                }
                if let Some(tmp) = write_file(&path, |w| Ok(w.write_all(bytes)?))? {
                    self.staged.push((tmp, path));
                }
            }
        } else {
            let stage = temp_dir_beside(dir)?;
            for (rel, bytes) in files {
                let path = stage.path().join(rel);
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| fail(parent, &e))?;
                }
                std::fs::write(&path, bytes).map_err(|e| fail(&dir.join(rel), &e))?;
            }
            self.staged_dirs.push((stage, dir.to_path_buf()));
        }
        self.wrote(dir, detail);
        Ok(())
    }

    /// Records a file written outside [`Plan::write`] (e.g. a directory of figures).
    pub fn wrote(&mut self, path: &Path, detail: Option<String>) {
        self.wrote.push(match detail {
            Some(d) => format!("{} ({d})", path.display()),
            None => path.display().to_string(),
        });
    }

    /// Renames every staged file into place, then prints the one "wrote" line on
    /// stderr (if any file was written). Until this is called no output file exists;
    /// dropping the plan instead removes the temporary files.
    pub fn finish(self) -> anyhow::Result<()> {
        for (tmp, path) in self.staged {
            tmp.persist(&path)
                .map_err(|e| Failure(format!("cannot write {}: {}", path.display(), e.error)))?;
        }
        for (stage, path) in self.staged_dirs {
            let staged = stage.keep();
            std::fs::rename(&staged, &path).map_err(|e| {
                let _ = std::fs::remove_dir_all(&staged);
                Failure(format!("cannot write {}: {e}", path.display()))
            })?;
        }
        if !self.wrote.is_empty() {
            note(&format!("wrote {}", self.wrote.join(", ")));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
