//! The invariants of `docs/architecture.md`, checked against the code itself: the
//! manifests' dependencies between workspace crates are exactly the table of the document,
//! every dependency a manifest lists is used, only `io`, the CLI's output layer and `xtask`
//! touch files, nothing prints outside the CLI's output layer, no crate's top-level
//! modules reference each other in a circle, and no source file or function outgrows the
//! limits the document states.
//!
//! Source text is read with comments removed (a doc link is not a dependency); the
//! checks are textual on purpose: they read what a reviewer reads.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    xtask::workspace_root()
}

/// The workspace's member folders: `crates/*` and `xtask`, by short name.
fn members() -> BTreeMap<String, PathBuf> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(root().join("crates")).unwrap() {
        let p = e.unwrap().path();
        if p.join("Cargo.toml").is_file() {
            out.insert(p.file_name().unwrap().to_string_lossy().into_owned(), p);
        }
    }
    out.insert("xtask".into(), root().join("xtask"));
    out
}

/// A manifest's table of normal dependencies (`[dependencies]`), by name.
fn dependencies(dir: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
    let v: toml::Table = toml::from_str(&text).unwrap();
    v.get("dependencies")
        .and_then(|d| d.as_table())
        .map(|d| d.keys().cloned().collect())
        .unwrap_or_default()
}

/// The workspace crate a dependency name refers to (`flakescatter-io` → `io`,
/// `flakescatter` → `flakescatter`), if it is one.
fn workspace_name(dep: &str) -> Option<String> {
    if dep == "flakescatter" {
        Some(dep.into())
    } else {
        dep.strip_prefix("flakescatter-").map(str::to_string)
    }
}

/// Every `.rs` file below `dir`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in entries {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(rust_files(&p));
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// Source text without its unit tests (from the first `#[cfg(test)]` followed by a
/// `mod` line: tests may print and touch files) and without `//` comments (line, doc and
/// inner doc comments); string literals holding `//` lose their tail, which the checks
/// here do not mind.
fn code(path: &Path) -> String {
    non_test_lines(path)
        .iter()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Whether `ident` occurs in `text` as a whole identifier.
fn mentions(text: &str, ident: &str) -> bool {
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    text.match_indices(ident).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + ident.len()..].chars().next();
        !before.is_some_and(is_ident) && !after.is_some_and(is_ident)
    })
}

/// Whether `word` occurs in `text` with no identifier character just before it
/// (`File::` but not `ParamsFile::`).
fn starts_a_word(text: &str, word: &str) -> bool {
    text.match_indices(word).any(|(i, _)| {
        !text[..i]
            .chars()
            .next_back()
            .is_some_and(|c| c.is_alphanumeric() || c == '_')
    })
}

/// The table under "Dependencies, as checked" in `docs/architecture.md`: crate →
/// workspace crates it depends on.
fn documented_layers() -> BTreeMap<String, BTreeSet<String>> {
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let start = doc
        .find("| crate | depends on (workspace crates) |")
        .expect("docs/architecture.md has lost its dependency table");
    let mut out = BTreeMap::new();
    for line in doc[start..].lines().skip(2) {
        let Some(row) = line.strip_prefix('|') else {
            break;
        };
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let name = cells[0].trim_matches('`').to_string();
        let deps = cells[1]
            .split(',')
            .map(|d| d.trim().trim_matches('`'))
            .filter(|d| !d.is_empty() && *d != "—")
            .map(str::to_string)
            .collect();
        out.insert(name, deps);
    }
    out
}

#[test]
fn the_manifests_are_the_documented_layers() {
    let layers = documented_layers();
    let members = members();
    let documented: BTreeSet<_> = layers.keys().cloned().collect();
    let present: BTreeSet<_> = members.keys().cloned().collect();
    assert_eq!(
        documented, present,
        "the table in docs/architecture.md and the workspace's members differ"
    );
    for (name, dir) in &members {
        let have: BTreeSet<String> = dependencies(dir)
            .iter()
            .filter_map(|d| workspace_name(d))
            .collect();
        assert_eq!(
            &have, &layers[name],
            "{name}: Cargo.toml's workspace dependencies against docs/architecture.md's table"
        );
    }
}

#[test]
fn every_listed_dependency_is_used() {
    // Library names that differ from the package's name.
    let lib_name = |dep: &str| match dep {
        "md-5" => "md5".to_string(),
        other => other.replace('-', "_"),
    };
    let mut unused = Vec::new();
    for (name, dir) in members() {
        let mut text = String::new();
        for f in rust_files(&dir.join("src")) {
            text.push_str(&code(&f));
        }
        if dir.join("build.rs").is_file() {
            text.push_str(&code(&dir.join("build.rs")));
        }
        for dep in dependencies(&dir) {
            if !mentions(&text, &lib_name(&dep)) {
                unused.push(format!("{name}: {dep}"));
            }
        }
    }
    assert!(
        unused.is_empty(),
        "normal dependencies the crate's own code never names (a test-only one belongs in [dev-dependencies]): {unused:?}"
    );
}

#[test]
fn only_io_the_cli_output_layer_and_xtask_touch_files() {
    let patterns = ["std::fs", "fs::", "File::", "OpenOptions"];
    let mut found = Vec::new();
    for (name, dir) in members() {
        if name == "io" || name == "xtask" {
            continue;
        }
        for f in rust_files(&dir.join("src")) {
            let rel = f.strip_prefix(&dir).unwrap().to_string_lossy().into_owned();
            if name == "cli" && rel.starts_with("src/output") {
                continue;
            }
            let text = code(&f);
            for p in patterns {
                if starts_a_word(&text, p) {
                    found.push(format!("{name}/{rel}: {p}"));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "file access outside io and the CLI's output layer: {found:?}"
    );
}

#[test]
fn nothing_prints_outside_the_cli_output_layer() {
    let macros = ["println!", "print!", "eprintln!", "eprint!", "dbg!"];
    let mut found = Vec::new();
    for (name, dir) in members() {
        if name == "xtask" {
            continue;
        }
        for f in rust_files(&dir.join("src")) {
            let rel = f.strip_prefix(&dir).unwrap().to_string_lossy().into_owned();
            let text = code(&f);
            for m in macros {
                // `println!` anywhere (it panics on a closed pipe); the others only in
                // the CLI's output layer.
                let allowed = m != "println!" && name == "cli" && rel.starts_with("src/output");
                if !allowed && mentions(&text, m.trim_end_matches('!')) && text.contains(m) {
                    found.push(format!("{name}/{rel}: {m}"));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "printing outside the CLI's output layer: {found:?}"
    );
}

/// A crate's top-level modules (files and folders directly in `src/`, but `lib.rs` and
/// `main.rs`) with the files of each.
fn modules(src: &Path) -> BTreeMap<String, Vec<PathBuf>> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(src).unwrap() {
        let p = e.unwrap().path();
        let file = p.file_name().unwrap().to_string_lossy().into_owned();
        if file == "lib.rs" || file == "main.rs" {
            continue;
        }
        if p.is_dir() {
            out.insert(file, rust_files(&p));
        } else if let Some(stem) = file.strip_suffix(".rs") {
            out.entry(stem.to_string()).or_insert_with(Vec::new).push(p);
        }
    }
    out
}

/// The modules a text refers to through `crate::m` or `crate::{m, …}`.
fn references(text: &str, names: &BTreeSet<String>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (i, _) in text.match_indices("crate::") {
        let rest = &text[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let group = &group[..group.find('}').unwrap_or(group.len())];
            for item in group.split(',') {
                let head = item.trim().split("::").next().unwrap_or("");
                if names.contains(head) {
                    out.insert(head.to_string());
                }
            }
        } else {
            let head: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if names.contains(&head) {
                out.insert(head);
            }
        }
    }
    out
}

/// Whether `to` can be reached from `from` in `edges`.
fn reaches(edges: &BTreeMap<String, BTreeSet<String>>, from: &str, to: &str) -> bool {
    let mut seen = BTreeSet::new();
    let mut stack = vec![from.to_string()];
    while let Some(m) = stack.pop() {
        if m == to {
            return true;
        }
        if seen.insert(m.clone()) {
            stack.extend(edges[&m].iter().cloned());
        }
    }
    false
}

#[test]
fn no_circles_between_a_crates_modules() {
    let mut circles = Vec::new();
    for (name, dir) in members() {
        let mods = modules(&dir.join("src"));
        let names: BTreeSet<String> = mods.keys().cloned().collect();
        let mut edges = BTreeMap::new();
        for (m, files) in &mods {
            let mut refs = BTreeSet::new();
            for f in files {
                refs.extend(references(&code(f), &names));
            }
            refs.remove(m);
            edges.insert(m.clone(), refs);
        }
        for (m, refs) in &edges {
            for r in refs {
                if m < r && reaches(&edges, r, m) {
                    circles.push(format!("{name}: {m} <-> {r}"));
                }
            }
        }
    }
    assert!(
        circles.is_empty(),
        "modules that reach each other: {circles:?}"
    );
}

/// The limits of a room (docs/architecture.md "Room sizes").
const MAX_FILE_LINES: usize = 800;
const MAX_FN_LINES: usize = 150;

/// A source file's lines before its unit-test module (`#[cfg(test)]` followed by an
/// inline `mod NAME {` or `pub(crate) mod NAME {`); tests are not counted.
fn non_test_lines(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    let end = (0..lines.len())
        .find(|&i| {
            lines[i].starts_with("#[cfg(test)]")
                && lines.get(i + 1).is_some_and(|l| {
                    // An inline module (`mod tests {`), not `mod tests;` in another file.
                    l.trim_start_matches("pub(crate) ").starts_with("mod ")
                        && l.trim_end().ends_with('{')
                })
        })
        .unwrap_or(lines.len());
    lines[..end].to_vec()
}

/// The functions of a file's lines with their lengths: from the line declaring `fn
/// name` to the first later line that is `}` at the declaration's indentation.
fn function_lengths(lines: &[String]) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let indent = &l[..l.len() - l.trim_start().len()];
        let mut words = l.split_whitespace();
        // Skip visibility and qualifiers up to `fn`.
        let mut name = None;
        while let Some(w) = words.next() {
            if w == "fn" {
                name = words.next().map(|n| {
                    n.chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect::<String>()
                });
                break;
            }
            let qualifier = w.starts_with("pub")
                || matches!(w, "const" | "async" | "unsafe" | "extern" | "\"C\"");
            if !qualifier {
                break;
            }
        }
        let Some(name) = name.filter(|n| !n.is_empty()) else {
            continue;
        };
        let close = format!("{indent}}}");
        if let Some(j) = lines[i + 1..].iter().position(|m| *m == close) {
            out.push((name, j + 1));
        }
    }
    out
}

/// The rows of the table under `heading` in docs/architecture.md, as cells.
fn documented_rows(heading: &str) -> Vec<Vec<String>> {
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let start = doc
        .find(heading)
        .unwrap_or_else(|| panic!("docs/architecture.md has lost its table `{heading}`"));
    doc[start..]
        .lines()
        .skip(2)
        .map_while(|l| l.strip_prefix('|'))
        .map(|row| {
            row.trim_end_matches('|')
                .split('|')
                .map(|c| c.trim().trim_matches('`').to_string())
                .collect()
        })
        .collect()
}

/// Every non-test source file of the workspace, relative to the root.
fn source_files() -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    for dir in members().values() {
        for f in rust_files(&dir.join("src")) {
            let rel = f
                .strip_prefix(root())
                .unwrap()
                .to_string_lossy()
                .into_owned();
            out.push((rel, f));
        }
    }
    out
}

#[test]
fn rooms_stay_within_their_sizes() {
    // The files and functions still over the limits are listed in the document with
    // the size they may not exceed; a listed one that has come under the limit must
    // leave the list, so the list is the remaining work, no more and no less.
    let files: BTreeMap<String, usize> = documented_rows("| file | lines at most |")
        .into_iter()
        .map(|r| (r[0].clone(), r[1].parse().expect("a whole number of lines")))
        .collect();
    let fns: BTreeMap<(String, String), usize> =
        documented_rows("| file | function | lines at most |")
            .into_iter()
            .map(|r| {
                (
                    (r[0].clone(), r[1].clone()),
                    r[2].parse().expect("a whole number of lines"),
                )
            })
            .collect();
    let mut wrong = Vec::new();
    let mut seen_files = BTreeSet::new();
    let mut seen_fns = BTreeSet::new();
    for (rel, path) in source_files() {
        let lines = non_test_lines(&path);
        let n = lines.len();
        if n > MAX_FILE_LINES {
            seen_files.insert(rel.clone());
            match files.get(&rel) {
                None => wrong.push(format!("{rel}: {n} lines (limit {MAX_FILE_LINES})")),
                Some(&most) if n > most => {
                    wrong.push(format!("{rel}: {n} lines, listed at most {most}"));
                }
                Some(_) => {}
            }
        }
        for (name, len) in function_lengths(&lines) {
            if len > MAX_FN_LINES {
                let key = (rel.clone(), name.clone());
                seen_fns.insert(key.clone());
                match fns.get(&key) {
                    None => wrong.push(format!(
                        "{rel}: fn {name} {len} lines (limit {MAX_FN_LINES})"
                    )),
                    Some(&most) if len > most => {
                        wrong.push(format!(
                            "{rel}: fn {name} {len} lines, listed at most {most}"
                        ));
                    }
                    Some(_) => {}
                }
            }
        }
    }
    for f in files.keys().filter(|f| !seen_files.contains(*f)) {
        wrong.push(format!(
            "{f}: listed but within the limit (or gone): remove its row"
        ));
    }
    for (f, name) in fns.keys().filter(|k| !seen_fns.contains(*k)) {
        wrong.push(format!(
            "{f}: fn {name} listed but within the limit (or gone): remove its row"
        ));
    }
    assert!(
        wrong.is_empty(),
        "room sizes against docs/architecture.md: {wrong:#?}"
    );
}

#[test]
fn the_size_rules_measure_what_they_say() {
    // A hand-counted sample: `fn a` spans lines 1..=4 (3 lines after its declaration),
    // the nested `fn b` 1 line, and the test module is not counted.
    let text = "pub(crate) fn a() {\n    fn b() {\n    }\n}\n#[cfg(test)]\nmod tests {\n}\n";
    let dir = std::env::temp_dir().join(format!("fs-arch-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("x.rs");
    std::fs::write(&p, text).unwrap();
    let lines = non_test_lines(&p);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(lines.len(), 4);
    assert_eq!(
        function_lengths(&lines),
        vec![("a".to_string(), 3), ("b".to_string(), 1)]
    );
}
