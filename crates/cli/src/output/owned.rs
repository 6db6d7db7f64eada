//! Output directories a command owns: `analyze --out DIR` (a sample's report, or a
//! batch), `reproduce --out DIR`, `segment --overlay DIR`, `fit --paint --plot DIR`.
//!
//! Such a directory is built whole in a temporary directory beside it and swapped in
//! when complete (an atomic exchange where the system has one, Linux `renameat2` and
//! macOS `renamex_np`; else two renames), so it always holds either the previous run's
//! files or this run's, never a mixture, and never a file this run did not write.
//!
//! A directory may only be replaced when this run would not lose anything by it: it is
//! missing, empty, or a previous output of the same command, recognised by the
//! [`MARKER`] file that command wrote into it and that lists every file it wrote. An
//! existing directory without the marker (a user's data folder, `--out .`), with the
//! marker of another command, or holding any file the marker does not list (notes added
//! to a report) is refused before any work, naming what it holds.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::bail;
use serde::{Deserialize, Serialize};

use super::Failure;
use super::parent_dir;

/// The marker file of an owned directory (JSON: [`Marker`]).
pub const MARKER: &str = ".flakescatter-output.json";

/// What an owned directory's [`MARKER`] holds.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Marker {
    /// The command that wrote the directory (`analyze`, `reproduce`, ...).
    pub written_by: String,
    /// The program version that wrote it.
    pub version: String,
    /// Every file written, relative, `/`-separated (the marker itself not listed).
    pub files: Vec<String>,
    /// Owned subdirectories (each with its own marker), e.g. the samples of a batch.
    #[serde(default)]
    pub dirs: Vec<String>,
}

impl Marker {
    /// A marker of `written_by` for `files` (sorted) and `dirs`.
    pub fn new(written_by: &str, mut files: Vec<String>, dirs: Vec<String>) -> Self {
        files.sort();
        Self {
            written_by: written_by.to_owned(),
            version: env!("CARGO_PKG_VERSION").to_owned(),
            files,
            dirs,
        }
    }

    /// The marker as JSON text.
    pub fn to_json(&self) -> String {
        // A struct of strings always serialises.
        serde_json::to_string_pretty(self).unwrap_or_default() + "\n"
    }
}

/// The marker of `dir`, if it has a readable one.
pub fn read_marker(dir: &Path) -> Option<Marker> {
    let text = fs::read_to_string(dir.join(MARKER)).ok()?;
    serde_json::from_str(&text).ok()
}

/// Every entry under `dir` (not following symbolic links), relative and
/// `/`-separated, with whether it is a directory; in name order.
pub(super) fn tree(dir: &Path) -> anyhow::Result<Vec<(String, bool)>> {
    fn walk(root: &Path, rel: &str, out: &mut Vec<(String, bool)>) -> std::io::Result<()> {
        let here = if rel.is_empty() {
            root.to_path_buf()
        } else {
            root.join(rel)
        };
        let mut entries: Vec<_> = fs::read_dir(&here)?.collect::<Result<_, _>>()?;
        entries.sort_by_key(fs::DirEntry::file_name);
        for e in entries {
            let name = e.file_name().to_string_lossy().into_owned();
            let path = if rel.is_empty() {
                name
            } else {
                format!("{rel}/{name}")
            };
            let is_dir = e.file_type()?.is_dir();
            out.push((path.clone(), is_dir));
            if is_dir {
                walk(root, &path, out)?;
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out)
        .map_err(|e| Failure(format!("cannot read the directory {}: {e}", dir.display())))?;
    Ok(out)
}

/// Up to three names of `items`, and how many more.
fn some_of(items: &[String]) -> String {
    let mut s = items
        .iter()
        .take(3)
        .map(|p| format!("`{p}`"))
        .collect::<Vec<_>>()
        .join(", ");
    if items.len() > 3 {
        s.push_str(&format!(" and {} more", items.len() - 3));
    }
    s
}

/// The entries of `dir` its marker does not account for: not the marker, not a listed
/// file, not a directory holding a listed file, not inside a listed owned
/// subdirectory (those are checked with their own markers: their unaccounted entries
/// come back prefixed with the subdirectory).
fn unaccounted(dir: &Path, marker: &Marker) -> anyhow::Result<Vec<String>> {
    let mut out = Vec::new();
    for (path, is_dir) in tree(dir)? {
        if path == MARKER || marker.files.contains(&path) {
            continue;
        }
        if marker
            .dirs
            .iter()
            .any(|d| path == *d || path.starts_with(&format!("{d}/")))
        {
            continue;
        }
        let prefix = format!("{path}/");
        if is_dir && marker.files.iter().any(|f| f.starts_with(&prefix)) {
            continue;
        }
        out.push(if is_dir { prefix } else { path });
    }
    for sub in &marker.dirs {
        let p = dir.join(sub);
        if fs::symlink_metadata(&p).is_err() {
            continue;
        }
        match read_marker(&p) {
            Some(m) => out.extend(
                unaccounted(&p, &m)?
                    .into_iter()
                    .map(|x| format!("{sub}/{x}")),
            ),
            None => out.push(format!("{sub}/")),
        }
    }
    Ok(out)
}

/// Checks that the directory `dir` (the output `flag`) may be replaced by an output of
/// `owner` (module docs); a missing directory may. Refusals are usage errors (exit 2).
pub fn check_owned(flag: &str, dir: &Path, owner: &str) -> anyhow::Result<()> {
    let shown = dir.display();
    if fs::metadata(dir).is_err() {
        return Ok(());
    }
    let entries = tree(dir)?;
    if entries.is_empty() {
        return Ok(());
    }
    let Some(marker) = read_marker(dir) else {
        let names: Vec<String> = entries
            .iter()
            .filter(|(p, _)| !p.contains('/'))
            .map(|(p, d)| if *d { format!("{p}/") } else { p.clone() })
            .collect();
        bail!(
            "{flag} {shown}: the directory exists and holds files that no `flakescatter {owner}` wrote ({}); refusing to replace it: give a new or empty directory",
            some_of(&names)
        );
    };
    if marker.written_by != owner {
        bail!(
            "{flag} {shown}: the directory holds the output of `flakescatter {}`, not of `flakescatter {owner}`; refusing to replace it: give a new or empty directory",
            marker.written_by
        );
    }
    let extra = unaccounted(dir, &marker)?;
    if !extra.is_empty() {
        bail!(
            "{flag} {shown}: the directory is an earlier output of `flakescatter {owner}` but also holds {} that it did not write (not listed in its {MARKER}); refusing to replace the directory and lose them: move them out, or give another directory",
            some_of(&extra)
        );
    }
    Ok(())
}

/// The path an owned directory is swapped at: an existing symbolic link to a directory
/// is followed (the link keeps pointing at the new output).
pub fn real_target(dir: &Path) -> PathBuf {
    if fs::symlink_metadata(dir).is_ok_and(|m| m.file_type().is_symlink()) {
        fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf())
    } else {
        dir.to_path_buf()
    }
}

/// Exchanges the directories `a` and `b` atomically where the system can.
#[cfg(any(target_os = "linux", target_os = "android", target_vendor = "apple"))]
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
        Ok(()) => Ok(true),
        Err(e)
            if e == rustix::io::Errno::INVAL
                || e == rustix::io::Errno::NOSYS
                || e == rustix::io::Errno::NOTSUP =>
        {
            Ok(false)
        }
        Err(e) => Err(e.into()),
    }
}

/// Exchanges the directories `a` and `b` atomically where the system can.
#[cfg(not(any(target_os = "linux", target_os = "android", target_vendor = "apple")))]
fn exchange(_a: &Path, _b: &Path) -> std::io::Result<bool> {
    Ok(false)
}

/// Puts the complete directory `staged` in place of `target` (module docs): renamed
/// there when `target` is missing or empty, else exchanged with it and the previous
/// output removed. On failure `target` is as it was and `staged` is removed.
pub fn swap_in(staged: &Path, target: &Path) -> anyhow::Result<()> {
    let target = real_target(target);
    let fail = |e: &dyn std::fmt::Display| {
        let _ = fs::remove_dir_all(staged);
        anyhow::Error::from(Failure(format!("cannot write {}: {e}", target.display())))
    };
    // A missing target, or an empty directory, is replaced by a plain rename.
    if fs::rename(staged, &target).is_ok() {
        return Ok(());
    }
    if !target.is_dir() {
        return Err(fail(&"exists and is not a directory"));
    }
    match exchange(staged, &target) {
        Ok(true) => {
            // `staged` now holds the previous output.
            let _ = fs::remove_dir_all(staged);
            return Ok(());
        }
        Ok(false) => {}
        Err(e) => return Err(fail(&e)),
    }
    // No atomic exchange: the previous output is renamed aside, then the new one in.
    let aside = tempfile::Builder::new()
        .prefix(&format!(
            ".{}.old.",
            target.file_name().unwrap_or_default().to_string_lossy()
        ))
        .tempdir_in(parent_dir(&target))
        .map_err(|e| fail(&e))?
        .keep();
    fs::rename(&target, &aside).map_err(|e| {
        let _ = fs::remove_dir(&aside);
        fail(&e)
    })?;
    if let Err(e) = fs::rename(staged, &target) {
        let _ = fs::rename(&aside, &target);
        return Err(fail(&e));
    }
    let _ = fs::remove_dir_all(&aside);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fs-owned-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn write_owned(dir: &Path, owner: &str, files: &[&str]) {
        for f in files {
            let p = dir.join(f);
            fs::create_dir_all(p.parent().unwrap()).unwrap();
            fs::write(p, f).unwrap();
        }
        let m = Marker::new(
            owner,
            files.iter().map(|s| (*s).to_owned()).collect(),
            vec![],
        );
        fs::write(dir.join(MARKER), m.to_json()).unwrap();
    }

    /// Missing and empty directories may be replaced; a previous output of the same
    /// command may, unless it holds a file its marker does not list (also in a
    /// subdirectory, also an empty directory); a folder without the marker or with
    /// another command's marker may not.
    #[test]
    fn only_a_previous_output_of_the_same_command_may_be_replaced() {
        let d = scratch("check");
        assert!(check_owned("--out", &d.join("new"), "analyze").is_ok());
        fs::create_dir(d.join("empty")).unwrap();
        assert!(check_owned("--out", &d.join("empty"), "analyze").is_ok());
        let r = d.join("report");
        fs::create_dir(&r).unwrap();
        write_owned(&r, "analyze", &["a.csv", "cache/models.json"]);
        assert!(check_owned("--out", &r, "analyze").is_ok());
        let e = check_owned("--out", &r, "reproduce")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`flakescatter analyze`, not of `flakescatter reproduce`"),
            "{e}"
        );
        for extra in ["notes.txt", "cache/mine.json", "empty/"] {
            let p = r.join(extra);
            if extra.ends_with('/') {
                fs::create_dir(&p).unwrap();
            } else {
                fs::write(&p, "x").unwrap();
            }
            let e = check_owned("--out", &r, "analyze").unwrap_err().to_string();
            assert!(e.contains(&format!("`{extra}`")), "{e}");
            if extra.ends_with('/') {
                fs::remove_dir(&p).unwrap();
            } else {
                fs::remove_file(&p).unwrap();
            }
        }
        let user = d.join("data");
        fs::create_dir(&user).unwrap();
        fs::write(user.join("curves.csv"), "x").unwrap();
        let e = check_owned("--out", &user, "analyze")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`curves.csv`") && e.contains("refusing"), "{e}");
        let _ = fs::remove_dir_all(&d);
    }

    /// A swap leaves exactly the new files (the previous output removed), through a
    /// symbolic link too (the link then points at the new output).
    #[test]
    fn a_swap_replaces_the_whole_directory() {
        let d = scratch("swap");
        let r = d.join("report");
        fs::create_dir(&r).unwrap();
        write_owned(&r, "analyze", &["old.csv", "sub/old.png"]);
        for target in [r.clone(), d.join("link")] {
            if target != r {
                std::os::unix::fs::symlink(&r, &target).unwrap();
            }
            let stage = tempfile::tempdir_in(&d).unwrap().keep();
            fs::write(stage.join("new.csv"), "n").unwrap();
            swap_in(&stage, &target).unwrap();
            let t = tree(&r).unwrap();
            assert_eq!(t, vec![("new.csv".to_owned(), false)]);
            assert!(!stage.exists());
        }
        let mut left: Vec<_> = fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["link", "report"]);
        let _ = fs::remove_dir_all(&d);
    }
}
