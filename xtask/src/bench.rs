//! `cargo xtask bench [--quick] [--report-only]`: run the criterion benches of the
//! workspace and print one table of how fast we are, against the issues' targets and
//! against a **floor** measured on the same input in the same run.
//!
//! * Every row of [`ROWS`] names one criterion benchmark (`<group>/<function>[/<value>]`,
//!   the directory criterion writes under `target/criterion/`), the work one iteration
//!   does (rays, pixels, evaluations, detectors or bytes), the target from the issues if
//!   there is one, and the floor benchmark it is paired with.
//! * The floor of a data-heavy bench is one streaming, single-threaded pass that reads
//!   every input value once (a sum of the heights; for the X3P read, reading the file's
//!   bytes into memory and summing them). `time / floor` says how far an operation is
//!   from being memory-bound; it stays meaningful on a noisy, shared machine where
//!   absolute times are not.
//! * The median is criterion's `median.point_estimate` (nanoseconds per iteration) from
//!   `target/criterion/<id>/new/estimates.json`. Throughput is `work / median`.
//! * The full run writes `docs/benchmarks.md` (the table plus the machine: CPU model,
//!   cores, memory, load average, rustc, date, commit); `--quick` (criterion's quick
//!   mode, at most 2 s per bench, no 4096² topographic maps, no rough layer) writes
//!   `target/benchmarks-quick.md` instead, so that a check before a commit does not
//!   touch the committed file. `--report-only` runs nothing and only prints the table
//!   of what `target/criterion` holds.
//! * A benchmark that did not produce an `estimates.json` in this run (bench renamed,
//!   crate failing to build) shows as "not measured" with the path that was expected;
//!   the task exits non-zero only when a `cargo bench` command itself failed.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Instant, SystemTime};

use anyhow::{Context, bail};

/// What one iteration of a benchmark processes, for the throughput column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Rays traced (usable pixels × incidences): rays/s.
    Rays,
    /// Map pixels: pixels/s.
    Pixels,
    /// Function evaluations: evaluations/s.
    Evaluations,
    /// Detector readings (incidences × detectors): detectors/s.
    Detectors,
    /// Bytes of data: MB/s (10⁶ bytes per second).
    Bytes,
}

impl Unit {
    /// The throughput unit as printed in the table.
    #[must_use]
    pub fn per_second(self) -> &'static str {
        match self {
            Self::Rays => "rays/s",
            Self::Pixels => "pixels/s",
            Self::Evaluations => "evaluations/s",
            Self::Detectors => "detectors/s",
            Self::Bytes => "MB/s",
        }
    }
}

/// A target from the issues.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// The median time per iteration must be at most this many seconds.
    MaxSeconds(f64),
    /// The throughput must be at least this many units per second.
    MinPerSecond(f64),
    /// The median time must be at most `times` × the median of the benchmark `of`
    /// (measured in the same run: a cost relative to another operation).
    MaxTimes {
        /// Criterion id of the reference benchmark.
        of: &'static str,
        /// Largest allowed ratio of the two medians.
        times: f64,
    },
}

/// One row of the table: which benchmark, what it measures, what it should reach.
#[derive(Debug, Clone, Copy)]
pub struct RowSpec {
    /// Operation, as printed.
    pub operation: &'static str,
    /// Size of the input, as printed (e.g. `4096²`).
    pub size: &'static str,
    /// Criterion id `<group>/<function>[/<value>]` (its directory under `target/criterion`).
    pub id: &'static str,
    /// Criterion id of the floor measured on the same input, if any.
    pub floor: Option<&'static str>,
    /// Work done by one iteration, in `unit`.
    pub work: f64,
    /// Unit of `work`.
    pub unit: Unit,
    /// Target from the issues, if any.
    pub target: Option<Target>,
    /// How the target is stated in the issue (printed next to it).
    pub target_note: &'static str,
    /// Whether the row is measured by `--quick`.
    pub quick: bool,
}

/// One criterion bench target to run: `cargo bench -p <package> --bench <bench>`.
#[derive(Debug, Clone, Copy)]
pub struct BenchTarget {
    /// Cargo package.
    pub package: &'static str,
    /// Bench target name.
    pub bench: &'static str,
}

/// Every bench target the table draws on, in the order they run.
pub const TARGETS: &[BenchTarget] = &[
    BenchTarget {
        package: "flakescatter-optics",
        bench: "optics",
    },
    BenchTarget {
        package: "flakescatter-gaussian",
        bench: "model",
    },
    BenchTarget {
        package: "flakescatter-topo",
        bench: "topo",
    },
    BenchTarget {
        package: "flakescatter-stats",
        bench: "segment",
    },
    BenchTarget {
        package: "flakescatter-io",
        bench: "read_x3p",
    },
    BenchTarget {
        package: "flakescatter-synth",
        bench: "generate",
    },
];

/// Usable pixels of an `n × n` map with the default 5 × 5 normal window: `(n − 4)²`.
const fn usable(n: u64) -> f64 {
    ((n - 4) * (n - 4)) as f64
}

/// `n²` as f64.
const fn square(n: u64) -> f64 {
    (n * n) as f64
}

/// The table, in order. Work counts match the benches' inputs (see each bench file).
pub const ROWS: &[RowSpec] = &[
    RowSpec {
        operation: "Fresnel power, air → coating",
        size: "1000 calls",
        id: "optics/fresnel_air_to_coating_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Snell refraction into the coating",
        size: "1000 calls",
        id: "optics/snell_into_coating_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Snell refraction out of the coating",
        size: "1000 calls",
        id: "optics/snell_out_of_coating_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Mirror reflection by a flake",
        size: "1000 calls",
        id: "optics/reflect_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Internal half vector",
        size: "1000 calls",
        id: "optics/half_vector_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, point BRDF",
        size: "1000 directions",
        id: "gaussian/point_brdf_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MinPerSecond(1e7)),
        target_note: "> 10⁷ evaluations/s",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, point Mueller BRDF",
        size: "1000 directions",
        id: "gaussian/point_mueller_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MaxTimes {
            of: "gaussian/point_brdf_x1000",
            times: 3.0,
        }),
        target_note: "≤ 3× the point BRDF",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, default set (exact cones, α = 1.5°)",
        size: "5 × 281",
        id: "gaussian/default_set_5x281_exact_1thread",
        floor: None,
        work: 1405.0,
        unit: Unit::Detectors,
        target: Some(Target::MaxSeconds(0.020)),
        target_note: "< 20 ms, 1 thread",
        quick: true,
    },
    RowSpec {
        operation: "Windowed normals (5 × 5)",
        size: "1024²",
        id: "topo/normals/1024",
        floor: Some("topo/floor_1024"),
        work: square(1024),
        unit: Unit::Pixels,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Windowed normals (5 × 5)",
        size: "4096²",
        id: "topo/normals/4096",
        floor: Some("topo/floor_4096"),
        work: square(4096),
        unit: Unit::Pixels,
        target: None,
        target_note: "",
        quick: false,
    },
    RowSpec {
        operation: "Topographic model, 5 incidences × 281 detectors",
        size: "1024²",
        id: "topo/run_5inc_281det/1024",
        floor: Some("topo/floor_1024"),
        work: usable(1024) * 5.0,
        unit: Unit::Rays,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Topographic model, 5 incidences × 281 detectors",
        size: "4096²",
        id: "topo/run_5inc_281det/4096",
        floor: Some("topo/floor_4096"),
        work: usable(4096) * 5.0,
        unit: Unit::Rays,
        target: Some(Target::MaxSeconds(1.5)),
        target_note: "< 1.5 s, 2 cores",
        quick: false,
    },
    RowSpec {
        operation: "Flake segmentation",
        size: "2048²",
        id: "segment/2048x2048",
        floor: Some("segment/floor_2048x2048"),
        work: square(2048),
        unit: Unit::Pixels,
        target: Some(Target::MaxSeconds(1.0)),
        target_note: "< 1 s, 2 cores",
        quick: true,
    },
    RowSpec {
        operation: "Read X3P (float64, deflate)",
        size: "4096²",
        id: "read_x3p/4096x4096_f64",
        floor: Some("read_x3p/floor_4096x4096_f64"),
        work: square(4096) * 8.0,
        unit: Unit::Bytes,
        target: Some(Target::MaxSeconds(1.0)),
        target_note: "< 1 s",
        quick: true,
    },
    RowSpec {
        operation: "Synthetic layer (defaults)",
        size: "512²",
        id: "generate/512_default",
        floor: Some("generate/floor_512"),
        work: square(512),
        unit: Unit::Pixels,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Synthetic layer (defaults)",
        size: "2048²",
        id: "generate/2048_default",
        floor: Some("generate/floor_2048"),
        work: square(2048),
        unit: Unit::Pixels,
        target: Some(Target::MaxSeconds(2.0)),
        target_note: "< 2 s",
        quick: true,
    },
    RowSpec {
        operation: "Synthetic layer (roughness, PSF, noise)",
        size: "2048²",
        id: "generate/2048_rough_psf_noise",
        floor: Some("generate/floor_2048"),
        work: square(2048),
        unit: Unit::Pixels,
        target: None,
        target_note: "",
        quick: false,
    },
];

/// A measured row: the spec with what criterion reported.
#[derive(Debug, Clone)]
pub struct Row {
    /// The row's specification.
    pub spec: RowSpec,
    /// Median time per iteration, seconds (`Err`: why it is missing).
    pub median_s: Result<f64, String>,
    /// Median time of the floor, seconds (`None` without a floor; `Err`: missing).
    pub floor_s: Option<Result<f64, String>>,
    /// Median time of the reference of a [`Target::MaxTimes`], seconds (`None` for
    /// other targets; `Err`: missing).
    pub reference_s: Option<Result<f64, String>>,
}

impl Row {
    /// Throughput in units per second (bytes per second for [`Unit::Bytes`]).
    #[must_use]
    pub fn per_second(&self) -> Option<f64> {
        self.median_s.as_ref().ok().map(|&t| self.spec.work / t)
    }

    /// Whether the target is met: `None` without a target or a measurement.
    #[must_use]
    pub fn met(&self) -> Option<bool> {
        let t = *self.median_s.as_ref().ok()?;
        match self.spec.target? {
            Target::MaxSeconds(max) => Some(t <= max),
            Target::MinPerSecond(min) => Some(self.spec.work / t >= min),
            Target::MaxTimes { times, .. } => {
                let r = *self.reference_s.as_ref()?.as_ref().ok()?;
                Some(t <= times * r)
            }
        }
    }

    /// Median time over floor median time, when both were measured.
    #[must_use]
    pub fn ratio(&self) -> Option<f64> {
        let t = *self.median_s.as_ref().ok()?;
        let f = *self.floor_s.as_ref()?.as_ref().ok()?;
        (f > 0.0).then(|| t / f)
    }
}

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

/// Reads every row of `specs` from `criterion_dir`, pairing each with its floor.
#[must_use]
pub fn build_rows(criterion_dir: &Path, specs: &[RowSpec], since: Option<SystemTime>) -> Vec<Row> {
    specs
        .iter()
        .map(|&spec| Row {
            spec,
            median_s: read_median(criterion_dir, spec.id, since),
            floor_s: spec.floor.map(|f| read_median(criterion_dir, f, since)),
            reference_s: match spec.target {
                Some(Target::MaxTimes { of, .. }) => Some(read_median(criterion_dir, of, since)),
                _ => None,
            },
        })
        .collect()
}

/// A time in seconds with a readable unit: `4.56 µs`, `6.40 ms`, `1.23 s`.
#[must_use]
pub fn format_time(s: f64) -> String {
    let (v, unit) = if s >= 1.0 {
        (s, "s")
    } else if s >= 1e-3 {
        (s * 1e3, "ms")
    } else if s >= 1e-6 {
        (s * 1e6, "µs")
    } else {
        (s * 1e9, "ns")
    };
    format!("{} {unit}", three_digits(v))
}

/// A throughput with an SI prefix: `20.2 M evaluations/s`, `512 MB/s`.
#[must_use]
pub fn format_rate(per_second: f64, unit: Unit) -> String {
    if unit == Unit::Bytes {
        return format!("{} MB/s", three_digits(per_second / 1e6));
    }
    let (v, prefix) = if per_second >= 1e9 {
        (per_second / 1e9, "G ")
    } else if per_second >= 1e6 {
        (per_second / 1e6, "M ")
    } else if per_second >= 1e3 {
        (per_second / 1e3, "k ")
    } else {
        (per_second, "")
    };
    format!("{} {prefix}{}", three_digits(v), unit.per_second())
}

/// Three significant digits for values in `[1, 1000)` (more digits above).
fn three_digits(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// The table as GitHub-flavoured Markdown, followed by the reasons for any missing row.
#[must_use]
pub fn render_table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| Operation | Size | Median time | Throughput | Target | Met | Floor median | Time / floor |\n\
         |---|---|---:|---:|---|:---:|---:|---:|\n",
    );
    let mut missing = Vec::new();
    for row in rows {
        let spec = &row.spec;
        let (median, rate) = match &row.median_s {
            Ok(t) => (format_time(*t), format_rate(spec.work / t, spec.unit)),
            Err(why) => {
                missing.push(format!("`{}`: {why}", spec.id));
                ("not measured".to_owned(), "—".to_owned())
            }
        };
        let target = if spec.target.is_some() {
            spec.target_note.to_owned()
        } else {
            "—".to_owned()
        };
        let met = match row.met() {
            Some(true) => "yes",
            Some(false) => "no",
            None => "—",
        };
        let floor = match &row.floor_s {
            None => "—".to_owned(),
            Some(Ok(f)) => format_time(*f),
            Some(Err(why)) => {
                missing.push(format!("floor `{}`: {why}", spec.floor.unwrap_or("")));
                "not measured".to_owned()
            }
        };
        let ratio = row
            .ratio()
            .map_or_else(|| "—".to_owned(), |r| format!("{}×", three_digits(r)));
        let _ = writeln!(
            s,
            "| {} | {} | {median} | {rate} | {target} | {met} | {floor} | {ratio} |",
            spec.operation, spec.size
        );
    }
    if !missing.is_empty() {
        s.push_str("\nNot measured:\n\n");
        for m in missing {
            let _ = writeln!(s, "* {m}");
        }
    }
    s
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
    // Howard Hinnant's days_from_civil inverse.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02} {hh:02}:{mm:02}")
}

/// The whole `docs/benchmarks.md`.
#[must_use]
pub fn render_document(rows: &[Row], machine: &[(String, String)], quick: bool) -> String {
    let mut s = String::from("# Benchmarks\n\n");
    s.push_str(
        "Generated by `cargo xtask bench` (do not edit by hand). Median time per iteration \
         from criterion; throughput is the work of one iteration over that median; targets \
         are those of the issues. The floor is one streaming, single-threaded pass that \
         reads every input value once (a sum of the map's heights; for the X3P read, the \
         file's bytes read into memory and summed), measured on the same input in the same \
         run: `time / floor` says how far an operation is from memory-bound and stays \
         comparable on a noisy machine where absolute times are not. For the synthetic \
         layer, which has no input map, the floor is one pass over its output.\n\n",
    );
    if quick {
        s.push_str(
            "**Quick run** (criterion `--quick`, at most 2 s per benchmark, no 4096² topographic maps, no rough layer): \
             indicative only.\n\n",
        );
    }
    s.push_str("## Machine\n\n");
    for (k, v) in machine {
        let _ = writeln!(s, "* {k}: {v}");
    }
    s.push_str("\n## Results\n\n");
    s.push_str(&render_table(rows));
    s.push_str(
        "\nRays = usable pixels (complete 5 × 5 window) × incidences; detectors = \
         incidences × detector cones; MB = 10⁶ bytes of float64 heights. A load average \
         above the number of cores means other work shared the machine: compare the \
         `time / floor` column rather than absolute times. Reproduce with \
         `cargo xtask bench` (about 5 minutes on 2 cores once the benches are built) or \
         `cargo xtask bench --quick` (under a minute once built, written to \
         `target/benchmarks-quick.md`).\n",
    );
    s
}

/// Options of the `bench` task.
#[derive(Debug, Default, Clone, Copy)]
struct Options {
    quick: bool,
    report_only: bool,
}

fn parse(args: &[String]) -> anyhow::Result<Options> {
    let mut o = Options::default();
    for a in args {
        match a.as_str() {
            "--quick" => o.quick = true,
            "--report-only" => o.report_only = true,
            other => bail!(
                "unknown option `{other}` for `cargo xtask bench` \
                 (expected --quick and/or --report-only)"
            ),
        }
    }
    Ok(o)
}

/// The cargo target directory (`CARGO_TARGET_DIR`, else `<root>/target`).
fn target_dir(root: &Path) -> PathBuf {
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
fn run_benches(cargo: &str, root: &Path, quick: bool) -> anyhow::Result<Vec<String>> {
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

/// Entry point of `cargo xtask bench`.
///
/// # Errors
/// Bad options, a `cargo bench` command that failed, or an output file not writable.
pub fn run(args: &[String]) -> anyhow::Result<()> {
    let opts = parse(args)?;
    let root = crate::workspace_root();
    let target = target_dir(&root);
    // Criterion writes under $CRITERION_HOME when set, else <target>/criterion.
    let criterion_dir = std::env::var_os("CRITERION_HOME")
        .map_or_else(|| target.join("criterion"), |d| root.join(d));
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_owned());
    let start = SystemTime::now();
    let clock = Instant::now();
    let failed = if opts.report_only {
        Vec::new()
    } else {
        run_benches(&cargo, &root, opts.quick)?
    };
    let specs: Vec<RowSpec> = ROWS
        .iter()
        .filter(|r| r.quick || !opts.quick)
        .copied()
        .collect();
    let since = (!opts.report_only).then_some(start);
    let rows = build_rows(&criterion_dir, &specs, since);
    let machine = machine_description(&root);
    let doc = render_document(&rows, &machine, opts.quick);
    let out = if opts.quick {
        target.join("benchmarks-quick.md")
    } else {
        root.join("docs").join("benchmarks.md")
    };
    println!("{}", render_table(&rows));
    for row in rows.iter().filter(|r| r.met() == Some(false)) {
        if let Ok(t) = row.median_s {
            eprintln!(
                "xtask bench: target not met: {} {}: {} ({})",
                row.spec.operation,
                row.spec.size,
                format_time(t),
                row.spec.target_note
            );
        }
    }
    // Without a run the machine's date and load would not describe the numbers: print only.
    if !opts.report_only {
        if let Some(dir) = out.parent() {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
        }
        std::fs::write(&out, doc).with_context(|| format!("cannot write {}", out.display()))?;
        eprintln!(
            "xtask bench: wrote {} ({:.0} s in all)",
            out.display(),
            clock.elapsed().as_secs_f64()
        );
    }
    if !failed.is_empty() {
        bail!("benches failed: {}", failed.join(", "));
    }
    Ok(())
}
