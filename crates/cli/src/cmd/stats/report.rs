//! What `stats` reports besides the histogram: the JSON of a pooled sample and the
//! `--json` summary of a sample, the per-map table (`--per-map`) and the histogram
//! plot with the fitted Gaussian.

use flakescatter::PixelOrientation;
use flakescatter::chart::histogram_chart;
use flakescatter::pooled_json;
use flakescatter::sample::SampleStatistics;
use flakescatter::stats::fit::WidthFit;
use flakescatter::stats::histogram::AreaHistogram;
use flakescatter::stats::pool::PooledWidth;
use serde_json::{Value, json};

use super::Args;
use crate::output::{Dest, Plan};
use crate::tables::num;

pub(super) use flakescatter::pooled_json::ci_deg;

/// The JSON of a pooled sample.
fn pooled_json(p: &PooledWidth, names: &[String]) -> Value {
    let flake = &p.flake_level;
    json!({
        "hwhm_deg": flake.hwhm().to_degrees(),
        "sigma_deg": flake.sigma.to_degrees(),
        "hwhm_ci95_deg": ci_deg(flake.hwhm_ci95()),
        "hwhm_ci95_method": format!("flake level: {}", flake.ci_method.describe()),
        "effective_flakes": flake.effective_n,
        "map_level": pooled_json::map_level(p),
        "quoted_interval": pooled_json::quoted_interval(p),
        "heterogeneity": pooled_json::heterogeneity(p),
        "z_bound": p.z_bound,
        "maps": pooled_json::maps(p, names),
        "warnings": p.warnings.iter().map(ToString::to_string).collect::<Vec<_>>(),
    })
}

/// Writes the per-map table.
pub(super) fn write_per_map(
    w: &mut dyn std::io::Write,
    p: &PooledWidth,
    names: &[String],
) -> anyhow::Result<()> {
    let mut out = csv::Writer::from_writer(w);
    out.write_record([
        "map",
        "flakes",
        "area_um2",
        "effective_flakes",
        "hwhm_deg",
        "hwhm_ci95_lo_deg",
        "hwhm_ci95_hi_deg",
        "z",
        "flagged",
    ])?;
    for (m, name) in p.maps.iter().zip(names) {
        let (h, lo, hi) = m.fit.map_or((f64::NAN, f64::NAN, f64::NAN), |f| {
            let ci = f.hwhm_ci95();
            (f.hwhm().to_degrees(), ci.0.to_degrees(), ci.1.to_degrees())
        });
        out.write_record([
            name.clone(),
            m.flakes.to_string(),
            num(m.area_um2),
            num(m.effective_n),
            num(h),
            num(lo),
            num(hi),
            m.z.map(num).unwrap_or_default(),
            m.flagged.to_string(),
        ])?;
    }
    out.flush()?;
    Ok(())
}

/// The histogram plot, when asked for: the flake histogram with the ML Gaussian and the
/// quoted interval's band.
pub(super) fn write_plot(
    plan: &mut Plan,
    plot: Option<&Dest>,
    hist: &AreaHistogram,
    fit: Option<&WidthFit>,
    pooled: Option<&PooledWidth>,
    what: &str,
) -> anyhow::Result<()> {
    let (Some(Dest::File(path)), Some(fit)) = (plot, fit) else {
        return Ok(());
    };
    let (ci, which) = match pooled.and_then(|p| p.map_level) {
        Some(m) => (m.sigma_ci95, "map level"),
        None => (fit.sigma_ci95, "flake level"),
    };
    let chart = histogram_chart(
        hist,
        fit.sigma,
        ci,
        which,
        &format!("Area-weighted flake tilts, {what}"),
    );
    let bytes = crate::plot::encode(path, &chart)?;
    plan.write(
        &Dest::File(path.clone()),
        |w| Ok(w.write_all(&bytes)?),
        None,
    )
}

/// The `pixel_level` object of the `--json` summary (`--pixel-normals`,
/// `--pixel-normals-only`).
pub(super) fn pixel_level(args: &Args, o: &PixelOrientation) -> Value {
    json!({
        "usable_pixels": o.tilts.usable_pixels,
        "pixels": o.tilts.pixels,
        "histogram_fit_hwhm_deg": o.histogram_fit.as_ref().ok().map(|h| h.hwhm().to_degrees()),
        "histogram_fit_error": o.histogram_fit.as_ref().err(),
        "histogram_fit_method": "least squares on the histogram's p_tilde (dominated by the core)",
        "hwhm_deg": o.width.map(|w| w.hwhm().to_degrees()),
        "hwhm_ci95_deg": o.width.map(|w| ci_deg(w.hwhm_ci95())),
        "hwhm_method": "maximum likelihood over all usable pixels (moment matching of θ²), interval from the spread between tiles of --tile-um",
        "window": args.window,
        "tile_um": args.tile_um,
    })
}

/// The `--json` summary of a sample.
pub(super) fn summary(
    args: &Args,
    names: &[String],
    sources: &[flakescatter::inputs::MapSource],
    stats: &SampleStatistics,
) -> Value {
    let p = &stats.pooled;
    let mut s = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "input": {
            "flakes_file": Value::Null,
            "map": names[0],
            "intensity": sources[0].intensity.as_ref().map(|p| p.display().to_string()),
            "cutoff": args.input.cutoff,
            "inputs": args.input.echo(sources),
            "column_set": "segmented map",
            "bin_deg": args.bin,
            "z_step_um": args.segment.z_step_um,
            "noise_um": args.segment.noise_um,
            "min_pixels": args.segment.min_pixels,
        },
        "flakes": stats.histogram.flakes(),
        "total_area_um2": stats.histogram.total_area_um2(),
        "fit": "maximum likelihood, Gaussian p_tilde ∝ exp(-θ²/(2 sigma²)) on [0, 90°), area-weighted, all flakes of all maps pooled",
        "histogram_fit_hwhm_deg": stats.histogram_fit.as_ref().ok().map(|h| h.hwhm().to_degrees()),
        "histogram_fit_error": stats.histogram_fit.as_ref().err(),
        "histogram_bins": stats.histogram.bins().len(),
        "histogram_file": args.out.as_ref().map(|p| p.display().to_string()),
        "histogram_of": if stats.pixel.is_some() { "pixel normals" } else { "flakes" },
    });
    if let (Value::Object(o), Value::Object(extra)) = (&mut s, pooled_json(p, names)) {
        o.extend(extra);
    }
    if let Some(px) = &stats.pixel {
        s["pixel_level"] = pixel_level(args, &px.orientation);
        s["width_sources"] = match &px.sources {
            Ok(w) => json!({
                "flake_level_hwhm_deg": w.flake.hwhm().to_degrees(),
                "flake_level_hwhm_ci95_deg": ci_deg(w.flake.hwhm_ci95()),
                "flakes": w.flakes,
                "pixel_level_hwhm_deg": w.pixel.map(|p| p.hwhm().to_degrees()),
                "inside_flakes_hwhm_deg": w.inside.hwhm().to_degrees(),
                "inside_flakes_hwhm_ci95_deg": ci_deg(w.inside.hwhm_ci95()),
                "inside_pixels": w.inside.pixels,
                "flake_level_pixel_weighted_sigma_deg": w.flake_sigma_pixel_weighted.to_degrees(),
                "within_flake_sigma_deg": w.within_flake_sigma.map(f64::to_degrees),
                "meaning": "flake level: one plane per segmented flake; pixel level: the local normals of all usable pixels (what the topographic model traces); inside flakes: pixels whose window lies inside one flake; within_flake_sigma = sqrt(s_inside² − s_flake²) with flakes weighted like their pixels: the flakes' own roughness as a tilt spread per component",
            }),
            Err(e) => json!({"error": e}),
        };
    }
    s
}
