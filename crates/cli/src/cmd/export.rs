//! `flakescatter export`: a model's BRDF as a table for renderers (MERL; formats.md).

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::export::{BrdfSource, SpectralSource, merl_table, paint_rgb};
use flakescatter::io::merl::write_merl;
use flakescatter::pipeline::distribution_model;
use serde_json::json;

use crate::flags::{DEFAULT_WAVELENGTHS, OpticsArgs, OrientationArgs, PaintFlags, SpectralArgs};
use crate::output::{Dest, Kind, Plan, print_json};

/// The table formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// MERL's isotropic table (Matusik et al. 2003): 90 × 90 × 180 bins of (θh, θd, φd),
    /// R, G, B.
    Merl,
}

/// A model's point BRDF tabulated for renderers and BRDF tools: every bin of a MERL
/// isotropic table (90 θh × 90 θd × 180 φd, R, G, B) filled with the BRDF at the bin's
/// centre, sr⁻¹ (docs/formats.md). The model is the distribution model of the orientation
/// and coating flags (grey: R = G = B), or a paint (--params P.json from `fit --paint`,
/// or --paint with its flags; its channels r, g, b, or its one channel as grey), or, with
/// the spectral flags (--wavelengths, --flake-material, --flake-nk, --flake-stack, ...),
/// the distribution model's BRDF spectrum as linear sRGB (CIE 1931 observer, D65). Bins
/// below the horizon are written as MERL does (−1); a smooth clear coat's specular delta
/// cannot be tabulated and is left out.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The table format.
    #[arg(long, value_enum)]
    pub format: Format,
    /// The table file (MERL: `.binary`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    #[command(flatten)]
    pub optics: OpticsArgs,
    #[command(flatten)]
    pub source: OrientationArgs,
    #[command(flatten)]
    pub spectral: SpectralArgs,
    /// A fitted paint (`fit --paint --params-out P.json`): its BRDF per channel (clear
    /// coat, flakes and base; physics.md §12).
    #[arg(long, value_name = "P.json", conflicts_with_all = [
        "hwhm", "sigma", "rms_tilt", "distribution", "orientation", "n",
        "transmission", "weighting", "flake_index",
    ])]
    pub params: Option<PathBuf>,
    #[command(flatten)]
    pub paint: PaintFlags,
    /// Print a JSON summary on stdout (inputs, the table's layout and units, how many
    /// bins hold a value).
    #[arg(long)]
    pub json: bool,
}

/// The flag checks before any work; the wavelengths of a spectral model.
fn check(args: &Args) -> anyhow::Result<Option<Vec<f64>>> {
    if args.optics.aperture.is_some() {
        bail!(
            "--aperture does not apply to export: every bin holds the point BRDF at its centre (an aperture-0 detector)"
        );
    }
    if args.params.is_some() && args.paint.paint {
        bail!("--params and --paint: give the paint either as a parameter file or by flags");
    }
    args.paint.refuse_base_without_paint("export")?;
    let is_paint = args.params.is_some() || args.paint.paint;
    if is_paint
        && (args.optics.transmission != Default::default()
            || args.optics.weighting != Default::default())
    {
        bail!(
            "--transmission and --weighting do not apply to a paint (it uses exact unpolarised Fresnel factors)"
        );
    }
    if is_paint && args.spectral.any() {
        bail!(
            "--params/--paint and the spectral flags: a paint's channels are its own (r, g, b); give one or the other"
        );
    }
    if args.params.is_none() {
        args.source.validate()?;
    }
    Ok(if args.spectral.any() {
        args.spectral.validate()?;
        args.spectral.wavelengths_nm(Some(DEFAULT_WAVELENGTHS))?
    } else {
        None
    })
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    args.source.inputs(&mut plan);
    args.spectral.inputs(&mut plan);
    if let Some(p) = &args.params {
        plan.input("--params", p);
    }
    let out = plan
        .output("--out", Some(&args.out), Kind::Brdf)
        .context("--out is required")?;
    if args.json {
        plan.stdout("--json");
    }
    let wavelengths = check(&args)?;
    plan.check()?;
    let paint = match &args.params {
        Some(path) => Some(crate::cmd::paint::model_of(path)?),
        None if args.paint.paint => {
            let (orientation, _) = args.source.orientation()?;
            let metal = crate::flags::flake_metal(&args.optics)?;
            Some(
                args.paint
                    .model(orientation, args.optics.coating()?.n, metal)?,
            )
        }
        None => None,
    };
    let spectral = match &wavelengths {
        Some(w) => {
            let (coating, _) = args.spectral.coating(&args.optics)?;
            let (orientation, _) = args.source.orientation()?;
            Some(SpectralSource::new(
                &coating,
                &orientation,
                &args.optics.settings(false),
                w,
            )?)
        }
        None => None,
    };
    let flakes = match (&paint, &spectral) {
        (Some(_), _) | (_, Some(_)) => None,
        (None, None) => {
            let (orientation, _) = args.source.orientation()?;
            let coating = args.optics.coating()?;
            let settings = args.optics.settings(false);
            Some(distribution_model(&coating, &settings, orientation)?)
        }
    };
    let source = match (&paint, &spectral, &flakes) {
        (Some(p), _, _) => BrdfSource::Paint {
            model: p,
            rgb: paint_rgb(p).context("--params/--paint")?,
        },
        (None, Some(s), _) => BrdfSource::Spectral(s),
        (None, None, Some(m)) => BrdfSource::Distribution(m),
        (None, None, None) => unreachable!("a paint, a spectrum or the flakes"),
    };
    let bar = crate::output::progress::bar("tabulating {bar:40} {pos}/{len} θh rows {eta}", true);
    let progress = |done: usize, total: usize| {
        crate::output::progress::show(bar.as_ref(), done as u64, total as u64);
    };
    let tabulated = merl_table(&source, &progress)?;
    let table = &tabulated.table;
    if tabulated.clipped > 0 {
        crate::output::warn(&format!(
            "{} bins have a colour outside the sRGB gamut: their negative components are written as 0",
            tabulated.clipped
        ));
    }
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let filled = table.channel(0).iter().filter(|v| **v >= 0.0).count();
    plan.write(
        &out,
        |w| Ok(write_merl(w, table)?),
        Some(format!("{filled} of {} bins", flakescatter::io::merl::BINS)),
    )?;
    plan.finish()?;
    if args.json {
        let model = match &args.params {
            Some(p) => json!({"params": p.display().to_string()}),
            None if args.paint.paint => json!({"paint": flakescatter::paint::file::ParamsFile::new(
                paint.as_ref().map(|p| p.params()).context("the paint")?, None)}),
            None => {
                json!({"distribution": args.source.orientation()?.1, "optics": args.optics.echo(false)})
            }
        };
        let rgb = match source {
            BrdfSource::Paint { model, rgb } => {
                let names: Vec<&str> = rgb
                    .iter()
                    .map(|&k| model.params().channels[k].channel.name.as_str())
                    .collect();
                json!(names)
            }
            BrdfSource::Distribution(_) => json!("grey: the flakes' one BRDF in R, G and B"),
            BrdfSource::Spectral(_) => json!(
                "linear sRGB of the BRDF spectrum: CIE 1931 2° observer, illuminant D65 (ASTM E308 weights), IEC 61966-2-1 matrix; out-of-gamut components written as 0"
            ),
        };
        print_json(&json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "export",
            "format": "merl",
            "out": match &out { Dest::File(p) => p.display().to_string(), Dest::Stdout => "-".into() },
            "model": model,
            "channels_rgb": rgb,
            "layout": {
                "bins": [90, 90, 180],
                "axes": ["theta_h (index floor(90 sqrt(theta_h/(pi/2))))", "theta_d (pi/180 bins over [0, pi/2))", "phi_d (pi/180 bins over [0, pi), folded by reciprocity)"],
                "scale_rgb": flakescatter::io::merl::SCALES,
                "value": "point BRDF at the bin centre, 1/sr, stored divided by the channel's scale; -1 below the horizon",
                "left_out": "the specular delta of a smooth clear coat",
            },
            "filled_bins": filled,
            "out_of_gamut_bins": tabulated.clipped,
        }))?;
    }
    Ok(())
}
