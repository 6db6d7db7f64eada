//! The `topo --json` summary: the model run's totals (plain or isotropic), their
//! counts and the interpolation error of an isotropic run.

use flakescatter::inputs::MapSource;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::topo::{HeightSource, IsotropicResult, TopoResult, TopoWarning};
use flakescatter::{Curves, MuellerCurves, Polarimetry};
use serde_json::{Value, json};

use super::Args;
use crate::tables::{rows_json, units_json};

/// What the model run gives besides the curves: the plain model's or the isotropic
/// model's totals.
pub(super) enum Totals {
    Plain(TopoResult),
    Isotropic(IsotropicResult),
}

/// What the `--json` summary says of each map.
pub(super) struct MapInfo {
    nx: usize,
    ny: usize,
    dx: f64,
    dy: f64,
    valid: u64,
}

/// The summary's description of maps in memory.
pub(super) fn infos(maps: &[HeightMap]) -> Vec<MapInfo> {
    maps.iter()
        .map(|m| MapInfo {
            nx: m.nx(),
            ny: m.ny(),
            dx: m.dx(),
            dy: m.dy(),
            valid: m.valid_count() as u64,
        })
        .collect()
}

/// The summary's description of streamed maps: sizes and pitches from the sources,
/// the valid points as the run counted them.
pub(super) fn source_infos(sources: &[&dyn HeightSource], totals: &Totals) -> Vec<MapInfo> {
    sources
        .iter()
        .zip(totals.valid_pixels())
        .map(|(s, &valid)| {
            let ((nx, ny), (dx, dy)) = (s.size(), s.pitch());
            MapInfo {
                nx,
                ny,
                dx,
                dy,
                valid,
            }
        })
        .collect()
}

impl Totals {
    /// Valid points per map, as the run counted them.
    pub(super) fn valid_pixels(&self) -> &[u64] {
        match self {
            Self::Plain(r) => &r.valid_pixels,
            Self::Isotropic(r) => &r.valid_pixels,
        }
    }

    pub(super) fn warnings(&self) -> &[TopoWarning] {
        match self {
            Self::Plain(r) => &r.warnings,
            Self::Isotropic(r) => &r.warnings,
        }
    }

    /// The `counts` object of the JSON summary.
    fn counts(&self) -> Value {
        match self {
            Self::Plain(r) => json!({
                "maps": r.maps,
                "pixels": r.pixels,
                "usable_pixels": r.usable_pixels,
                "usable_fraction": r.usable_fraction(),
                "rays_traced": r.rays_traced,
                "rays_lost_tir": r.rays_lost_tir,
                "rays_lost_down": r.rays_lost_down,
                "tiles": r.tiles,
            }),
            Self::Isotropic(r) => json!({
                "maps": r.maps,
                "pixels": r.pixels,
                "usable_pixels": r.usable_pixels,
                "usable_fraction": r.usable_fraction(),
                "rings_traced": r.rings_traced,
                "rings_lost_tir": r.rings_lost_tir,
                "rings_lost_down": r.rings_lost_down,
                "tiles": r.tiles,
                "node_spacing_deg": r.node_spacing.to_degrees(),
                "nodes": r.nodes,
            }),
        }
    }
}

/// The largest interpolation error estimate of an isotropic run, absolute (reflectance
/// units) and relative to the row's reflectance (over rows with light).
fn interpolation_summary(r: &IsotropicResult) -> Value {
    let max = r
        .interpolation_error
        .iter()
        .copied()
        .filter(|e| e.is_finite())
        .fold(0.0, f64::max);
    let max_relative = r
        .interpolation_error
        .iter()
        .zip(&r.points)
        .filter(|(e, p)| e.is_finite() && p.reflectance > 0.0)
        .map(|(e, p)| e / p.reflectance)
        .fold(0.0, f64::max);
    json!({ "max": max, "max_relative": max_relative })
}

/// The `--json` summary (without the rows).
pub(super) fn summary(
    args: &Args,
    sources: &[MapSource],
    maps: &[MapInfo],
    r: &Totals,
    curves: &Curves,
) -> Value {
    let per_map: Vec<Value> = sources
        .iter()
        .zip(maps)
        .map(|(p, m)| {
            json!({
                "file": p.height.display().to_string(),
                "nx": m.nx,
                "ny": m.ny,
                "dx_um": m.dx,
                "dy_um": m.dy,
                "valid_pixels": m.valid,
            })
        })
        .collect();
    let mut s = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "topo",
        "model": curves.model,
        "inputs": {
            "maps": per_map,
            "intensity": sources.iter().filter_map(|s| s.intensity.as_ref().map(|p| p.display().to_string())).collect::<Vec<_>>(),
            "cutoff": args.input.cutoff,
            "pixel_um": args.input.calibration.pixel_um,
            "z_unit": args.input.calibration.z_unit,
            "map_inputs": args.input.echo(sources),
            "window": args.window,
            "tile_um": args.tile_um,
            "isotropic": args.isotropic,
            "node_spacing_deg": args.node_spacing_deg,
            "instrument": args.instrument.echo(),
        },
        "counts": r.counts(),
        "warnings": r.warnings().iter().map(ToString::to_string).collect::<Vec<_>>(),
        "units": {
            "columns": units_json(),
            "rays": "number of rays counted in the detector",
            "std_err": "1/sr, standard error of brdf_per_sr from the spread between map tiles; null (empty in the CSV) when not estimable: fewer than 2 tiles, or no ray in the detector",
            "reflectance_normalisation": "fraction of the incident beam over all pixels of all maps (invalid pixels are black substrate)",
        },
        "out": args.out.as_ref().map(|p| p.display().to_string()),
        "plot": args.plot.as_ref().map(|p| p.display().to_string()),
    });
    if let Totals::Isotropic(iso) = r {
        s["interpolation_error"] = interpolation_summary(iso);
        let units = &mut s["units"];
        units["rays"] = json!(
            "number of usable pixels whose ring of exit directions (every azimuth of the sample) meets the detector"
        );
        units["interpolation_error"] = json!(
            "fraction of the incident beam (reflectance units): estimated error of the row's reflectance from tabulating each ring response on tilt nodes (docs/physics.md §5.1); interpolation_error.max is the largest over the rows, max_relative the largest relative to the row's reflectance"
        );
        units["node_spacing_deg"] =
            json!("degree, spacing of the tilt nodes of the ring-response table");
        units["rings"] = json!(
            "rings_traced: usable pixels x incidences; rings_lost_tir / rings_lost_down: summed azimuth fractions of the rings totally internally reflected / heading down (rays' worth)"
        );
    }
    s
}

/// What a single-angle run gives, as the `--json` report describes it.
pub(super) struct Outcome<'a> {
    pub sources: &'a [MapSource],
    pub maps: &'a [MapInfo],
    pub totals: &'a Totals,
    pub curves: &'a Curves,
    /// The incident and analyser states, with --polarization/--incident/--analyzer.
    pub polarimetry: Option<&'a Polarimetry>,
    /// The Mueller curves of a polarimetric run.
    pub mueller: Option<&'a MuellerCurves>,
    /// The warnings printed on stderr.
    pub warnings: &'a [String],
}

/// The `--json` report of a single-angle run: the summary, its warnings and
/// polarimetry, and the rows when they went nowhere else (`with_rows`) or their count.
pub(super) fn report(args: &Args, o: &Outcome, with_rows: bool) -> Value {
    let mut s = summary(args, o.sources, o.maps, o.totals, o.curves);
    s["warnings"] = json!(o.warnings);
    if let Some(p) = o.polarimetry {
        s["inputs"]["polarimetry"] = args.polarization.echo(p);
        s["polarimetry"] = json!({
            "convention": crate::mueller::CONVENTION,
            "units": crate::mueller::units(args.polarization.elements()),
            "std_err": "1/sr, standard error of the reading brdf_per_sr from the spread between map tiles (the elements' own errors are not written)",
        });
    }
    if with_rows {
        let mut rows = rows_json(o.curves);
        if let (Totals::Isotropic(r), Some(rows)) = (o.totals, rows.as_array_mut()) {
            for (row, e) in rows.iter_mut().zip(&r.interpolation_error) {
                row["interpolation_error"] = json!(e.is_finite().then_some(*e));
            }
        }
        if let Some(mu) = o.mueller {
            crate::mueller::add_to_rows(&mut rows, mu, args.polarization.elements());
        }
        s["rows"] = rows;
    } else {
        s["row_count"] = json!(o.curves.rows.len());
    }
    s
}
