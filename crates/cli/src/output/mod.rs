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
//!   written in place. An output named through a symbolic link replaces the file the
//!   link points to (the link stays).
//! * Stdout is written through [`stdout`], whose errors end the command: a closed pipe
//!   (`| head -1`) ends it quietly with exit status 0, any other error (a full disk) is
//!   exit status 1 with a message naming "stdout".
//! * Output directories (`analyze --out`, `reproduce --out`, `segment --overlay`,
//!   `fit --paint --plot`) are owned by their command ([`owned`]): built whole beside
//!   the target and swapped in by [`Plan::finish`]; an existing directory is replaced
//!   only when it is empty or an earlier output of the same command holding nothing
//!   else, and never when an input of the run lies inside it.
//! * [`Plan::finish`] prints one line on stderr naming the files written
//!   (`wrote out.csv (1405 rows), plot.png`).

pub mod batch;
mod check;
mod failure;
pub mod owned;
pub mod progress;
pub mod scratch;
mod stdout;
mod write;

use std::io::Write;
use std::path::{Path, PathBuf};

pub use stdout::{note, print, print_json, print_json_with, stdout_closed, stdout_failed, warn};
use stdout::{stdout, stdout_error};
pub use write::temp_dir_beside;
use write::{is_special, real_path, temp_in, write_file};

pub use failure::Failure;

/// What kind of file an output is, for the extension check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A table (CSV) or text: any name.
    Table,
    /// A plot: `.svg` or `.png`.
    Plot,
    /// A height or intensity map: `.x3p`, `.txt` or a `.zarr` store ([`Plan::map_output`]).
    Map,
    /// A height map written by `convert`: `.x3p`, `.sdf`, `.txt` or a `.zarr` store.
    ConvertedMap,
    /// A confocal z-stack: `.tif` or `.tiff` (multi-page TIFF).
    Stack,
    /// A tabulated BRDF: `.binary` (MERL).
    Brdf,
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
    /// For an output directory, the command that owns it ([`owned`]).
    owner: Option<String>,
}

/// A complete output directory waiting to be swapped in by [`Plan::finish`].
#[derive(Debug)]
struct StagedDir {
    stage: tempfile::TempDir,
    target: PathBuf,
    flag: String,
    owner: String,
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
    /// Complete temporary directories, swapped into place by [`Plan::finish`].
    staged_dirs: Vec<StagedDir>,
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
            owner: None,
        });
        Some(dest)
    }

    /// Registers an output directory (`reproduce --out DIR`) owned by the command
    /// `owner` (the name its marker records, [`owned`]).
    pub fn output_dir(&mut self, flag: &str, path: &Path, owner: &str) {
        self.outputs.push(Output {
            flag: flag.to_owned(),
            dest: Dest::File(path.to_path_buf()),
            kind: Kind::Table,
            owner: Some(owner.to_owned()),
        });
    }

    /// Registers a map output (`kind` [`Kind::Map`] or [`Kind::ConvertedMap`]): a file,
    /// or, for a name ending in `.zarr`, a Zarr store: a directory owned by the command
    /// `owner` ([`Plan::output_dir`]), so that it is written whole or not at all and
    /// only an empty directory or an earlier store of the same command is replaced.
    pub fn map_output(&mut self, flag: &str, path: Option<&Path>, kind: Kind, owner: &str) {
        match path {
            Some(p) if flakescatter::io::zarr::has_zarr_extension(p) => {
                self.output_dir(flag, p, owner);
            }
            _ => {
                self.output(flag, path, kind);
            }
        }
    }

    /// Writes a map output registered with [`Plan::map_output`] by a function that
    /// writes the file or store at the path it is given: a temporary file renamed into
    /// place, or, for a `.zarr` store, a temporary directory beside it swapped in by
    /// [`Plan::finish`] (with the owner's marker listing every file written).
    pub fn write_map_output(
        &mut self,
        flag: &str,
        path: &Path,
        owner: &str,
        body: impl FnOnce(&Path) -> anyhow::Result<()>,
        detail: Option<String>,
    ) -> anyhow::Result<()> {
        if !flakescatter::io::zarr::has_zarr_extension(path) {
            return self.write_via_path(path, body, detail);
        }
        let name = path.display();
        let stage = temp_dir_beside(&owned::real_target(path))?;
        // The stage is empty: the store is written into it, then the marker beside.
        body(stage.path()).map_err(|e| match e.downcast::<Failure>() {
            Ok(f) => anyhow::Error::from(f),
            Err(e) => anyhow::Error::from(Failure(format!("writing {name}: {e:#}"))),
        })?;
        let fail = |e: &dyn std::fmt::Display| {
            anyhow::Error::from(Failure(format!("cannot write {name}: {e}")))
        };
        let files = owned::tree(stage.path())?
            .into_iter()
            .filter_map(|(rel, is_dir)| (!is_dir).then_some(rel))
            .collect();
        let marker = owned::Marker::new(owner, files, Vec::new());
        std::fs::write(stage.path().join(owned::MARKER), marker.to_json()).map_err(|e| fail(&e))?;
        self.staged_dirs.push(StagedDir {
            stage,
            target: path.to_path_buf(),
            flag: flag.to_owned(),
            owner: owner.to_owned(),
        });
        self.wrote(path, detail);
        Ok(())
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
                let real = real_path(path);
                if let Some(tmp) = write_file(&real, body)? {
                    self.staged.push((tmp, real));
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
        let real = real_path(path);
        if is_special(&real) {
            body(&real)?;
        } else {
            let tmp = temp_in(&real)?;
            body(tmp.path()).map_err(|e| match e.downcast::<Failure>() {
                Ok(f) => anyhow::Error::from(f),
                Err(e) => anyhow::Error::from(Failure(format!("writing {name}: {e:#}"))),
            })?;
            self.staged.push((tmp, real));
        }
        self.wrote(path, detail);
        Ok(())
    }

    /// Writes the files `(path relative to dir, bytes)` as the directory `dir`
    /// (registered with [`Plan::output_dir`] as `flag`, owned by `owner`): the
    /// directory is built whole beside `dir`, with its [`owned::MARKER`], and swapped
    /// in by [`Plan::finish`]. `detail` goes into the "wrote" line.
    pub fn write_dir(
        &mut self,
        flag: &str,
        dir: &Path,
        owner: &str,
        files: &[(PathBuf, Vec<u8>)],
        detail: Option<String>,
    ) -> anyhow::Result<()> {
        let stage = self.stage_dir(dir, owner, files)?;
        self.staged_dirs.push(StagedDir {
            stage,
            target: dir.to_path_buf(),
            flag: flag.to_owned(),
            owner: owner.to_owned(),
        });
        self.wrote(dir, detail);
        Ok(())
    }

    /// A temporary directory beside `dir` holding `files` and the marker of `owner`.
    fn stage_dir(
        &self,
        dir: &Path,
        owner: &str,
        files: &[(PathBuf, Vec<u8>)],
    ) -> anyhow::Result<tempfile::TempDir> {
        let fail = |p: &Path, e: &dyn std::fmt::Display| {
            anyhow::Error::from(Failure(format!("cannot write {}: {e}", p.display())))
        };
        let stage = temp_dir_beside(&owned::real_target(dir))?;
        let mut listed = Vec::with_capacity(files.len());
        for (rel, bytes) in files {
            let path = stage.path().join(rel);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| fail(&dir.join(rel), &e))?;
            }
            std::fs::write(&path, bytes).map_err(|e| fail(&dir.join(rel), &e))?;
            listed.push(
                rel.components()
                    .map(|c| c.as_os_str().to_string_lossy())
                    .collect::<Vec<_>>()
                    .join("/"),
            );
        }
        let marker = owned::Marker::new(owner, listed, Vec::new());
        std::fs::write(stage.path().join(owned::MARKER), marker.to_json())
            .map_err(|e| fail(&dir.join(owned::MARKER), &e))?;
        Ok(stage)
    }

    /// Records a file written outside [`Plan::write`] (e.g. a directory of figures).
    pub fn wrote(&mut self, path: &Path, detail: Option<String>) {
        self.wrote.push(match detail {
            Some(d) => format!("{} ({d})", path.display()),
            None => path.display().to_string(),
        });
    }

    /// Renames every staged file into place and swaps every staged directory in, then
    /// prints the one "wrote" line on stderr (if any file was written). Until this is
    /// called no output file exists; dropping the plan instead removes the temporary
    /// files and directories.
    pub fn finish(self) -> anyhow::Result<()> {
        // Checked again: a directory may have changed while the command worked.
        for d in &self.staged_dirs {
            owned::check_owned(&d.flag, &d.target, &d.owner)?;
        }
        for (tmp, path) in self.staged {
            tmp.persist(&path)
                .map_err(|e| Failure(format!("cannot write {}: {}", path.display(), e.error)))?;
        }
        for d in self.staged_dirs {
            owned::swap_in(&d.stage.keep(), &d.target)?;
        }
        if !self.wrote.is_empty() {
            note(&format!("wrote {}", self.wrote.join(", ")));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
