//! Running criterion and reading what it wrote: the `cargo bench` commands, the
//! medians from `target/criterion`, the machine the numbers come from.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Instant, SystemTime};

use anyhow::{Context, bail};

use super::rows::{BenchTarget, LIMITS, LimitSource, Row, RowSpec, TARGETS, Target, Unit};

/// Median seconds per iteration of benchmark `id`, read from
/// `<criterion_dir>/<id>/new/estimates.json` (`median.point_estimate`, nanoseconds).
/// With `since`, a file last modified before it counts as missing (a stale result of
/// an earlier run).
///
/// # Errors
/// A message naming the file and what is wrong with it.
pub fn read_median(
    criterion_dir: &Path,
    id: &str,
    since: Option<SystemTime>,
) -> Result<f64, String> {
    let path = criterion_dir.join(id).join("new").join("estimates.json");
    let meta = std::fs::metadata(&path).map_err(|_| {
        format!(
            "not measured: {} does not exist (bench not run, failed or renamed)",
            path.display()
        )
    })?;
    if let (Some(since), Ok(modified)) = (since, meta.modified())
        && modified < since
    {
        return Err(format!(
            "not measured in this run: {} is from an earlier run",
            path.display()
        ));
    }
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| format!("{} is not valid JSON: {e}", path.display()))?;
    let ns = json
        .get("median")
        .and_then(|m| m.get("point_estimate"))
        .and_then(serde_json::Value::as_f64)
        .ok_or_else(|| format!("{} has no number at median.point_estimate", path.display()))?;
    if !(ns.is_finite() && ns > 0.0) {
        return Err(format!(
            "{}: median.point_estimate = {ns} ns is not a positive time",
            path.display()
        ));
    }
    Ok(ns * 1e-9)
}

/// Elements per iteration that benchmark `id` gave criterion as its throughput, read
/// from `<criterion_dir>/<id>/new/benchmark.json` (`throughput.Elements`).
///
/// # Errors
/// A message naming the file and what is wrong with it.
pub fn read_elements(criterion_dir: &Path, id: &str) -> Result<f64, String> {
    let path = criterion_dir.join(id).join("new").join("benchmark.json");
    let text = std::fs::read_to_string(&path).map_err(|_| {
        format!(
            "not measured: {} does not exist (bench not run, failed or renamed)",
            path.display()
        )
    })?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| format!("{} is not valid JSON: {e}", path.display()))?;
    let n = json
        .get("throughput")
        .and_then(|t| t.get("Elements"))
        .and_then(serde_json::Value::as_f64)
        .ok_or_else(|| format!("{} has no number at throughput.Elements", path.display()))?;
    if !(n.is_finite() && n > 0.0) {
        return Err(format!(
            "{}: throughput.Elements = {n} is not a positive count",
            path.display()
        ));
    }
    Ok(n)
}

/// Reads every row of `specs` from `criterion_dir`, pairing each with its floor.
#[must_use]
pub fn build_rows(criterion_dir: &Path, specs: &[RowSpec], since: Option<SystemTime>) -> Vec<Row> {
    specs
        .iter()
        .map(|&spec| Row {
            spec,
            work: match spec.unit {
                Unit::Segments => read_elements(criterion_dir, spec.id),
                _ => Ok(spec.work),
            },
            median_s: read_median(criterion_dir, spec.id, since),
            floor_s: spec.floor.map(|f| read_median(criterion_dir, f, since)),
            reference_s: match spec.target {
                Some(Target::MaxTimes { of, .. }) => Some(read_median(criterion_dir, of, since)),
                _ => None,
            },
            limit_s: LIMITS
                .iter()
                .find(|l| l.id == spec.id)
                .and_then(|l| match l.source {
                    LimitSource::Measured(id) => Some(read_median(criterion_dir, id, since)),
                    LimitSource::Known(_) => None,
                }),
        })
        .collect()
}

/// The machine the numbers come from: CPU model, cores, memory, load average, rustc,
/// date, commit.
#[must_use]
pub fn machine_description(root: &Path) -> Vec<(String, String)> {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map_or_else(|| "unknown".to_owned(), |(_, v)| v.trim().to_owned());
    let cores = std::thread::available_parallelism().map_or(0, std::num::NonZero::get);
    let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let memory = meminfo
        .lines()
        .find(|l| l.starts_with("MemTotal:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or_else(
            || "unknown".to_owned(),
            |kb| format!("{:.1} GiB", kb / (1024.0 * 1024.0)),
        );
    // Other work on the machine changes absolute times: state how busy it was.
    let load = std::fs::read_to_string("/proc/loadavg").map_or_else(
        |_| "unknown".to_owned(),
        |l| l.split_whitespace().take(3).collect::<Vec<_>>().join(", "),
    );
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".to_owned());
    let rustc_version = command_output(Command::new(rustc).arg("--version"), root);
    let commit = command_output(
        Command::new("git").args(["rev-parse", "--short", "HEAD"]),
        root,
    );
    vec![
        ("CPU".to_owned(), cpu),
        ("Cores available".to_owned(), cores.to_string()),
        ("Memory".to_owned(), memory),
        ("Load average when written (1, 5, 15 min)".to_owned(), load),
        ("Compiler".to_owned(), rustc_version),
        ("Date (UTC)".to_owned(), utc_date(SystemTime::now())),
        ("Commit".to_owned(), commit),
    ]
}

fn command_output(cmd: &mut Command, dir: &Path) -> String {
    cmd.current_dir(dir)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or_else(
            || "unknown".to_owned(),
            |o| String::from_utf8_lossy(&o.stdout).trim().to_owned(),
        )
}

/// `YYYY-MM-DD HH:MM` (UTC) of a system time (civil-from-days, proleptic Gregorian).
#[must_use]
pub fn utc_date(t: SystemTime) -> String {
    let secs = t
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let days = (secs / 86_400) as i64;
    let (hh, mm) = ((secs % 86_400) / 3600, (secs % 3600) / 60);
    let (y, m, d) = flakescatter_io::provenance::civil_from_days(days);
    format!("{y:04}-{m:02}-{d:02} {hh:02}:{mm:02}")
}

/// Options of the `bench` task.
#[derive(Debug, Default, Clone)]
pub(super) struct Options {
    pub(super) quick: bool,
    pub(super) report_only: bool,
    /// Only the streamed-memory rows ([`super::streamed`]).
    pub(super) streamed: bool,
    /// With `streamed`: only the rows whose label starts with this (`--streamed=LABEL`).
    pub(super) streamed_only: Option<String>,
}

pub(super) fn parse(args: &[String]) -> anyhow::Result<Options> {
    let mut o = Options::default();
    for a in args {
        match a.as_str() {
            "--quick" => o.quick = true,
            "--report-only" => o.report_only = true,
            "--streamed" => o.streamed = true,
            s if s.starts_with("--streamed=") => {
                o.streamed = true;
                o.streamed_only = Some(s["--streamed=".len()..].to_owned());
            }
            other => bail!(
                "unknown option `{other}` for `cargo xtask bench` \
                 (expected --quick and/or --report-only, or --streamed[=LABEL] alone)"
            ),
        }
    }
    Ok(o)
}

/// The cargo target directory (`CARGO_TARGET_DIR`, else `<root>/target`).
pub(super) fn target_dir(root: &Path) -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) => root.join(d),
        None => root.join("target"),
    }
}

/// The arguments after `--` for criterion.
fn criterion_args(quick: bool) -> Vec<&'static str> {
    let mut a = vec!["--noplot"];
    if quick {
        a.extend(["--quick", "--warm-up-time", "1", "--measurement-time", "2"]);
    }
    a
}

/// Builds and runs every bench of [`TARGETS`]. All together in one cargo command (one
/// build, one feature resolution); if that build fails (a crate under construction),
/// each bench on its own so the others still run. Returns the benches that failed.
pub(super) fn run_benches(cargo: &str, root: &Path, quick: bool) -> anyhow::Result<Vec<String>> {
    let bench_cmd = |targets: &[BenchTarget]| {
        let mut cmd = Command::new(cargo);
        cmd.current_dir(root).arg("bench");
        for t in targets {
            cmd.args(["-p", t.package, "--bench", t.bench]);
        }
        if quick {
            cmd.env("FLAKESCATTER_BENCH_QUICK", "1");
        }
        cmd
    };
    let clock = Instant::now();
    eprintln!("xtask bench: building the benches (bench profile)");
    let built = bench_cmd(TARGETS)
        .arg("--no-run")
        .status()
        .context("cannot run cargo")?
        .success();
    eprintln!(
        "xtask bench: build finished after {:.0} s",
        clock.elapsed().as_secs_f64()
    );
    if built {
        let status = bench_cmd(TARGETS)
            .arg("--no-fail-fast")
            .arg("--")
            .args(criterion_args(quick))
            .status()
            .context("cannot run cargo bench")?;
        if status.success() {
            return Ok(Vec::new());
        }
        eprintln!("xtask bench: some benches failed ({status}); see above");
        return Ok(vec![
            "cargo bench --no-fail-fast (see its output)".to_owned(),
        ]);
    }
    eprintln!("xtask bench: building all benches together failed; running them one by one");
    let mut failed = Vec::new();
    for t in TARGETS {
        let status = bench_cmd(std::slice::from_ref(t))
            .arg("--")
            .args(criterion_args(quick))
            .status()
            .with_context(|| format!("cannot run cargo bench for {}", t.package))?;
        if !status.success() {
            eprintln!(
                "xtask bench: `cargo bench -p {} --bench {}` failed ({status})",
                t.package, t.bench
            );
            failed.push(format!("{}/{}", t.package, t.bench));
        }
    }
    Ok(failed)
}
