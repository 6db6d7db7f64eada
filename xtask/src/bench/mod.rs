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
//! * The full run also measures the peak memory of whole CLI commands on a 4096² map
//!   ([`memory`]) and of `topo` and `stats --pixel-normals-only` streaming a 16,384²
//!   Zarr store ([`streamed`]) and adds those tables to `docs/benchmarks.md`;
//!   `--streamed` measures the streamed rows alone and prints them (no criterion bench,
//!   no file written), `--streamed=LABEL` only those whose label starts with `LABEL`.

mod format;
pub mod memory;
mod rows;
mod runner;
pub mod streamed;

use std::time::{Instant, SystemTime};

use anyhow::{Context, bail};

pub use format::{format_rate, format_time, render_document, render_table};
pub use rows::{
    BenchTarget, LIMITS, Limit, LimitSource, ROWS, Row, RowSpec, TARGETS, Target, Unit,
};
pub use runner::{build_rows, machine_description, read_elements, read_median, utc_date};
use runner::{parse, run_benches, target_dir};

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
    if opts.streamed {
        if opts.quick || opts.report_only {
            bail!("--streamed runs alone: leave out --quick and --report-only");
        }
        println!(
            "{}",
            streamed::render(&streamed::measure(
                &cargo,
                &root,
                &target,
                opts.streamed_only.as_deref()
            )?)
        );
        return Ok(());
    }
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
    let mut doc = render_document(&rows, &machine, opts.quick);
    // Peak memory of whole commands: full runs only (it builds the release CLI and
    // writes two 4096² maps).
    if !opts.quick && !opts.report_only {
        let mem = memory::measure(&cargo, &root, &target)?;
        let section = memory::render(&mem);
        println!("{section}");
        doc.push_str(&section);
        let big = streamed::measure(&cargo, &root, &target, None)?;
        let section = streamed::render(&big);
        println!("{section}");
        doc.push_str(&section);
    }
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
