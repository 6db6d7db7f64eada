//! Maps pooled twice (issue 52, item 7): two map files of one pool that hold the same
//! data — the same file by two names (a symbolic or hard link, `..`), or two files with
//! byte-identical content (a copy). Pooled, such a pair counts one measurement twice:
//! flake counts double and the between-map interval shrinks as if a second, independent
//! map agreed with the first.
//!
//! [`find_duplicate_maps`] compares the files of the sources' height maps (z-stacks
//! too): first their identity ([`flakescatter_io::files::same_file`]), then, among files
//! of equal length only, the SHA-256 of their bytes. Callers refuse a duplicate by
//! default and allow it on request (the command line's `--allow-duplicate-maps`, the
//! manifest key `maps.allow_duplicates`).

use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

use flakescatter_io::files::{ReadFileError, file_len, same_file, sha256_file};

use super::MapSource;

/// Why two map files are one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sameness {
    /// The same file by two names (link, `..`, hard link).
    SameFile,
    /// Two files with byte-identical content, of this SHA-256 (hex).
    SameContent(String),
}

/// Two sources whose height maps are the same data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DuplicateMaps {
    /// The index of the first, in the order given.
    pub first: usize,
    /// The index of the second (later) one.
    pub second: usize,
    /// The first one's file.
    pub first_path: PathBuf,
    /// The second one's file.
    pub second_path: PathBuf,
    /// Why they are one.
    pub why: Sameness,
}

impl fmt::Display for DuplicateMaps {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (a, b) = (self.first_path.display(), self.second_path.display());
        match &self.why {
            Sameness::SameFile => write!(f, "{b} is the same file as {a}"),
            Sameness::SameContent(h) => {
                write!(f, "{b} is byte-identical to {a} (SHA-256 {h})")
            }
        }
    }
}

/// Whether the files `a` and `b` are the same data: the same file by two names, or
/// byte-identical (equal length, then equal SHA-256); `None` when they differ or either
/// cannot be read (its reader then says why). Used to refuse a map given as its own
/// intensity image (issue 52, item 6) by any name or as a copy.
#[must_use]
pub fn same_data(a: &Path, b: &Path) -> Option<Sameness> {
    if a == b || same_file(a, b) {
        return Some(Sameness::SameFile);
    }
    match (file_len(a), file_len(b)) {
        (Some(x), Some(y)) if x == y => {}
        _ => return None,
    }
    match (sha256_file(a), sha256_file(b)) {
        (Ok(x), Ok(y)) if x == y => Some(Sameness::SameContent(x)),
        _ => None,
    }
}

/// Every later source whose height map is the same data as an earlier one, each paired
/// with the first source it repeats, in the order given.
///
/// # Errors
/// [`ReadFileError`] naming a file that cannot be read for its hash.
pub fn find_duplicate_maps(sources: &[MapSource]) -> Result<Vec<DuplicateMaps>, ReadFileError> {
    let mut out = Vec::new();
    let lengths: Vec<Option<u64>> = sources.iter().map(|s| file_len(&s.height)).collect();
    let mut per_length: HashMap<u64, usize> = HashMap::new();
    for l in lengths.iter().flatten() {
        *per_length.entry(*l).or_default() += 1;
    }
    // Hashes only of files that share their length with another.
    let mut hashes: Vec<Option<String>> = vec![None; sources.len()];
    for (k, s) in sources.iter().enumerate() {
        if lengths[k].is_some_and(|l| per_length[&l] > 1) {
            hashes[k] = Some(sha256_file(&s.height)?);
        }
    }
    for (k, s) in sources.iter().enumerate() {
        let earlier = (0..k).find_map(|j| {
            let o = &sources[j];
            if o.height == s.height || same_file(&o.height, &s.height) {
                Some((j, Sameness::SameFile))
            } else {
                match (&hashes[j], &hashes[k]) {
                    (Some(a), Some(b)) if a == b => Some((j, Sameness::SameContent(a.clone()))),
                    _ => None,
                }
            }
        });
        if let Some((j, why)) = earlier {
            out.push(DuplicateMaps {
                first: j,
                second: k,
                first_path: sources[j].height.clone(),
                second_path: s.height.clone(),
                why,
            });
        }
    }
    Ok(out)
}

/// [`find_duplicate_maps`] as a decision: the first duplicate as an error (naming both
/// files, the count of the others and `allow_with`, how to allow them) unless `allowed`;
/// when allowed, one warning per duplicate, saying that it is pooled twice.
///
/// # Errors
/// The message, or a file that cannot be read for its hash.
pub fn check_distinct_maps(
    sources: &[MapSource],
    allowed: bool,
    allow_with: &str,
) -> Result<Vec<String>, String> {
    let found = find_duplicate_maps(sources).map_err(|e| e.to_string())?;
    match found.first() {
        None => Ok(Vec::new()),
        Some(d) if !allowed => {
            let more = match found.len() {
                1 => String::new(),
                n => format!(" ({} more pair(s) alike)", n - 1),
            };
            Err(format!(
                "{d}{more}: one measurement pooled twice would count its flakes twice and \
                 narrow the between-map interval; remove the copy, or {allow_with} to pool it anyway"
            ))
        }
        Some(_) => Ok(found
            .iter()
            .map(|d| format!("{d}: pooled twice, as allowed"))
            .collect()),
    }
}
