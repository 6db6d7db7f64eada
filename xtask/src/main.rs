//! Project automation, run as `cargo xtask <task>`.

/// One line per task: name and what it does.
const TASKS: &[(&str, &str)] = &[
    ("help", "this text"),
    (
        "bench [--quick]",
        "run the criterion benches; table vs targets and floors -> docs/benchmarks.md \
         (--quick: under 2 min, -> target/benchmarks-quick.md; --report-only: print the \
         last results, run nothing; --streamed: only the peak memory of `topo` and `stats \
         --pixel-normals-only` streaming a 16,384² Zarr store; --streamed=LABEL: only the \
         rows whose label starts with LABEL, e.g. --streamed=stats)",
    ),
    (
        "figures",
        "run `flakescatter reproduce` (the paper's Figs. 4, 7, 9, 10 in kind) into docs/figures",
    ),
    (
        "fixtures [--check]",
        "regenerate the synthetic maps in fixtures/ (--check: only verify they are current)",
    ),
];

fn usage() -> String {
    let mut s = String::from("usage: cargo xtask <task>\n\ntasks:\n");
    for (name, what) in TASKS {
        s.push_str(&format!("  {name:<20} {what}\n"));
    }
    s
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let task = args.next();
    let rest: Vec<String> = args.collect();
    match task.as_deref() {
        None | Some("help" | "--help" | "-h") => {
            print!("{}", usage());
            Ok(())
        }
        Some("bench") => xtask::bench::run(&rest),
        Some("figures") => xtask::figures::run(&rest),
        Some("fixtures") => xtask::fixtures::run(&rest),
        Some(other) => anyhow::bail!("unknown xtask `{other}`\n\n{}", usage()),
    }
}
