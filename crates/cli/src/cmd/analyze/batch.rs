//! A batch of samples in one output directory: `DIR/<name>/` per sample (each an owned
//! report directory, swapped in when that sample is complete) and the comparison
//! across samples (`samples.csv`, `index.md`, `index.html`) written when the whole
//! batch is. The directory's marker (`output::owned`) lists the comparison files and
//! the sample folders, so a rerun recognises it and nothing else in it is touched.
//!
//! Order of the writes: before the first sample is swapped in, the previous batch's
//! comparison files are removed (a half-finished batch then never shows a comparison
//! of other runs' samples); each sample folder is swapped in when complete (an
//! interrupted batch keeps the samples it finished, and a rerun reuses their caches);
//! at the end the comparison is written and the sample folders of the previous batch
//! that this batch does not hold are removed, so the folder holds exactly this batch.

use std::path::{Path, PathBuf};

use anyhow::bail;

use super::OWNER;
use crate::common::Failure;
use crate::output::owned::{MARKER, Marker, check_owned, read_marker};

/// The owner recorded in a batch directory's marker.
pub const BATCH_OWNER: &str = "analyze (batch)";

/// The batch's own files in its directory.
pub const COMPARISON_FILES: [&str; 3] = ["samples.csv", "index.md", "index.html"];

/// Refuses sample names that cannot each have their own folder in a batch directory:
/// two equal names (also ignoring case: one folder on case-insensitive file systems,
/// macOS and Windows) and names of the batch's own files. Called before any work.
pub fn check_names(names: &[(&str, &Path)]) -> anyhow::Result<()> {
    for (k, (name, file)) in names.iter().enumerate() {
        let lower = name.to_lowercase();
        if let Some(own) = COMPARISON_FILES
            .iter()
            .chain(std::iter::once(&MARKER))
            .find(|f| f.to_lowercase() == lower)
        {
            bail!(
                "sample {} is named `{name}`, the name of the batch's own file `{own}` in --out: give it another `name`",
                file.display()
            );
        }
        if let Some((other, ofile)) = names[..k].iter().find(|(o, _)| o.to_lowercase() == lower) {
            if other == name {
                bail!(
                    "samples {} and {} are both named `{name}`: give one of them another `name`",
                    ofile.display(),
                    file.display(),
                );
            }
            bail!(
                "samples {} and {} are named `{other}` and `{name}`, one folder on file systems that ignore case (macOS, Windows): give one of them another `name`",
                ofile.display(),
                file.display(),
            );
        }
    }
    Ok(())
}

/// The batch directory while its samples are written.
pub struct Batch {
    dir: PathBuf,
    /// The sample folders listed in the marker (previous batch's and this one's).
    dirs: Vec<String>,
    /// The sample folders of this batch.
    this: Vec<String>,
}

fn fail(p: &Path, e: &dyn std::fmt::Display) -> anyhow::Error {
    Failure(format!("cannot write {}: {e}", p.display())).into()
}

impl Batch {
    /// Takes the directory `dir` (checked by the plan: missing, empty, or an earlier
    /// batch holding nothing else): creates it, or removes the previous comparison
    /// files, and writes its marker.
    pub fn open(dir: &Path) -> anyhow::Result<Self> {
        if !dir.exists() {
            std::fs::create_dir_all(dir).map_err(|e| fail(dir, &e))?;
        }
        let previous = read_marker(dir).unwrap_or_default();
        for f in previous
            .files
            .iter()
            .filter(|f| COMPARISON_FILES.contains(&f.as_str()))
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
            dirs: previous.dirs,
            this: Vec::new(),
        };
        batch.mark(&[])?;
        Ok(batch)
    }

    /// Records that the folder of sample `name` is in place.
    pub fn added(&mut self, name: &str) -> anyhow::Result<()> {
        if !self.dirs.iter().any(|d| d == name) {
            self.dirs.push(name.to_owned());
        }
        self.this.push(name.to_owned());
        self.mark(&[])
    }

    /// Writes the marker listing `files` and the sample folders, atomically.
    fn mark(&self, files: &[&str]) -> anyhow::Result<()> {
        let marker = Marker::new(
            BATCH_OWNER,
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

    /// After the comparison files are in place: removes the previous batch's sample
    /// folders this batch does not hold (each checked again to hold only what its
    /// report wrote) and writes the final marker.
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
                check_owned("--out", &p, OWNER)?;
                std::fs::remove_dir_all(&p).map_err(|e| fail(&p, &e))?;
            }
        }
        self.dirs.clone_from(&self.this);
        self.mark(&COMPARISON_FILES)
    }
}
