//! `fit --paint`: one paint (coat, flakes, base) for every incidence, row and channel of
//! a measured BRDF table.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::paint::file::ParamsFile;
use flakescatter::paint::report::{
    fit_and_report, fit_text, in_plane_chart, points_csv, residual_map,
};
use flakescatter::paint::{
    Family, FitExtras, FitOptions, Measurement, PaintFit, Selection, ThicknessFit,
};
use flakescatter::paint_model::FlakeMetal;
use serde_json::json;

use super::Args;
use crate::output::{Kind, Plan, print, print_json, warn};

/// The paint fit's own flags.
#[derive(Debug, Clone, clap::Args)]
pub struct PaintArgs {
    /// Fit a paint (clear coat, flakes, base; physics.md §12) to a BRDF table
    /// (`theta_i_deg, theta_r_deg, phi_r_deg, brdf_<channel>_per_sr`): one parameter set
    /// for every incidence, row and channel.
    #[arg(long)]
    pub paint: bool,
    /// --paint: orientation family, auto (every family, the lowest BIC kept), gaussian,
    /// trowbridge-reitz, pearson-vii or table (a log-linear p~ at fixed knots).
    #[arg(long, value_name = "F", default_value = "auto")]
    pub family: String,
    /// --paint: the flakes' coverage, if known (e.g. from a confocal map), in [0, 1];
    /// default: the middle of the interval the table allows.
    #[arg(long, value_name = "C", allow_negative_numbers = true)]
    pub coverage: Option<f64>,
    /// --paint: no haze population on the coat's surface.
    #[arg(long)]
    pub no_haze: bool,
    /// --paint: smoothness weight of the table family (second differences of ln p~ per
    /// radian), >= 0.
    #[arg(
        long,
        value_name = "X",
        default_value_t = 0.01,
        allow_negative_numbers = true
    )]
    pub smoothing: f64,
    /// --paint: leave out detectors beyond this polar angle, degrees (default 90: none).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub max_theta_r: Option<f64>,
    /// --paint: leave out values below this BRDF, 1/sr (default 0: none).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub min_value: Option<f64>,
    /// --paint: write the fitted paint and the fit's report (JSON) here; `model --params`
    /// and `compare --params` read it.
    #[arg(long, value_name = "FILE")]
    pub params_out: Option<PathBuf>,
    /// --paint: draw measured against fitted in the plane for each incidence and a map
    /// of the out-of-plane residuals into this directory (PNG). The directory is
    /// created, or replaced whole when empty or an earlier plot directory; a directory
    /// holding other files is refused.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// --paint with --flake-stack: fit the thickness of these layers of the stack
    /// (numbered from 1 on the side light arrives on; several move together, e.g. `1,3`
    /// for both TiO2 coats of TiO2/mica/TiO2). The fit starts at the best point of a
    /// scan over --thickness-range (physics.md §12.7).
    #[arg(long, value_name = "LAYERS")]
    pub fit_thickness: Option<String>,
    /// --fit-thickness: the range scanned and the fit's bounds, nm, `LO:HI`
    /// [default: 10:600].
    #[arg(
        long,
        value_name = "LO:HI",
        requires = "fit_thickness",
        allow_hyphen_values = true
    )]
    pub thickness_range: Option<String>,
    /// --paint with a free --flake-stack (no --flake-core): the flakes lie N deep, one
    /// under another, and reflect as a pile of N plates (the light one flake transmits
    /// meets the ones below; physics.md §12.8), 1 to 1000 [default: 1].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub flake_layers: Option<u32>,
    /// --paint with a free --flake-stack: fit the number of flake layers: the whole fit
    /// at every N from 1 to 16, the lowest chi2 kept; the report lists chi2 at each N
    /// (physics.md §12.8).
    #[arg(long, conflicts_with = "flake_layers")]
    pub fit_flake_layers: bool,
    /// --paint with --flake-stack: each colour channel (r, g, b) sees the flakes over a
    /// Gaussian band of this full width at half maximum about its wavelength, nm, in
    /// (0, 400] (the power-weighted mean of the flakes' reflectance every 5 nm within one
    /// width of the centre and 380-780 nm; physics.md §12.7). Default: the channel's one
    /// wavelength.
    #[arg(long, value_name = "NM", allow_negative_numbers = true)]
    pub channel_band: Option<f64>,
    /// --paint: fit the binder's tint over the flakes too: per channel its optical
    /// depth t >= 0 at normal incidence, the flake light attenuated by
    /// exp(-t (1/cos θt + 1/cos θ2)) along the refracted path (physics.md §12.9).
    #[arg(long)]
    pub fit_tint: bool,
}

impl PaintArgs {
    /// `true` when a paint-only flag is set without `--paint`, naming it.
    pub fn stray(&self) -> Option<&'static str> {
        if self.paint {
            return None;
        }
        [
            (self.family != "auto", "--family"),
            (self.coverage.is_some(), "--coverage"),
            (self.no_haze, "--no-haze"),
            (self.smoothing != 0.01, "--smoothing"),
            (self.max_theta_r.is_some(), "--max-theta-r"),
            (self.min_value.is_some(), "--min-value"),
            (self.params_out.is_some(), "--params-out"),
            (self.plot.is_some(), "--plot"),
            (self.fit_thickness.is_some(), "--fit-thickness"),
            (self.flake_layers.is_some(), "--flake-layers"),
            (self.fit_flake_layers, "--fit-flake-layers"),
            (self.channel_band.is_some(), "--channel-band"),
            (self.fit_tint, "--fit-tint"),
        ]
        .into_iter()
        .find(|(set, _)| *set)
        .map(|(_, name)| name)
    }
}

/// `--region LO:HI` for a paint (default 2:180 degrees).
fn region(text: Option<&str>) -> anyhow::Result<(f64, f64)> {
    let Some(text) = text else {
        return Ok(Selection::default().aspecular);
    };
    match text
        .split_once(':')
        .map(|(a, b)| (a.trim().parse::<f64>(), b.trim().parse::<f64>()))
    {
        Some((Ok(lo), Ok(hi))) if lo >= 0.0 && hi > lo && hi <= 180.0 => {
            Ok((lo.to_radians(), hi.to_radians()))
        }
        _ => bail!(
            "--region `{text}`: expected LO:HI in degrees with 0 <= LO < HI <= 180 (default 2:180 with --paint)"
        ),
    }
}

/// The fit's options from the flags (checked before any work).
pub fn options(args: &Args) -> anyhow::Result<FitOptions> {
    let p = &args.paint;
    let optics = &args.measured.optics;
    let refuse = |flag: &str, why: &str| -> anyhow::Result<()> {
        bail!("{flag} does not apply to --paint: {why}")
    };
    if args.nonparametric {
        refuse(
            "--nonparametric",
            "the paint's orientations are a family (--family table is the tabulated one)",
        )?;
    }
    if args.common_scale {
        refuse(
            "--common-scale",
            "a paint has absolute amplitudes per channel, not scales",
        )?;
    }
    if args.out.is_some() && args.measured.measured_multiangle.is_some() {
        refuse("--out", "")?;
    }
    if args.hwhm_start != 4.0 {
        refuse(
            "--hwhm-start",
            "every family starts from the previous one's fit",
        )?;
    }
    if args.measured.clearcoat || args.measured.no_clearcoat {
        refuse(
            "--clearcoat/--no-clearcoat",
            "the coat is part of the paint",
        )?;
    }
    if optics.aperture.is_some_and(|a| a != 0.0) {
        refuse(
            "--aperture",
            "the fit compares point BRDFs with the table (whose detectors are points); give 0 or leave it out",
        )?;
    }
    if optics.transmission != Default::default() || optics.weighting != Default::default() {
        refuse(
            "--transmission/--weighting",
            "a paint uses the exact unpolarised Fresnel factors and the physical weighting",
        )?;
    }
    if !(p.smoothing.is_finite() && p.smoothing >= 0.0) {
        bail!("--smoothing {}: expected a finite value >= 0", p.smoothing);
    }
    if let Some(c) = p.coverage
        && !(0.0..=1.0).contains(&c)
    {
        bail!("--coverage {c}: expected a fraction in [0, 1]");
    }
    if p.fit_tint && p.coverage == Some(0.0) {
        bail!(
            "--fit-tint with --coverage 0: without flakes there is no flake light for a tint to change"
        );
    }
    let mut selection = Selection {
        aspecular: region(args.region.as_deref())?,
        ..Selection::default()
    };
    if let Some(t) = p.max_theta_r {
        if !(t > 0.0 && t <= 90.0) {
            bail!("--max-theta-r {t}: expected a polar angle in (0, 90] degrees");
        }
        selection.max_theta_r = t.to_radians();
    }
    if let Some(v) = p.min_value {
        if !(v.is_finite() && v >= 0.0) {
            bail!("--min-value {v}: expected a BRDF >= 0 (1/sr)");
        }
        selection.min_value = v;
    }
    let coating = optics.coating()?;
    let mut flake_metal = crate::flags::paint_flakes(optics, &args.spectral)?;
    let free_stack = matches!(&flake_metal, FlakeMetal::Stack(s) if s.core.is_none());
    if p.fit_flake_layers && !free_stack {
        bail!(
            "--fit-flake-layers: needs free interference flakes, --flake-stack SPEC without --flake-core (a pile of flakes that transmit nothing is the top flake itself)"
        );
    }
    if let Some(n) = p.flake_layers {
        if !free_stack {
            bail!(
                "--flake-layers {n}: needs free interference flakes, --flake-stack SPEC without --flake-core (a pile of flakes that transmit nothing is the top flake itself)"
            );
        }
        flake_metal = flake_metal
            .with_layers(n)
            .with_context(|| format!("--flake-layers {n}"))?;
    }
    if let Some(w) = p.channel_band {
        flake_metal = flake_metal
            .with_band(Some(w))
            .with_context(|| format!("--channel-band {w}"))?;
    }
    let thickness = thickness(p, &flake_metal)?;
    Ok(FitOptions {
        families: Family::choice(&p.family)
            .map_err(|e| anyhow::anyhow!("--family {}: {e}", p.family))?,
        n: coating.n,
        fit_n: args.fit_n,
        coverage: p.coverage,
        flake_metal,
        selection,
        haze: !p.no_haze,
        smoothing: p.smoothing,
        thickness,
    })
}

/// `--fit-thickness LAYERS` and `--thickness-range LO:HI` (checked against the stack).
fn thickness(p: &PaintArgs, metal: &FlakeMetal) -> anyhow::Result<Option<ThicknessFit>> {
    let Some(text) = p.fit_thickness.as_deref() else {
        return Ok(None);
    };
    if !matches!(metal, FlakeMetal::Stack(_)) {
        bail!("--fit-thickness {text}: needs interference flakes, --flake-stack SPEC");
    }
    let layers = text
        .split(',')
        .map(|v| v.trim().parse::<usize>().ok().filter(|&l| l > 0))
        .collect::<Option<Vec<_>>>()
        .with_context(|| {
            format!("--fit-thickness {text}: expected layer numbers from 1 separated by commas, e.g. 1,3")
        })?;
    let range_text = p.thickness_range.as_deref().unwrap_or("10:600");
    let Some((Ok(lo), Ok(hi))) = range_text
        .split_once(':')
        .map(|(a, b)| (a.trim().parse::<f64>(), b.trim().parse::<f64>()))
    else {
        bail!(
            "--thickness-range {range_text}: expected LO:HI in nm with 0 < LO < HI (default 10:600)"
        );
    };
    let t = ThicknessFit {
        layers,
        range_nm: (lo, hi),
    };
    // The paint fit's own check (range, layers of the stack), named by the flags.
    t.check(metal)
        .with_context(|| format!("--fit-thickness {text} --thickness-range {range_text}"))?;
    Ok(Some(t))
}

/// The owner recorded in a plot directory's marker (`output::owned`).
const PLOT_OWNER: &str = "fit --paint --plot";

/// Runs `fit --paint`.
pub fn run(args: &Args, mut plan: Plan) -> anyhow::Result<()> {
    let opts = options(args)?;
    let p = &args.paint;
    let params_out = plan.output("--params-out", p.params_out.as_deref(), Kind::Table);
    let out = plan.output("--out", args.out.as_deref(), Kind::Table);
    if let Some(dir) = &p.plot {
        plan.output_dir("--plot", dir, PLOT_OWNER);
    }
    plan.check()?;
    let m = args.measured.read_paint()?;
    let extras = FitExtras { tint: p.fit_tint };
    let (fit, report) = fit_and_report(&m, &opts, extras, p.fit_flake_layers)
        .with_context(|| format!("paint fit of {}", m.file))?;
    for w in &fit.warnings {
        warn(&format!("{}: {w}", m.file));
    }
    if let Some(dest) = &params_out {
        let text = ParamsFile::new(&fit.params, Some(report.clone())).to_json()?;
        plan.write(
            dest,
            |w| Ok(w.write_all(text.as_bytes())?),
            Some("the fitted paint".into()),
        )?;
    }
    if let Some(dest) = &out {
        let text = points_csv(&m, &fit.points, &fit.model);
        plan.write(
            dest,
            |w| Ok(w.write_all(text.as_bytes())?),
            Some(format!("{} points", fit.points.len())),
        )?;
    }
    if let Some(dir) = &p.plot {
        let files = plots(&m, &fit)?;
        plan.write_dir(
            "--plot",
            dir,
            PLOT_OWNER,
            &files,
            Some(format!("{} plots", files.len())),
        )?;
    }
    plan.finish()?;
    if args.json {
        print_json(&json!({ "command": "fit --paint", "fit": report }))
    } else {
        print(&(fit_text(&fit).join("\n") + "\n"))
    }
}

/// The plots of `--plot`: one in-plane chart per incidence, one out-of-plane residual map.
pub fn plots(m: &Measurement, fit: &PaintFit) -> anyhow::Result<Vec<(PathBuf, Vec<u8>)>> {
    let mut incidences: Vec<f64> = Vec::new();
    for p in &fit.points {
        let t = m.rows[p.row].theta_i;
        if !incidences.contains(&t) {
            incidences.push(t);
        }
    }
    incidences.sort_by(f64::total_cmp);
    let mut files = Vec::new();
    for &t in &incidences {
        let chart = in_plane_chart(m, &fit.points, &fit.model, t);
        if chart.series.iter().all(|s| s.points.is_empty()) {
            continue;
        }
        let name = format!("in_plane_theta_i_{}.png", fmt_deg(t));
        files.push((PathBuf::from(&name), crate::plot::png(&chart, &name)?));
    }
    let maps: Vec<crate::plot::ResidualPanel> = incidences
        .iter()
        .map(|&t| (t, residual_map(m, &fit.points, &fit.model, t)))
        .filter(|(_, cells)| !cells.is_empty())
        .collect();
    if !maps.is_empty() {
        let name = "out_of_plane_residuals.png";
        files.push((
            PathBuf::from(name),
            crate::plot::residual_maps_png(&maps, &m.file, name)?,
        ));
    }
    Ok(files)
}

/// An angle in degrees for a file name (`30`, `12.5`).
fn fmt_deg(t: f64) -> String {
    let d = (t.to_degrees() * 1e6).round() / 1e6;
    format!("{d}")
}
