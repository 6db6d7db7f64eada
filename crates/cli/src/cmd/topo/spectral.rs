//! `topo --wavelengths` (the curves at every wavelength) and `topo --multi-angle`
//! (CIELAB per geometry of a set), both from the spectral topographic model.

use anyhow::{Context, bail};
use flakescatter::TopoSettings;
use flakescatter::inputs::MapSource;
use flakescatter::spectral::{MultiAngleSource, multi_angle_colour, spectral_topographic_curves};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::topo::TopoWarning;
use serde_json::json;

use super::summary::{Totals, summary};
use super::{Args, load_maps, progress_bar};
use crate::flags::DEFAULT_WAVELENGTHS;
use crate::output::{Dest, Kind, Plan, print_json, warn};

/// `--wavelengths` without `--multi-angle`: the curves at every wavelength.
pub(super) fn spectral_curves(
    args: &Args,
    sources: &[MapSource],
    mut plan: Plan,
    table: Option<Dest>,
    plot: bool,
    settings: &flakescatter::Settings,
) -> anyhow::Result<()> {
    let (wavelengths, instrument) = args.spectral.curve_run(&args.instrument, plot)?;
    plan.check()?;
    let (coating, coating_echo) = args.spectral.coating(&args.instrument.optics)?;
    let maps = load_maps(args, sources)?;
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let runs = if coating.is_wavelength_independent() {
        1
    } else {
        wavelengths.len()
    };
    let pixels: usize = maps.iter().map(HeightMap::len).sum();
    let bar = progress_bar(pixels as f64 * instrument.theta_i().len() as f64 * runs as f64);
    let progress = |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let s = spectral_topographic_curves(
        &coating,
        &wavelengths,
        &instrument,
        settings,
        &topo,
        &refs,
        &progress,
    )
    .with_context(|| format!("--window {}, --tile-um {}", args.window, args.tile_um))?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut warnings: Vec<String> = s.topo[0]
        .warnings
        .iter()
        .map(|w| format!("{w} (--tile-um {})", args.tile_um))
        .collect();
    let all_missing = s.topo[0]
        .warnings
        .iter()
        .any(|w| matches!(w, TopoWarning::StdErrNotEstimable { .. }));
    crate::spectra::push_curve_warnings(&mut warnings, &s, !all_missing);
    for w in &warnings {
        warn(w);
    }
    if let Some(dest) = &table {
        let n: usize = s.curves.iter().map(|c| c.rows.len()).sum();
        plan.write(
            dest,
            |w| crate::spectra::write_spectral_curves(w, &s, true),
            Some(format!("{n} rows")),
        )?;
    }
    plan.finish()?;
    if args.json {
        let mut j = summary(
            args,
            sources,
            &super::summary::infos(&maps),
            &Totals::Plain(s.topo[0].clone()),
            &s.curves[0],
        );
        j["command"] = json!("topo --wavelengths");
        j["inputs"]["spectral"] = coating_echo;
        j["inputs"]["wavelengths_nm"] = json!(args.spectral.wavelengths_text(""));
        if args.base_albedo.is_some() {
            j["inputs"]["base_albedo"] = json!(settings.base_albedo);
        }
        j["warnings"] = json!(warnings);
        if table.is_none() {
            j["rows"] = crate::spectra::spectral_rows_json(&s);
        } else {
            j["row_count"] = json!(s.curves.iter().map(|c| c.rows.len()).sum::<usize>());
        }
        print_json(&j)?;
    }
    Ok(())
}

/// `--multi-angle`: CIELAB per geometry of the set, from the spectral topographic model.
pub(super) fn multi_angle(
    args: &Args,
    sources: &[MapSource],
    mut plan: Plan,
    table: Option<Dest>,
    plot: bool,
    settings: &flakescatter::Settings,
) -> anyhow::Result<()> {
    if plot {
        bail!("--plot draws curves; it does not apply to --multi-angle");
    }
    if args.instrument.theta_s.is_some() || args.instrument.detectors.is_some() {
        bail!(
            "--theta-s/--detectors do not apply to --multi-angle: its detectors are the geometry set's aspecular angles"
        );
    }
    let spectra = plan.output(
        "--spectra-out",
        args.geometry.spectra_out.as_deref(),
        Kind::Table,
    );
    let set = args.geometry.set(args.instrument.theta_i.as_deref())?;
    let aperture = args.instrument.optics.aperture_rad()?;
    let wavelengths = args
        .spectral
        .wavelengths_nm(Some(DEFAULT_WAVELENGTHS))?
        .unwrap_or_default();
    args.spectral.validate()?;
    plan.check()?;
    let (coating, coating_echo) = args.spectral.coating(&args.instrument.optics)?;
    let maps = load_maps(args, sources)?;
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let runs = if coating.is_wavelength_independent() {
        1
    } else {
        wavelengths.len()
    };
    let pixels: usize = maps.iter().map(HeightMap::len).sum();
    let bar = progress_bar(pixels as f64 * set.incidences().len() as f64 * runs as f64);
    let progress = |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let m = multi_angle_colour(
        &coating,
        settings,
        MultiAngleSource::Topographic {
            topo: &topo,
            maps: &refs,
        },
        &set,
        aperture,
        &wavelengths,
        args.colour.illuminant(),
        args.colour.observer(),
        &progress,
    )
    .with_context(|| {
        format!(
            "--multi-angle (--window {}, --tile-um {})",
            args.window, args.tile_um
        )
    })?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut inputs = json!({
        "maps": sources.iter().map(|p| p.height.display().to_string()).collect::<Vec<_>>(),
        "intensity": sources.iter().filter_map(|s| s.intensity.as_ref().map(|p| p.display().to_string())).collect::<Vec<_>>(),
        "cutoff": args.input.cutoff,
        "map_inputs": args.input.echo(sources),
        "window": args.window,
        "tile_um": args.tile_um,
        "instrument": args.instrument.optics.echo(args.instrument.clearcoat),
        "spectral": coating_echo,
        "wavelengths_nm": args.spectral.wavelengths_text(DEFAULT_WAVELENGTHS),
        "colorimetry": args.colour.echo(),
    });
    if args.base_albedo.is_some() {
        inputs["base_albedo"] = json!(settings.base_albedo);
    }
    crate::spectra::multi_angle_outputs(
        plan,
        "topo --multi-angle",
        &m,
        inputs,
        table.as_ref(),
        spectra.as_ref(),
        args.json,
        args.out.as_deref(),
    )
}
