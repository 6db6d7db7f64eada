//! The `flakescatter` command-line tool.
//!
//! Degrees live here and only here: every flag and file column in degrees is converted
//! to radians before it reaches a library crate (`docs/architecture.md`).

use std::process::ExitCode;

use clap::{FromArgMatches, Parser, Subcommand};

mod cmd;
mod common;
mod flags;
mod maps;
mod mueller;
mod negative_values;
mod number;
mod output;
mod parse;
mod picture;
mod plot;
mod spectra;
mod tables;

/// Predict how a metallic (aluminium-flake) coating reflects light at every angle.
///
/// Angles are in degrees on the command line; in-plane scattering angles are signed,
/// with `theta_s = -theta_i` the specular direction (see docs/physics.md).
#[derive(Debug, Parser)]
#[command(name = "flakescatter", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Distribution model: reflectance from a flake orientation distribution (eqs. 9-13, corrected).
    Model(cmd::model::Args),
    /// Measured goniometric curve against a model: fitted scale, residuals per region.
    Compare(cmd::compare::Args),
    /// Fit the flake orientation distribution (Gaussian width or tabulated) to a measured curve.
    Fit(cmd::fit::Args),
    /// The paper's Figs. 4, 7, 9, 10 in kind (CSV, SVG, PNG, index.md) from the fixtures and seeded synthetic layers.
    Reproduce(cmd::reproduce::Args),
    /// Topographic model: ray tracing over confocal height maps, accumulated.
    Topo(Box<cmd::topo::Args>),
    /// What a height-map file holds: size, pitch, valid points, height statistics, metadata.
    Info(cmd::info::Args),
    /// Convert a height map (any readable format) to X3P, SDF or text, by OUT's extension.
    Convert(cmd::convert::Args),
    /// Find individual flakes in a confocal height map: flake table with normals and areas.
    Segment(cmd::segment::Args),
    /// Synthetic flake layer with known truth: height map, intensity map, flake table, confocal z-stack.
    Synth(cmd::synth::Args),
    /// Confocal z-stack (multi-page TIFF) to height, intensity and peak-width maps, localised between slices.
    Stack(cmd::stack::Args),
    /// Flake orientation statistics: area-weighted histogram and fitted Gaussian width.
    Stats(cmd::stats::Args),
    /// Volume model: a 3-D flake layer with multiple scattering, curves split by history, energy balance.
    Volume(cmd::volume::Args),
    /// Colour of reflectance spectra (XYZ, CIELAB, L*C*h) and ΔE from a reference, per geometry for multi-angle files.
    Colour(cmd::colour::Args),
    /// Thin-film (interference) flakes: amplitude and power reflection and transmission of a layer stack over angles and wavelengths.
    Film(cmd::film::Args),
    /// A model's BRDF as a table for renderers and BRDF tools (MERL isotropic format).
    Export(cmd::export::Args),
    /// A sample from its manifest (maps, measured curve) to a report: statistics, models, comparison, fit.
    Analyze(cmd::analyze::Args),
}

fn main() -> ExitCode {
    let mut command = negative_values::command();
    let parsed = command
        .try_get_matches_from_mut(std::env::args_os())
        .and_then(|m| {
            Cli::from_arg_matches(&m)
                .map(|cli| (cli, m))
                .map_err(|e| e.format(&mut command))
        });
    let (cli, matches) = match parsed {
        Ok(parsed) => parsed,
        Err(e) => return common::clap_exit(&e),
    };
    // Flags that act only in another mode are refused before any work (flags/modes.rs),
    // on the matches just parsed (the same rules for values that start with `-`).
    if let Err(err) = flags::modes::check(&command, &matches) {
        return common::report(&err);
    }
    let result: anyhow::Result<()> = match cli.command {
        Command::Model(a) => cmd::model::run(a),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Fit(a) => cmd::fit::run(a),
        Command::Reproduce(a) => cmd::reproduce::run(a),
        Command::Topo(a) => cmd::topo::run(*a),
        Command::Info(a) => cmd::info::run(a),
        Command::Convert(a) => cmd::convert::run(a),
        Command::Segment(a) => cmd::segment::run(a),
        Command::Synth(a) => cmd::synth::run(a),
        Command::Stack(a) => cmd::stack::run(a),
        Command::Stats(a) => cmd::stats::run(a),
        Command::Volume(a) => cmd::volume::run(a),
        Command::Colour(a) => cmd::colour::run(a),
        Command::Film(a) => cmd::film::run(a),
        Command::Export(a) => cmd::export::run(a),
        Command::Analyze(a) => cmd::analyze::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => common::report(&err),
    }
}
