//! `flakescatter reproduce --out DIR`: the paper's Figs. 4, 7, 9 and 10 in kind, from the
//! shipped fixtures and seeded synthetic layers (composed by
//! [`flakescatter::figures::reproduce`]); this command reads the fixtures, draws the
//! charts and writes the files.
//!
//! Every file is made in a temporary directory beside `--out` first and swapped in
//! when all are complete (`output::owned`), so a failed run leaves neither half a
//! directory nor an empty one, and the directory holds exactly this run's files.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use flakescatter::figures::{Content, FIXTURE_FILES, FIXTURES, FiguresSpec, Fixture, reproduce};
use flakescatter::io::flakes::read_flakes;
use flakescatter::io::{ReadOptions, read_intensity, read_map};
use flakescatter::optics::polarization::Weighting;

use crate::output::{Plan, note};

/// Reproduces the paper's figures in kind (Figs. 4, 7, 9, 10) and the volume model's
/// answer to its multiple-scattering question into a directory: CSV for every curve, SVG
/// and PNG plots, `index.md` and `comparison.json`. Deterministic
/// (fixed seeds); run from the repository root (or give --fixtures).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory: created, or replaced whole when empty or an earlier
    /// `reproduce` output; a directory holding other files (or the fixtures) is refused.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Directory holding the shipped fixtures (`synth-hwhm3-smooth.*`,
    /// `synth-hwhm6-rough.*`).
    #[arg(long, value_name = "DIR", default_value = "fixtures")]
    pub fixtures: PathBuf,
    /// Smaller synthetic "measured" sample (2 maps of 512² pixels instead of 8 of 2048²):
    /// faster, noisier; for tests and quick looks.
    #[arg(long)]
    pub quick: bool,
    /// Ray weighting of every model curve: physical (default), or paper-printed (the
    /// printed eqs. 9/13/14, for the paper's shapes only; physics.md §4).
    #[arg(long, value_name = "K", default_value = "physical")]
    pub weighting: Weighting,
}

fn command_line(args: &Args) -> String {
    let mut c = format!("flakescatter reproduce --out {}", args.out.display());
    if args.fixtures != Path::new("fixtures") {
        let _ = write!(c, " --fixtures {}", args.fixtures.display());
    }
    if args.quick {
        c.push_str(" --quick");
    }
    if args.weighting == Weighting::PaperPrinted {
        c.push_str(" --weighting paper-printed");
    }
    c
}

/// Reads the shipped fixtures; errors name the file.
fn read_fixtures(dir: &Path) -> anyhow::Result<Vec<Fixture>> {
    let opts = ReadOptions::default();
    FIXTURES
        .iter()
        .map(|(stem, _, _)| {
            let file = |suffix: &str| dir.join(format!("{stem}.{suffix}"));
            let (height, _) = read_map(file(FIXTURE_FILES[0]), &opts)
                .with_context(|| format!("reading {}", file(FIXTURE_FILES[0]).display()))?;
            let (intensity, _) = read_intensity(file(FIXTURE_FILES[1]), &opts)
                .with_context(|| format!("reading {}", file(FIXTURE_FILES[1]).display()))?;
            let truth = read_flakes(&file(FIXTURE_FILES[2]))
                .with_context(|| format!("reading {}", file(FIXTURE_FILES[2]).display()))?
                .flakes;
            Ok(Fixture {
                stem: (*stem).to_owned(),
                height,
                intensity,
                truth,
            })
        })
        .collect()
}

/// The owner recorded in the output directory's marker (`output::owned`).
const OWNER: &str = "reproduce";

/// Runs the reproduction (module docs).
pub fn run(args: Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let say = |msg: &str| {
        note(&format!(
            "reproduce [{:5.1} s] {msg}",
            start.elapsed().as_secs_f64()
        ))
    };
    let mut plan = Plan::new();
    plan.input("--fixtures", &args.fixtures);
    plan.output_dir("--out", &args.out, OWNER);
    for (stem, _, _) in FIXTURES {
        for suffix in FIXTURE_FILES {
            let p = args.fixtures.join(format!("{stem}.{suffix}"));
            if !p.is_file() {
                bail!(
                    "--fixtures {}: missing {} (run from the repository root, or point --fixtures at the fixtures/ folder)",
                    args.fixtures.display(),
                    p.display()
                );
            }
            plan.input("--fixtures", &p);
        }
    }
    plan.check()?;
    let fixtures = read_fixtures(&args.fixtures)?;
    let spec = FiguresSpec {
        quick: args.quick,
        weighting: args.weighting,
        command: command_line(&args),
    };
    let report = reproduce(&fixtures, &spec, &say)?;

    // Everything into a staging directory beside --out, swapped in at the end.
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    for file in &report.files {
        match &file.content {
            Content::Text(t) => files.push((file.name.clone().into(), t.clone().into_bytes())),
            Content::Chart(c) => {
                files.push((
                    format!("{}.svg", file.name).into(),
                    crate::plot::svg(c, &file.name)?.into_bytes(),
                ));
                files.push((
                    format!("{}.png", file.name).into(),
                    crate::plot::png(c, &file.name)?,
                ));
            }
        }
    }
    let count = files.len();
    plan.write_dir(
        "--out",
        &args.out,
        OWNER,
        &files,
        Some(format!("{count} files")),
    )?;
    say(&format!(
        "done: {} figures in {}",
        report
            .files
            .iter()
            .filter(|f| matches!(f.content, Content::Chart(_)))
            .count(),
        args.out.display()
    ));
    plan.finish()
}

#[cfg(test)]
mod tests {
    #[test]
    fn command_line_names_only_non_default_flags() {
        let args = super::Args {
            out: "x".into(),
            fixtures: "fixtures".into(),
            quick: true,
            weighting: super::Weighting::Physical,
        };
        assert_eq!(
            super::command_line(&args),
            "flakescatter reproduce --out x --quick"
        );
    }
}
