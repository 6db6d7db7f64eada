//! An owned directory of owned sub-folders (`analyze`'s batch: one report folder per
//! sample and the comparison files beside them). The directory's marker ([`super::owned`])
//! lists the directory's own files and the sub-folders, so a rerun recognises it and
//! nothing else in it is touched.
//!
//! Order of the writes: [`Batch::open`] removes the previous run's own files (a
//! half-finished run then never shows files of another run); each sub-folder is swapped
//! in by its command when complete and recorded by [`Batch::added`] (an interrupted run
//! keeps the folders it finished); [`Batch::finish`], after the command has written the
//! own files, removes the previous run's sub-folders this run does not hold, each
//! checked again to hold only what its own marker lists.

use std::path::{Path, PathBuf};

use super::Failure;
use super::owned::{MARKER, Marker, check_owned, read_marker};

/// The batch directory while its sub-folders are written.
pub struct Batch {
    dir: PathBuf,
    /// The owner recorded in the directory's marker.
    owner: &'static str,
    /// The directory's own files (written by the command before [`Batch::finish`]).
    files: &'static [&'static str],
    /// The owner recorded in each sub-folder's marker.
    sub_owner: &'static str,
    /// The sub-folders listed in the marker (previous run's and this one's).
    dirs: Vec<String>,
    /// The sub-folders of this run.
    this: Vec<String>,
}

/// Whether `name` is one normal path component (no separator, not `.` or `..`, not
/// absolute, not empty).
fn is_plain_name(name: &str) -> bool {
    let mut c = Path::new(name).components();
    matches!(
        (c.next(), c.next()),
        (Some(std::path::Component::Normal(n)), None) if n == std::ffi::OsStr::new(name)
    )
}

fn fail(p: &Path, e: &dyn std::fmt::Display) -> anyhow::Error {
    Failure(format!("cannot write {}: {e}", p.display())).into()
}

impl Batch {
    /// Takes the directory `dir` (checked by the plan beforehand: missing, empty, or an
    /// earlier output of `owner` holding nothing else): creates it, or removes the
    /// previous run's `files`, and writes its marker.
    pub fn open(
        dir: &Path,
        owner: &'static str,
        files: &'static [&'static str],
        sub_owner: &'static str,
    ) -> anyhow::Result<Self> {
        if !dir.exists() {
            std::fs::create_dir_all(dir).map_err(|e| fail(dir, &e))?;
        }
        let previous = read_marker(dir).unwrap_or_default();
        // The marker is a file anyone can edit: only plain folder names inside `dir`
        // are taken from it (never `..`, an absolute path or a path with separators).
        if let Some(bad) = previous.dirs.iter().find(|d| !is_plain_name(d)) {
            anyhow::bail!(
                "{}: lists `{bad}` as a sample folder, which is not a plain folder name inside {}; remove the directory or its marker by hand",
                dir.join(MARKER).display(),
                dir.display()
            );
        }
        for f in previous
            .files
            .iter()
            .filter(|f| files.contains(&f.as_str()))
        {
            let p = dir.join(f);
            match std::fs::remove_file(&p) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(fail(&p, &e)),
            }
        }
        let batch = Self {
            dir: dir.to_path_buf(),
            owner,
            files,
            sub_owner,
            dirs: previous.dirs,
            this: Vec::new(),
        };
        batch.mark(&[])?;
        Ok(batch)
    }

    /// Records that the sub-folder `name` is in place.
    pub fn added(&mut self, name: &str) -> anyhow::Result<()> {
        if !self.dirs.iter().any(|d| d == name) {
            self.dirs.push(name.to_owned());
        }
        self.this.push(name.to_owned());
        self.mark(&[])
    }

    /// Writes the marker listing `files` and the sub-folders, atomically.
    fn mark(&self, files: &[&str]) -> anyhow::Result<()> {
        let marker = Marker::new(
            self.owner,
            files.iter().map(|f| (*f).to_owned()).collect(),
            self.dirs.clone(),
        );
        let path = self.dir.join(MARKER);
        let mut tmp = tempfile::Builder::new()
            .prefix(".marker.")
            .tempfile_in(&self.dir)
            .map_err(|e| fail(&path, &e))?;
        std::io::Write::write_all(&mut tmp, marker.to_json().as_bytes())
            .map_err(|e| fail(&path, &e))?;
        tmp.persist(&path).map_err(|e| fail(&path, &e.error))?;
        Ok(())
    }

    /// After the directory's own files are in place: removes the previous run's
    /// sub-folders this run does not hold (each checked again to hold only what its
    /// marker lists) and writes the final marker.
    pub fn finish(mut self) -> anyhow::Result<()> {
        let stale: Vec<String> = self
            .dirs
            .iter()
            .filter(|d| !self.this.contains(d))
            .cloned()
            .collect();
        for d in &stale {
            let p = self.dir.join(d);
            if p.exists() {
                check_owned("--out", &p, self.sub_owner)?;
                std::fs::remove_dir_all(&p).map_err(|e| fail(&p, &e))?;
            }
        }
        self.dirs.clone_from(&self.this);
        self.mark(self.files)
    }
}

#[cfg(test)]
mod tests {
    use super::is_plain_name;

    #[test]
    fn only_plain_folder_names_are_taken_from_a_marker() {
        for ok in ["a", "sample-1", "x.y"] {
            assert!(is_plain_name(ok), "{ok}");
        }
        for bad in ["", ".", "..", "/abs/other", "a/b", "../up", "a/", "./a"] {
            assert!(!is_plain_name(bad), "{bad}");
        }
    }
}
