//! `cargo xtask figures [--check]`: the reproduction run (`flakescatter reproduce`) into
//! `docs/figures/`, the committed figures the README and the user guide show.
//!
//! Builds and runs the command-line tool in release mode from the workspace root
//! (`cargo run --release -p flakescatter-cli -- reproduce --out docs/figures`), so the
//! committed `index.md` records the same command a user would type. The run is
//! deterministic (fixed seeds): rerunning it on the same platform changes no byte.
//!
//! `--check` runs the reproduction into `target/figures-check/` instead and compares it
//! with `docs/figures/`: the same files; text files (CSV, JSON, Markdown) equal apart
//! from numbers, which must agree to a relative [`TOLERANCE`] (another platform's maths
//! library may round a last bit differently); plots present and decodable (they are
//! drawings of the CSVs, which are compared).

use std::path::Path;
use std::process::Command;

use anyhow::{Context, bail};

use crate::workspace_root;

/// Relative tolerance of numbers in `--check`.
pub const TOLERANCE: f64 = 1e-6;

/// Entry point of `cargo xtask figures`. Extra arguments are passed to `reproduce`
/// (e.g. `--weighting paper-printed`).
///
/// # Errors
/// If cargo cannot be started, the reproduction fails, or `--check` finds a difference.
pub fn run(args: &[String]) -> anyhow::Result<()> {
    if args.iter().any(|a| a == "--out") {
        bail!(
            "cargo xtask figures always writes docs/figures; run `flakescatter reproduce --out DIR` for another folder"
        );
    }
    let check = args.iter().any(|a| a == "--check");
    let rest: Vec<&String> = args.iter().filter(|a| *a != "--check").collect();
    let root = workspace_root();
    let out = if check {
        "target/figures-check"
    } else {
        "docs/figures"
    };
    if check {
        let _ = std::fs::remove_dir_all(root.join(out));
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_owned());
    let status = Command::new(cargo)
        .current_dir(&root)
        .args([
            "run",
            "--release",
            "-p",
            "flakescatter-cli",
            "--",
            "reproduce",
            "--out",
            out,
        ])
        .args(rest)
        .status()
        .context("cannot run cargo")?;
    if !status.success() {
        bail!("xtask figures: `flakescatter reproduce --out {out}` failed ({status})");
    }
    if check {
        let problems = compare_dirs(&root.join("docs/figures"), &root.join(out), out)?;
        if !problems.is_empty() {
            bail!(
                "docs/figures is not what `cargo xtask figures` makes now:\n  {}",
                problems.join("\n  ")
            );
        }
        println!("docs/figures is current (numbers within a relative {TOLERANCE:e})");
    } else {
        println!("figures written to {}", root.join(out).display());
    }
    Ok(())
}

/// Differences between the committed figures `old` and a fresh run `new` (written with
/// `--out new_name`, which the fresh files name where the committed ones say
/// `docs/figures`).
///
/// # Errors
/// If a directory cannot be read.
pub fn compare_dirs(old: &Path, new: &Path, new_name: &str) -> anyhow::Result<Vec<String>> {
    let names = |d: &Path| -> anyhow::Result<Vec<String>> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .with_context(|| format!("reading {}", d.display()))?
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        Ok(v)
    };
    let (a, b) = (names(old)?, names(new)?);
    let mut problems = Vec::new();
    for n in a.iter().filter(|n| !b.contains(n)) {
        problems.push(format!("{n}: committed but not made any more"));
    }
    for n in b.iter().filter(|n| !a.contains(n)) {
        problems.push(format!("{n}: made but not committed"));
    }
    for n in a.iter().filter(|n| b.contains(n)) {
        let (x, y) = (std::fs::read(old.join(n))?, std::fs::read(new.join(n))?);
        let result = if n.ends_with(".png") {
            check_png(&y)
        } else if n.ends_with(".svg") {
            check_svg(&y)
        } else {
            let fresh = String::from_utf8_lossy(&y).replace(new_name, "docs/figures");
            compare_text(&String::from_utf8_lossy(&x), &fresh, TOLERANCE)
        };
        if let Err(why) = result {
            problems.push(format!("{n}: {why}"));
        }
    }
    Ok(problems)
}

/// A PNG signature and an IHDR chunk.
fn check_png(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() > 24 && &bytes[..8] == b"\x89PNG\r\n\x1a\n" && &bytes[12..16] == b"IHDR" {
        Ok(())
    } else {
        Err("not a PNG file".into())
    }
}

/// An SVG document.
fn check_svg(bytes: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(bytes);
    if text.contains("<svg") && text.trim_end().ends_with("</svg>") {
        Ok(())
    } else {
        Err("not a complete SVG document".into())
    }
}

/// Splits text into runs of number characters and of other characters.
fn tokens(s: &str) -> Vec<&str> {
    let is_num = |c: char| c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E');
    let mut out = Vec::new();
    let mut start = 0;
    let mut kind = None;
    for (i, c) in s.char_indices() {
        let k = is_num(c);
        if kind.is_some_and(|old| old != k) {
            out.push(&s[start..i]);
            start = i;
        }
        kind = Some(k);
    }
    if start < s.len() {
        out.push(&s[start..]);
    }
    out
}

/// Whether `old` and `new` are the same text with numbers equal to a relative `tol`
/// (absolute `tol` below 1); the first difference otherwise.
///
/// # Errors
/// A description of the first difference (line and the two values).
pub fn compare_text(old: &str, new: &str, tol: f64) -> Result<(), String> {
    let (lo, ln): (Vec<&str>, Vec<&str>) = (old.lines().collect(), new.lines().collect());
    if lo.len() != ln.len() {
        return Err(format!("{} lines committed, {} made", lo.len(), ln.len()));
    }
    for (k, (a, b)) in lo.iter().zip(&ln).enumerate() {
        let (ta, tb) = (tokens(a), tokens(b));
        let same = ta.len() == tb.len()
            && ta.iter().zip(&tb).all(|(x, y)| {
                x == y
                    || match (x.parse::<f64>(), y.parse::<f64>()) {
                        (Ok(u), Ok(v)) => (u - v).abs() <= tol * u.abs().max(v.abs()).max(1.0),
                        _ => false,
                    }
            });
        if !same {
            return Err(format!("line {}: committed `{a}`, made `{b}`", k + 1));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn last_digit_differences_pass_and_real_ones_fail() {
        let old = "a,b\n30,1.234567890e-3,fig\n\"scale\": 114.326725,\n";
        // A last-bit difference of libm: the 10th significant digit.
        assert!(
            compare_text(
                old,
                "a,b\n30,1.234567891e-3,fig\n\"scale\": 114.326725,\n",
                1e-6
            )
            .is_ok()
        );
        // A real change of the number, the text, or the row count.
        assert!(
            compare_text(
                old,
                "a,b\n30,1.244567890e-3,fig\n\"scale\": 114.326725,\n",
                1e-6
            )
            .is_err()
        );
        assert!(
            compare_text(
                old,
                "a,b\n30,1.234567890e-3,fog\n\"scale\": 114.326725,\n",
                1e-6
            )
            .is_err()
        );
        assert!(compare_text(old, "a,b\n30,1.234567890e-3,fig\n", 1e-6).is_err());
        // Near zero the tolerance is absolute.
        assert!(compare_text("-1.3e-16", "-1.0e-16", 1e-6).is_ok());
    }

    #[test]
    fn plots_must_decode() {
        assert!(check_png(b"not a png at all, not at all").is_err());
        assert!(check_svg(b"<svg>").is_err());
        assert!(check_svg(b"<svg></svg>\n").is_ok());
    }
}
