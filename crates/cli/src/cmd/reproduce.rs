//! `flakescatter reproduce --out DIR`: the paper's Figs. 4, 7, 9 and 10 in kind, from the
//! shipped fixtures and seeded synthetic layers (composed by
//! [`flakescatter::figures::reproduce`]); this command reads the fixtures, draws the
//! charts and writes the files.
//!
//! Every file is made in a temporary directory beside `--out` first and moved into
//! place when all are complete, so a failed run leaves neither half a directory nor an
//! empty one.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use flakescatter::figures::{Content, FIXTURE_FILES, FIXTURES, FiguresSpec, Fixture, reproduce};
use flakescatter::io::flakes::read_flakes;
use flakescatter::io::{ReadOptions, read_intensity, read_map};
use flakescatter::optics::polarization::Weighting;

use crate::common::Failure;
use crate::output::{Plan, note, temp_dir_beside};

/// Reproduces the paper's figures in kind (Figs. 4, 7, 9, 10) and the volume model's
/// answer to its multiple-scattering question into a directory: CSV for every curve, SVG
/// and PNG plots, `index.md` and `comparison.json`. Deterministic
/// (fixed seeds); run from the repository root (or give --fixtures).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created if missing; the files it gets are replaced).
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
    plan.output_dir("--out", &args.out);
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

    // Everything into a staging directory beside --out, moved into place at the end.
    let stage = temp_dir_beside(&args.out)?;
    let fail =
        |p: &Path, e: &dyn std::fmt::Display| Failure(format!("cannot write {}: {e}", p.display()));
    let mut names = Vec::new();
    for file in &report.files {
        let items: Vec<(String, Vec<u8>)> = match &file.content {
            Content::Text(t) => vec![(file.name.clone(), t.clone().into_bytes())],
            Content::Chart(c) => vec![
                (
                    format!("{}.svg", file.name),
                    crate::plot::svg(c, &file.name)?.into_bytes(),
                ),
                (
                    format!("{}.png", file.name),
                    crate::plot::png(c, &file.name)?,
                ),
            ],
        };
        for (name, bytes) in items {
            let p = stage.path().join(&name);
            std::fs::write(&p, bytes).map_err(|e| fail(&p, &e))?;
            names.push(name);
        }
    }
    if args.out.exists() {
        for name in &names {
            let target = args.out.join(name);
            std::fs::rename(stage.path().join(name), &target).map_err(|e| fail(&target, &e))?;
        }
    } else {
        let staged = stage.keep();
        std::fs::rename(&staged, &args.out).map_err(|e| {
            let _ = std::fs::remove_dir_all(&staged);
            fail(&args.out, &e)
        })?;
    }
    say(&format!(
        "done: {} figures in {}",
        report
            .files
            .iter()
            .filter(|f| matches!(f.content, Content::Chart(_)))
            .count(),
        args.out.display()
    ));
    plan.wrote(&args.out, Some(format!("{} files", names.len())));
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
