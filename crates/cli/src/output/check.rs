//! The checks of [`Plan::check`], made before any work starts: every output against the
//! inputs (by canonical path and by device and inode) and the other outputs, every
//! output directory against the inputs inside it and the files it holds
//! ([`owned::check_owned`]), and each target on its own (directory, parent directory,
//! extension).

use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use anyhow::bail;

use super::Failure;
use super::{Dest, Kind, Plan, owned, parent_dir};

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

impl Plan {
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
                    "{} -: a map cannot go to stdout; give a file name ending in .x3p or .txt, or a Zarr store name ending in .zarr",
                    out.flag
                ),
                Kind::ConvertedMap => bail!(
                    "{} -: a map cannot go to stdout; give a file name ending in .x3p, .sdf or .txt, or a Zarr store name ending in .zarr",
                    out.flag
                ),
                Kind::Stack => bail!(
                    "{} -: a stack cannot go to stdout; give a file name ending in .tif",
                    out.flag
                ),
                Kind::Brdf => bail!(
                    "{} -: a binary BRDF table cannot go to stdout; give a file name ending in .binary",
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
            check_target(flag, path, out.kind, out.owner.is_some())?;
            let Some(id) = Identity::of(path) else {
                continue;
            };
            if let Some(owner) = &out.owner {
                for (iflag, ipath, iid) in &inputs {
                    if iid
                        .as_ref()
                        .is_some_and(|i| i.canonical.starts_with(&id.canonical))
                    {
                        bail!(
                            "{flag} {shown} holds the input {iflag} {}: refusing to write the output directory over the run's inputs; give another directory",
                            ipath.display()
                        );
                    }
                }
                owned::check_owned(flag, path, owner)?;
            }
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
        // No output inside an output directory (the directory is replaced whole).
        for (dflag, dpath, did) in &seen {
            if !self
                .outputs
                .iter()
                .any(|o| o.owner.is_some() && o.dest == Dest::File(dpath.to_path_buf()))
            {
                continue;
            }
            for (oflag, opath, oid) in &seen {
                if oid.canonical != did.canonical && oid.canonical.starts_with(&did.canonical) {
                    bail!(
                        "{oflag} {} lies inside the output directory {dflag} {}, which is replaced whole: give it a name outside",
                        opath.display(),
                        dpath.display()
                    );
                }
            }
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
                    "{flag} {shown}: a map file must end in .x3p (ISO 25178-72) or .txt (plain text), or name a Zarr v3 store ending in .zarr"
                );
            }
        }
        Kind::ConvertedMap => {
            if !matches!(ext.as_deref(), Some("x3p" | "sdf" | "txt")) {
                bail!(
                    "{flag} {shown}: the output format is taken from the extension: .x3p (ISO 25178-72), .sdf (ISO 25178-71, text), .txt (plain text) or .zarr (a Zarr v3 store, a directory)"
                );
            }
        }
        Kind::Stack => {
            if !matches!(ext.as_deref(), Some("tif" | "tiff")) {
                bail!("{flag} {shown}: a stack file must end in .tif or .tiff (multi-page TIFF)");
            }
        }
        Kind::Brdf => {
            if ext.as_deref() != Some("binary") {
                bail!("{flag} {shown}: a MERL BRDF file must end in .binary");
            }
        }
    }
    Ok(())
}
