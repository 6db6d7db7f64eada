//! `cargo xtask figures`: the reproduction run (`flakescatter reproduce`) into
//! `docs/figures/`, the committed figures the README and the user guide show.
//!
//! Builds and runs the command-line tool in release mode from the workspace root
//! (`cargo run --release -p flakescatter-cli -- reproduce --out docs/figures`), so the
//! committed `index.md` records the same command a user would type. The run is
//! deterministic (fixed seeds): rerunning it changes no number.

use std::process::Command;

use anyhow::{Context, bail};

use crate::workspace_root;

/// Entry point of `cargo xtask figures`. Extra arguments are passed to `reproduce`
/// (e.g. `--weighting paper-printed`).
///
/// # Errors
/// If cargo cannot be started or the reproduction fails.
pub fn run(args: &[String]) -> anyhow::Result<()> {
    if args.iter().any(|a| a == "--out") {
        bail!(
            "cargo xtask figures always writes docs/figures; run `flakescatter reproduce --out DIR` for another folder"
        );
    }
    let root = workspace_root();
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
            "docs/figures",
        ])
        .args(args)
        .status()
        .context("cannot run cargo")?;
    if !status.success() {
        bail!("xtask figures: `flakescatter reproduce --out docs/figures` failed ({status})");
    }
    println!("figures written to {}", root.join("docs/figures").display());
    Ok(())
}
