//! What the CLI's integration tests share: running the binary, the repository's
//! fixtures, scratch directories and snapshots of a directory tree. Each test file that
//! uses it says `mod common;`; not every file uses every helper.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `flakescatter` binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_flakescatter"))
}

/// Runs the binary with `args`.
pub fn run<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    bin().args(args).output().unwrap()
}

/// Runs the binary with `args`: its exit status (-1 when killed by a signal), standard
/// output and standard error as text.
pub fn run_text(args: &[&str]) -> (i32, String, String) {
    let out = run(args);
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs the binary with `args` in the directory `dir`.
pub fn run_in<S: AsRef<std::ffi::OsStr>>(dir: &Path, args: &[S]) -> Output {
    bin().current_dir(dir).args(args).output().unwrap()
}

/// The repository's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A file of `fixtures/`.
pub fn fixture(name: &str) -> PathBuf {
    root().join("fixtures").join(name)
}

/// The repository's `fixtures/` directory.
pub fn fixtures() -> PathBuf {
    root().join("fixtures")
}

/// An empty scratch directory `fs-<tag>-<name>-<pid>` in the system's temporary
/// directory (`tag` names the test file, so that test binaries running at once never
/// share one).
pub fn scratch(tag: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fs-{tag}-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

/// A path as text.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The standard error of a run as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Every entry under `d` (relative path → bytes): files with their bytes, directories
/// as `path/` with none, symbolic links (not followed) with their target.
pub fn snapshot(d: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![d.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(d).unwrap().display().to_string();
            let meta = fs::symlink_metadata(&p).unwrap();
            if meta.file_type().is_symlink() {
                let target = fs::read_link(&p).unwrap().display().to_string();
                out.insert(rel, target.into_bytes());
            } else if meta.is_dir() {
                out.insert(rel + "/", Vec::new());
                stack.push(p);
            } else {
                out.insert(rel, fs::read(&p).unwrap());
            }
        }
    }
    out
}

/// Power transmittances `(Ts, Tp)` of the air/coating surface at incidence `theta`
/// (radians) for a coat of index `n`: the Fresnel amplitudes written out,
/// `rs = (cos θi − n cos θt)/(cos θi + n cos θt)`, `rp = (n cos θi − cos θt)/(n cos θi + cos θt)`,
/// `T = 1 − r²` (independent of the library's optics).
pub fn fresnel_ts_tp(theta: f64, n: f64) -> (f64, f64) {
    let ci = theta.cos();
    let ct = (1.0 - (theta.sin() / n).powi(2)).sqrt();
    let rs = (ci - n * ct) / (ci + n * ct);
    let rp = (n * ci - ct) / (n * ci + ct);
    (1.0 - rs * rs, 1.0 - rp * rp)
}
