//! Peak memory of whole CLI commands on a 4096² map (issue 22: `info`, `topo` and
//! `segment` within 1.5× the map's float64 size plus a fixed few tens of MB).
//!
//! The full `cargo xtask bench` builds the release CLI, writes a 4096² synthetic layer
//! and its intensity map (`synth --size 4096 --seed 1`, X3P) under
//! `<target>/bench-memory/`, runs each command of [`COMMANDS`] under `/usr/bin/time -v`
//! and reads its "Maximum resident set size" (the kernel's peak RSS of the process,
//! KiB). The allowance is [`FIXED_ALLOWANCE`] bytes above 1.5× the map.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Map side of the memory runs, pixels.
pub const SIDE: usize = 4096;

/// What a command may use above 1.5× the map's float64 size: the binary, its libraries
/// and thread stacks, output buffers (bytes).
pub const FIXED_ALLOWANCE: f64 = 50e6;

/// The commands measured: a label and the arguments after `flakescatter` (`{map}`,
/// `{intensity}` and `{dir}` are replaced by paths).
pub const COMMANDS: [(&str, &str); 4] = [
    ("info", "info {map}"),
    ("topo", "topo {map} --out {dir}/topo.csv"),
    ("segment", "segment {map} --out {dir}/flakes.csv"),
    (
        "topo with an intensity map",
        "topo {map} --intensity {intensity} --cutoff 0.5 --out {dir}/topo-intensity.csv",
    ),
];

/// One measured command.
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryRow {
    /// Label of [`COMMANDS`].
    pub label: &'static str,
    /// The command line as run (paths relative to the bench directory).
    pub command: String,
    /// Peak resident set size, bytes (`Err`: why it is missing).
    pub peak_bytes: Result<f64, String>,
}

/// Bytes of the map's heights as float64.
#[must_use]
pub fn map_bytes() -> f64 {
    (SIDE * SIDE * 8) as f64
}

/// The peak RSS in bytes from the report of GNU `time -v` ("Maximum resident set size
/// (kbytes): N", KiB).
#[must_use]
pub fn parse_time_v(report: &str) -> Option<f64> {
    report.lines().find_map(|l| {
        let v = l
            .trim()
            .strip_prefix("Maximum resident set size (kbytes):")?;
        v.trim().parse::<f64>().ok().map(|k| k * 1024.0)
    })
}

/// Builds the release CLI, writes the maps and measures every command.
///
/// # Errors
/// The CLI does not build or the maps cannot be written.
pub fn measure(cargo: &str, root: &Path, target: &Path) -> anyhow::Result<Vec<MemoryRow>> {
    use anyhow::{Context, bail};
    let cli = release_cli(cargo, root, target)?;
    let dir = target.join("bench-memory");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let (map, intensity) = (dir.join("map.x3p"), dir.join("intensity.x3p"));
    if !map.exists() || !intensity.exists() {
        let status = Command::new(&cli)
            .args(["synth", "--size", &SIDE.to_string(), "--seed", "1", "--out"])
            .arg(&map)
            .arg("--intensity-out")
            .arg(&intensity)
            .status()
            .context("cannot run flakescatter synth")?;
        if !status.success() {
            bail!("flakescatter synth failed");
        }
    }
    let mut rows = Vec::new();
    for (label, args) in COMMANDS {
        let command = args
            .replace("{map}", "map.x3p")
            .replace("{intensity}", "intensity.x3p")
            .replace("{dir}", ".");
        let peak_bytes = peak_rss(&cli, &command, &dir)?;
        rows.push(MemoryRow {
            label,
            command: format!("flakescatter {command}"),
            peak_bytes,
        });
    }
    Ok(rows)
}

/// Builds the release CLI (`cargo build --release -p flakescatter-cli` in `root`) and
/// returns its path under `target`.
///
/// # Errors
/// cargo cannot run or the build fails.
pub(super) fn release_cli(cargo: &str, root: &Path, target: &Path) -> anyhow::Result<PathBuf> {
    use anyhow::{Context as _, bail};
    let status = Command::new(cargo)
        .args(["build", "--release", "-p", "flakescatter-cli"])
        .current_dir(root)
        .status()
        .context("cannot run cargo build for the CLI")?;
    if !status.success() {
        bail!("cargo build --release -p flakescatter-cli failed");
    }
    Ok(target.join("release").join("flakescatter"))
}

/// Peak resident memory of `cli command` (arguments split at spaces) run in `dir`, bytes,
/// as GNU time's `-v` report gives it; `Err(why)` (a row's text) when `/usr/bin/time` is
/// missing, the command fails or the report has no peak.
///
/// # Errors
/// The outer error when `/usr/bin/time` exists but cannot be run.
pub(super) fn peak_rss(
    cli: &Path,
    command: &str,
    dir: &Path,
) -> anyhow::Result<Result<f64, String>> {
    use anyhow::Context as _;
    let time = Path::new("/usr/bin/time");
    if !time.exists() {
        return Ok(Err("/usr/bin/time (GNU time) not found".to_owned()));
    }
    let out = Command::new(time)
        .arg("-v")
        .arg(cli)
        .args(command.split(' '))
        .current_dir(dir)
        .output()
        .context("cannot run /usr/bin/time")?;
    let report = String::from_utf8_lossy(&out.stderr);
    Ok(if out.status.success() {
        parse_time_v(&report).ok_or_else(|| "no peak in /usr/bin/time's report".to_owned())
    } else {
        Err(format!(
            "the command failed: {}",
            report.lines().next().unwrap_or("")
        ))
    })
}

/// The memory section of `docs/benchmarks.md`.
#[must_use]
pub fn render(rows: &[MemoryRow]) -> String {
    let map = map_bytes();
    let mut s = format!(
        "\n## Peak memory\n\n\
         Whole commands on a {SIDE}² map (X3P written by `flakescatter synth --size {SIDE} \
         --seed 1`, with its intensity map), peak resident set size from `/usr/bin/time -v`. \
         The map's heights as float64 are {:.1} MB; the target (issue 22) is at most 1.5× \
         that plus {:.0} MB.\n\n\
         | Command | Peak memory | × map float64 | Target | Met |\n|---|---:|---:|---|:---:|\n",
        map / 1e6,
        FIXED_ALLOWANCE / 1e6
    );
    for r in rows {
        let (peak, times, met) = match &r.peak_bytes {
            Ok(b) => (
                format!("{:.0} MB", b / 1e6),
                format!("{:.2}×", b / map),
                if *b <= 1.5 * map + FIXED_ALLOWANCE {
                    "yes"
                } else {
                    "no"
                },
            ),
            Err(why) => (format!("not measured ({why})"), "—".to_owned(), "—"),
        };
        let _ = writeln!(
            s,
            "| {} (`{}`) | {peak} | {times} | ≤ {:.0} MB | {met} |",
            r.label,
            r.command,
            (1.5 * map + FIXED_ALLOWANCE) / 1e6
        );
    }
    s
}
