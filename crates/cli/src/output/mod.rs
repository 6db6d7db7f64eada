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

mod stdout;
mod write;

use std::io::Write;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use anyhow::bail;

pub use stdout::{note, print, print_json, stdout_closed, stdout_failed, warn};
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

/// Identity of an existing file: canonical path and (device, inode).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Identity {
    canonical: PathBuf,
    inode: Option<(u64, u64)>,
}

impl Identity {
    /// The identity of `path`; for a file that does not exist yet, its canonical parent
    /// joined with its name (so `./new.csv` and `new.csv` still compare equal).
    fn of(path: &Path) -> Option<Self> {
        if let Ok(meta) = std::fs::metadata(path) {
            return Some(Self {
                canonical: std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
                inode: Some((meta.dev(), meta.ino())),
            });
        }
        let name = path.file_name()?;
        let parent = parent_dir(path);
        let canonical = std::fs::canonicalize(parent).ok()?.join(name);
        Some(Self {
            canonical,
            inode: None,
        })
    }

    fn same(&self, other: &Self) -> bool {
        self.canonical == other.canonical
            || matches!((self.inode, other.inode), (Some(a), Some(b)) if a == b)
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

    /// Checks every registered output (module docs); errors are usage errors (exit 2).
    pub fn check(&self) -> anyhow::Result<()> {
        for out in self.outputs.iter().filter(|o| o.dest == Dest::Stdout) {
            match out.kind {
                Kind::Table => {}
                Kind::Plot => bail!(
                    "{} -: a plot cannot go to stdout; give a file name ending in .svg or .png",
                    out.flag
                ),
                Kind::Map => bail!(
                    "{} -: a map cannot go to stdout; give a file name ending in .x3p or .txt",
                    out.flag
                ),
                Kind::ConvertedMap => bail!(
                    "{} -: a map cannot go to stdout; give a file name ending in .x3p, .sdf or .txt",
                    out.flag
                ),
                Kind::Stack => bail!(
                    "{} -: a stack cannot go to stdout; give a file name ending in .tif",
                    out.flag
                ),
            }
        }
        if self.stdout_users.len() > 1 {
            bail!(
                "{} both write to stdout: give the table a file name (--out FILE)",
                self.stdout_users.join(" and ")
            );
        }
        let inputs: Vec<(&str, &Path, Option<Identity>)> = self
            .inputs
            .iter()
            .map(|(f, p)| (f.as_str(), p.as_path(), Identity::of(p)))
            .collect();
        let mut seen: Vec<(&str, &Path, Identity)> = Vec::new();
        for out in &self.outputs {
            let Dest::File(path) = &out.dest else {
                continue;
            };
            let shown = path.display();
            let flag = out.flag.as_str();
            check_target(flag, path, out.kind, out.dir)?;
            let Some(id) = Identity::of(path) else {
                continue;
            };
            for (iflag, ipath, iid) in &inputs {
                if iid.as_ref().is_some_and(|i| i.same(&id)) {
                    bail!(
                        "{flag} {shown} is the input {iflag} {}: refusing to overwrite an input; give another output name",
                        ipath.display()
                    );
                }
            }
            for (oflag, opath, oid) in &seen {
                if oid.same(&id) {
                    bail!(
                        "{oflag} {} and {flag} {shown} are the same file: give each output its own name",
                        opath.display()
                    );
                }
            }
            seen.push((flag, path, id));
        }
        Ok(())
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

/// Checks one output target: not a directory (unless a directory is wanted), an
/// existing parent directory, a known extension. A target the system could not write
/// (a directory, a missing parent) is a failure (exit status 1), as a failed write
/// would be; a wrong name is a usage error (exit status 2).
fn check_target(flag: &str, path: &Path, kind: Kind, dir: bool) -> anyhow::Result<()> {
    let shown = path.display();
    if path.as_os_str().is_empty() {
        bail!("{flag}: empty file name");
    }
    let meta = std::fs::metadata(path).ok();
    if dir {
        if meta.as_ref().is_some_and(|m| !m.is_dir()) {
            return Err(Failure(format!(
                "cannot write {flag} {shown}: exists and is not a directory"
            ))
            .into());
        }
    } else if meta.as_ref().is_some_and(std::fs::Metadata::is_dir)
        || path.as_os_str().to_string_lossy().ends_with('/')
    {
        return Err(Failure(format!(
            "cannot write {flag} {shown}: it is a directory; give a file name"
        ))
        .into());
    }
    let parent = parent_dir(path);
    if !parent.is_dir() {
        return Err(Failure(format!(
            "cannot write {flag} {shown}: the directory {} does not exist",
            parent.display()
        ))
        .into());
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match kind {
        Kind::Table => {}
        Kind::Plot => {
            if !matches!(ext.as_deref(), Some("svg" | "png")) {
                bail!("{flag} {shown}: a plot file must end in .svg or .png");
            }
        }
        Kind::Map => {
            if !matches!(ext.as_deref(), Some("x3p" | "txt")) {
                bail!(
                    "{flag} {shown}: a map file must end in .x3p (ISO 25178-72) or .txt (plain text)"
                );
            }
        }
        Kind::ConvertedMap => {
            if !matches!(ext.as_deref(), Some("x3p" | "sdf" | "txt")) {
                bail!(
                    "{flag} {shown}: the output format is taken from the extension: .x3p (ISO 25178-72), .sdf (ISO 25178-71, text) or .txt (plain text)"
                );
            }
        }
        Kind::Stack => {
            if !matches!(ext.as_deref(), Some("tif" | "tiff")) {
                bail!("{flag} {shown}: a stack file must end in .tif or .tiff (multi-page TIFF)");
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
