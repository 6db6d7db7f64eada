//! `volume` at several wavelengths (`--wavelengths`, or a stack's default): the same
//! layers and rays at each (one seed), composed by
//! [`flakescatter::spectral_volume_curves`]; a `wavelength_nm` column first in the CSV,
//! the energy balance per wavelength and incidence in the JSON.

use anyhow::{Context, bail};
use flakescatter::optics::catalogue::Catalogue;
use flakescatter::optics::dispersion::CoatIndex;
use flakescatter::optics::stack_spec::StackSpec;
use flakescatter::spectral::{FlakeSpectrum, SpectralCoating};
use flakescatter::{Instrument, SpectralVolumeCurves, VolumeCurves, spectral_volume_curves};
use serde_json::{Value, json};

use super::rows::{COLUMNS, push_rows, rows_json, volume_warnings};
use super::settings::explain;
use super::summary::{energy_list, summary};
use super::{Args, Binder, Ready};
use crate::output::{Plan, print_json, warn};
use crate::parse::shortest;

/// Refuses a run of more rows than [`crate::flags::MAX_ROWS`].
pub(super) fn check_rows(instrument: &Instrument, wavelengths: usize) -> anyhow::Result<()> {
    let rows = instrument.theta_i().len() as f64
        * instrument.detectors().len() as f64
        * wavelengths as f64;
    if rows > crate::flags::MAX_ROWS as f64 {
        bail!(
            "--wavelengths with --theta-i and --theta-s: {rows:e} rows is more than the limit of {}",
            crate::flags::MAX_ROWS
        );
    }
    Ok(())
}

/// The coating versus wavelength: the binder's index (--n), the stack of --flake-stack
/// (with --flake-core) or the fixed flake of `ready`.
fn spectral_coating(args: &Args, ready: &Ready) -> anyhow::Result<SpectralCoating> {
    let flake = match &args.flake_stack {
        None => FlakeSpectrum::Fixed(ready.coating.flake.clone()),
        Some(text) => {
            let catalogue = Catalogue::builtin();
            let stack = StackSpec::parse(text, &catalogue).context("--flake-stack")?;
            let core = args
                .flake_core
                .as_deref()
                .map(|c| catalogue.parse(c))
                .transpose()
                .context("--flake-core")?;
            FlakeSpectrum::Stack { stack, core }
        }
    };
    Ok(SpectralCoating {
        coat: CoatIndex::Constant(ready.coating.n),
        flake,
        binder: None,
    })
}

/// Runs the model at every wavelength of `nm` (`text` as typed) and writes the CSV and
/// the JSON.
pub(super) fn run_many(
    args: &Args,
    ready: Ready,
    mut plan: Plan,
    binder: Option<&Binder>,
    nm: &[f64],
    text: &str,
) -> anyhow::Result<()> {
    let coating = spectral_coating(args, &ready)?;
    // Every wavelength inside the tables before any work, each refusal naming its flag.
    coating.at_all(nm).map_err(|e| {
        anyhow::anyhow!(
            "--flake-stack {} at --wavelengths {text}: {e}",
            args.flake_stack.as_deref().unwrap_or_default()
        )
    })?;
    if let Some(b) = binder {
        for &w in nm {
            args.alpha_at(b, Some(w))?;
        }
    }
    let rays_total =
        ready.settings.rays as f64 * ready.instrument.theta_i().len() as f64 * nm.len() as f64;
    let bar = crate::output::progress::bar(
        "tracing {bar:40} {pos}/{len} chunks of rays {eta}",
        rays_total > 2e6,
    );
    let progress = |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
    let s = spectral_volume_curves(
        &coating,
        binder.map(|b| &b.table),
        nm,
        &ready.instrument,
        &ready.settings,
        &ready.source,
        &progress,
    )
    .map_err(|e| explain(e, args))?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    // The warnings of all wavelengths' rows together (the layers are the same).
    let mut all = s.curves[0].clone();
    all.rows = s.curves.iter().flat_map(|c| c.rows.clone()).collect();
    let warnings = volume_warnings(&all);
    for w in &warnings {
        warn(w);
    }
    if let Some(dest) = &ready.table {
        let rows = all.rows.len();
        plan.write(
            dest,
            |w| Ok(w.write_all(csv(&s).as_bytes())?),
            Some(format!("{rows} rows")),
        )?;
    }
    plan.finish()?;
    if args.json {
        let mut j = json_summary(args, &ready, &s, binder, text);
        j["warnings"] = json!(warnings);
        if ready.table.is_none() {
            j["rows"] = rows_of(&s);
        } else {
            j["row_count"] = json!(all.rows.len());
        }
        print_json(&j)?;
    }
    Ok(())
}

/// The CSV: `wavelength_nm` then the columns of a one-wavelength run.
fn csv(s: &SpectralVolumeCurves) -> String {
    let mut text = format!("wavelength_nm,{}\n", COLUMNS.join(","));
    for (w, c) in s.wavelengths_nm.iter().zip(&s.curves) {
        push_rows(&mut text, c, Some(&shortest(*w)));
    }
    text
}

/// The rows of every wavelength as JSON objects (`wavelength_nm` added to each).
fn rows_of(s: &SpectralVolumeCurves) -> Value {
    let mut rows = Vec::new();
    for (w, c) in s.wavelengths_nm.iter().zip(&s.curves) {
        if let Value::Array(r) = rows_json(c) {
            for mut v in r {
                v["wavelength_nm"] = json!(w);
                rows.push(v);
            }
        }
    }
    Value::Array(rows)
}

/// The `--json` summary of a spectral run: that of one wavelength (the layers and
/// settings are shared) with the wavelengths, the energy balance per wavelength and
/// incidence, and the binder's coefficient at each wavelength.
fn json_summary(
    args: &Args,
    ready: &Ready,
    s: &SpectralVolumeCurves,
    binder: Option<&Binder>,
    text: &str,
) -> Value {
    let first: &VolumeCurves = &s.curves[0];
    let mut j = summary(
        args,
        &ready.instrument_args,
        first,
        ready.orientation_echo.clone(),
    );
    let energy: Vec<Value> = s
        .wavelengths_nm
        .iter()
        .zip(&s.curves)
        .flat_map(|(w, c)| {
            energy_list(c, binder.is_some())
                .into_iter()
                .map(move |mut v| {
                    v["wavelength_nm"] = json!(w);
                    v
                })
        })
        .collect();
    j["energy"] = json!(energy);
    j["segments"] = json!(s.curves.iter().map(|c| c.segments).sum::<u64>());
    j["wavelengths_nm"] = json!(s.wavelengths_nm);
    j["inputs"]["wavelengths_nm"] = json!(text);
    if let Some(stack) = &args.flake_stack {
        j["inputs"]["flake_index"] = Value::Null;
        j["inputs"]["flake_stack"] = json!(stack);
        j["inputs"]["flake_core"] = json!(args.flake_core);
    }
    if let Some(b) = binder {
        j["inputs"]["binder_absorption"] = b.echo.clone();
        j["binder_alpha_per_um"] = json!(
            s.curves
                .iter()
                .map(|c| c.settings.binder_alpha_per_um)
                .collect::<Vec<_>>()
        );
    }
    j["units"]["columns"]["wavelength_nm"] = json!("nm, in vacuum");
    j["units"]["wavelengths"] = json!(
        "every wavelength is traced through the same layers with the same rays (one seed: common random numbers), so each wavelength's rows and energy balance are those of a run with --wavelength at that wavelength; energy holds one entry per wavelength and incidence"
    );
    j
}
