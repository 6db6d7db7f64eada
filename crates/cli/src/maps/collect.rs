//! Map-input collection and pairing: `MAP` arguments (files, directories, glob
//! patterns) expanded into map files, and each height map paired with its intensity
//! map, by the rules in the `maps` module docs ("Which files are maps", "Pairing").

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::inputs::{MapSource, SourceKind};

use super::{MAP_EXTENSIONS, MAX_MAPS, Pairing, Repeats};

/// Whether `p` is a Zarr store (a directory read as one map, [`flakescatter::io::zarr`]).
fn is_store(p: &Path) -> bool {
    flakescatter::io::zarr::is_store(p)
}

/// Whether a path segment is a glob pattern.
fn is_pattern(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

fn has_map_extension(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| MAP_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

/// The file name of `p` without its extension (`a.height` for `a.height.x3p`).
fn stem_of(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Expands files, directories and glob patterns into map files (module docs), each
/// relative to `base` when given and not absolute. `flag` names the argument in errors.
pub fn expand(
    flag: &str,
    items: &[PathBuf],
    base: Option<&Path>,
    pairing: &Pairing,
    repeats: Repeats,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = Vec::new();
    for item in items {
        let path = match base {
            Some(b) if item.is_relative() => b.join(item),
            _ => item.clone(),
        };
        let shown = path.display().to_string();
        if is_store(&path) {
            out.push(path);
        } else if path.is_dir() {
            let mut found: Vec<PathBuf> = Vec::new();
            let entries = flakescatter::io::files::list_dir(&path)
                .with_context(|| format!("{flag} {shown}: cannot list the directory"))?;
            for p in entries {
                let hidden = p
                    .file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with('.'));
                let wanted = has_map_extension(&p)
                    && !hidden
                    && match pairing {
                        Pairing::Suffix { height, .. } if !height.is_empty() => {
                            stem_of(&p).ends_with(height.as_str())
                        }
                        _ => true,
                    };
                if !wanted {
                    continue;
                }
                if let Some(why) = dangling(&p) {
                    bail!("{flag} {shown}: {why}; remove the link or restore its target");
                }
                if p.is_file() || is_store(&p) {
                    found.push(p);
                }
            }
            found.sort();
            if found.is_empty() {
                match pairing {
                    Pairing::Suffix { height, .. } => bail!(
                        "{flag} {shown}: the directory holds no map whose name ends in `{height}` before the extension ({})",
                        MAP_EXTENSIONS.join(", ")
                    ),
                    _ => bail!(
                        "{flag} {shown}: the directory holds no map file ({})",
                        MAP_EXTENSIONS.join(", ")
                    ),
                }
            }
            out.extend(found);
        } else if path.exists() {
            out.push(path);
        } else if let Some(why) = dangling(&path) {
            bail!("{flag}: {why}");
        } else if is_pattern(&shown) {
            let mut found: Vec<PathBuf> = Vec::new();
            for m in glob::glob(&shown)
                .with_context(|| format!("{flag} {shown}: not a valid pattern"))?
            {
                let p = m.map_err(|e| {
                    anyhow::anyhow!(
                        "{flag} {shown}: cannot read {}: {}",
                        e.path().display(),
                        e.error()
                    )
                })?;
                if let Some(why) = dangling(&p) {
                    bail!("{flag} {shown}: {why}; remove the link or restore its target");
                }
                if p.is_file() || is_store(&p) {
                    found.push(p);
                }
            }
            found.sort();
            if found.is_empty() {
                bail!("{flag} {shown}: the pattern matches no file");
            }
            out.extend(found);
        } else {
            bail!("{flag} {shown}: no such file or directory");
        }
        if out.len() > MAX_MAPS {
            bail!("{flag}: more than {MAX_MAPS} maps");
        }
    }
    for (k, p) in out.iter().enumerate() {
        // One path by two spellings; other names of one file (hard links) and copies
        // are the duplicate check's (`super::check_duplicates`).
        let same = |q: &PathBuf| q == p || flakescatter::io::files::same_path(q, p);
        if let Some(q) = out[..k].iter().find(|q| same(q)) {
            match repeats {
                Repeats::Refuse => bail!(
                    "{flag}: {} is given twice (also as {}); each map may be counted once",
                    p.display(),
                    q.display()
                ),
                Repeats::Warn => crate::output::warn(&format!(
                    "{flag}: {} is given twice (also as {}); it is counted twice",
                    p.display(),
                    q.display()
                )),
            }
        }
    }
    Ok(out)
}

/// For a symbolic link whose target does not exist (at any depth of links), what it is:
/// `<link> is a symbolic link to <target>, which does not exist`; `None` otherwise.
pub fn dangling(path: &Path) -> Option<String> {
    flakescatter::io::files::dangling_link(path).map(|d| d.to_string())
}

/// Why an intensity file named by the pairing cannot be used: it does not exist (or is a
/// dangling link), or it is the height map file itself.
fn check_partner(map: &Path, partner: &Path, how: &str) -> anyhow::Result<()> {
    if let Some(why) = dangling(partner) {
        bail!("{}: its intensity map ({how}): {why}", map.display());
    }
    if !partner.is_file() && !is_store(partner) {
        bail!(
            "{}: its intensity map {} ({how}) does not exist",
            map.display(),
            partner.display()
        );
    }
    if let Some(why) = flakescatter::distinct::same_data(map, partner) {
        let what = match why {
            flakescatter::distinct::Sameness::SameFile => "the height map file itself".to_string(),
            flakescatter::distinct::Sameness::SameContent(h) => {
                format!("a byte-identical copy of the height map (SHA-256 {h})")
            }
        };
        bail!(
            "{}: its intensity map {} ({how}) is {what}: a map cannot be its own intensity image",
            map.display(),
            partner.display()
        );
    }
    Ok(())
}

/// The intensity partner of `map` under the suffix rule (module docs).
pub fn partner(map: &Path, height: &str, intensity: &str) -> anyhow::Result<PathBuf> {
    let name = map
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (stem, ext) = match map.extension() {
        Some(e) => (
            name[..name.len() - e.len() - 1].to_owned(),
            format!(".{}", e.to_string_lossy()),
        ),
        None => (name.clone(), String::new()),
    };
    let Some(at) = (!height.is_empty()).then(|| stem.rfind(height)).flatten() else {
        bail!(
            "{}: the name has no `{height}` before its extension, so --intensity-suffix {intensity} finds no partner (set --height-suffix, or give --intensity once per map)",
            map.display()
        );
    };
    let new = format!(
        "{}{intensity}{}{ext}",
        &stem[..at],
        &stem[at + height.len()..]
    );
    Ok(map.with_file_name(new))
}

/// Pairs map files with their intensity maps (module docs).
pub fn pair(files: &[PathBuf], pairing: &Pairing) -> anyhow::Result<Vec<MapSource>> {
    match pairing {
        Pairing::None => Ok(files.iter().map(|f| MapSource::new(f, None)).collect()),
        Pairing::Explicit(list) => {
            if let Some(stack) = files
                .iter()
                .find(|f| SourceKind::of(f) == SourceKind::Stack)
            {
                bail!(
                    "--intensity with the z-stack {}: a stack carries its own intensity; give --intensity only with height maps (or use --intensity-suffix, which skips stacks)",
                    stack.display()
                );
            }
            if list.len() != files.len() {
                bail!(
                    "--intensity given {} times for {} height maps: give one intensity map per height map, in the same order",
                    list.len(),
                    files.len()
                );
            }
            for (f, i) in files.iter().zip(list) {
                check_partner(f, i, "--intensity")?;
            }
            Ok(files
                .iter()
                .zip(list)
                .map(|(f, i)| MapSource::new(f, Some(i.clone())))
                .collect())
        }
        Pairing::Suffix { height, intensity } => {
            if height.is_empty() {
                bail!(
                    "the height suffix is empty (--height-suffix \"\", or `maps.height_suffix = \"\"` in a manifest): --intensity-suffix {intensity} replaces the height suffix in each map's name, so it must name a part of the name, e.g. `.height`"
                );
            }
            if height == intensity {
                bail!(
                    "the intensity suffix `{intensity}` is the height suffix itself (--intensity-suffix, --height-suffix): every map would be paired with itself"
                );
            }
            files
                .iter()
                .map(|f| {
                    if SourceKind::of(f) == SourceKind::Stack {
                        return Ok(MapSource::new(f, None));
                    }
                    let p = partner(f, height, intensity)?;
                    check_partner(f, &p, &format!("--intensity-suffix {intensity}"))?;
                    Ok(MapSource::new(f, Some(p)))
                })
                .collect()
        }
    }
}
