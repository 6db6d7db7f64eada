//! Sets `FLAKESCATTER_BUILD`, the identity of this build, which `analyze` puts into
//! every cache key (docs/guide.md "Reruns and batches"): the SHA-256 (first 16
//! hexadecimal digits) of the source of every crate the program is built from
//! (`crates/*/src/**` and `crates/*/Cargo.toml` of the workspace, the workspace's
//! `Cargo.toml` and `Cargo.lock`), the compiler's version, the target and the
//! optimisation settings. Any change to the code, a dependency, the compiler or the
//! profile gives another identity, so a cache written by another build is never
//! reused. Outside the workspace (a packaged crate) only this crate's own sources
//! are there to hash.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

/// Every file under `dir`, recursively, in name order.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut v: Vec<PathBuf> = entries.filter_map(Result::ok).map(|e| e.path()).collect();
    v.sort();
    for p in v {
        if p.is_dir() {
            files(&p, out);
        } else {
            out.push(p);
        }
    }
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let root = manifest.join("../..");
    let mut inputs: Vec<PathBuf> = Vec::new();
    let crates = root.join("crates");
    if root.join("Cargo.lock").is_file() && crates.is_dir() {
        for f in ["Cargo.toml", "Cargo.lock"] {
            inputs.push(root.join(f));
        }
        let mut dirs: Vec<PathBuf> = std::fs::read_dir(&crates)
            .map(|e| e.filter_map(Result::ok).map(|e| e.path()).collect())
            .unwrap_or_default();
        dirs.sort();
        for d in dirs.iter().filter(|d| d.join("src").is_dir()) {
            inputs.push(d.join("Cargo.toml"));
            println!("cargo:rerun-if-changed={}", d.join("src").display());
            files(&d.join("src"), &mut inputs);
        }
    } else {
        inputs.push(manifest.join("Cargo.toml"));
        println!("cargo:rerun-if-changed={}", manifest.join("src").display());
        files(&manifest.join("src"), &mut inputs);
    }
    let mut h = Sha256::new();
    for f in &inputs {
        if f.file_name()
            .is_some_and(|n| n == "Cargo.toml" || n == "Cargo.lock")
        {
            println!("cargo:rerun-if-changed={}", f.display());
        }
        let rel = f.strip_prefix(&root).unwrap_or(f);
        h.update(rel.to_string_lossy().as_bytes());
        h.update([0]);
        h.update(std::fs::read(f).unwrap_or_default());
        h.update([0]);
    }
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = std::process::Command::new(rustc)
        .arg("-vV")
        .output()
        .map(|o| o.stdout)
        .unwrap_or_default();
    h.update(&version);
    for var in [
        "TARGET",
        "PROFILE",
        "OPT_LEVEL",
        "DEBUG",
        "CARGO_PKG_VERSION",
    ] {
        h.update(var.as_bytes());
        h.update(std::env::var(var).unwrap_or_default().as_bytes());
        h.update([0]);
    }
    let digest = h.finalize();
    let id: String = digest[..8].iter().map(|b| format!("{b:02x}")).collect();
    println!("cargo:rustc-env=FLAKESCATTER_BUILD={id}");
}
