//! `flakescatter volume`: the three-dimensional flake layer with multiple scattering
//! (physics.md §10, issue 20), composed by [`flakescatter::volume_curves`]; this command
//! parses and checks the flags, shows progress, and writes the curves, the energy
//! balance and what the layer realised.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::bail;
use flakescatter::chart::volume_chart;
use flakescatter::volume::{Amount, Depth, Diameter, EnergyBalance, RimRule, Substrate};
use flakescatter::{OrientationSource, PipelineError, VolumeCurves, VolumeSettings, volume_curves};
use serde_json::{Value, json};

use crate::flags::{InstrumentArgs, OpticsArgs, OrientationArgs};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use crate::parse::{deg, deg_num};
use crate::tables::{detector_rad, num};

/// Largest number of rays per incidence (the tracer's limit, 2^40).
const MAX_RAYS: u64 = 1 << 40;
/// Rows whose flake light rests on fewer escapes than this are named in a warning.
const FEW_RAYS: u64 = 100;

/// What a flake's rim does to a ray (physics.md §10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Rims {
    /// Absorbs (broken edges are not mirrors; the share is reported).
    Absorb,
    /// Transparent: the ray passes through the flake.
    Ignore,
    /// Reflects diffusely (cosine law) with the flake's normal-incidence reflectance.
    Diffuse,
}

/// How a substrate of `--substrate-reflectance R > 0` reflects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SubstrateKind {
    /// Cosine law (a diffuse primer); depolarises.
    Lambertian,
    /// A mirror (a polished panel).
    Mirror,
}

/// Multiple scattering in a three-dimensional flake layer: thin circular flakes placed
/// without overlap in a film under a smooth top interface, every ray followed until it
/// escapes or is absorbed (docs/physics.md §10).
///
/// Writes one CSV row per incidence × detector: theta_i_deg, theta_s_deg, phi_s_deg,
/// aperture_deg, brdf_per_sr, reflectance, relative (as `model`), rays (escapes counted
/// in the detector), std_err_per_sr, and the split coat_brdf_per_sr (first surface),
/// single_bounce_brdf_per_sr (one flake reflection) and multiple_bounce_brdf_per_sr
/// (everything else), with standard errors. The defaults are the paper's coating: 38 µm
/// film, 16 µm flakes (relative sd 0.25), 1 µm thick, 5 % aluminium by mass.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Film thickness, µm (the flakes lie wholly inside it).
    #[arg(
        long = "film-um",
        value_name = "UM",
        default_value_t = 38.0,
        allow_negative_numbers = true
    )]
    pub film_um: f64,
    /// Film (binder) refractive index (real, >= 1).
    #[arg(
        long = "n",
        value_name = "X",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub n: f64,
    /// Complex flake index `N,K` (e.g. `0.96,6.69` for aluminium at 550 nm); default a
    /// perfect conductor.
    #[arg(long, value_name = "N,K", allow_hyphen_values = true)]
    pub flake_index: Option<String>,
    /// Mean flake diameter, µm.
    #[arg(
        long = "diameter-um",
        value_name = "UM",
        default_value_t = 16.0,
        allow_negative_numbers = true
    )]
    pub diameter_um: f64,
    /// Relative standard deviation of the log-normal diameters, in [0, 1] (0 = all
    /// equal; truncated to [mean/4, 3 mean]).
    #[arg(
        long = "diameter-rel-sd",
        value_name = "X",
        default_value_t = 0.25,
        allow_negative_numbers = true
    )]
    pub diameter_rel_sd: f64,
    /// Flake thickness, µm.
    #[arg(
        long = "thickness-um",
        value_name = "UM",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub thickness_um: f64,
    /// Flake volume per film volume, in [0, 1) [default: --mass-loading 0.05].
    #[arg(
        long,
        value_name = "X",
        conflicts_with = "mass_loading",
        allow_negative_numbers = true
    )]
    pub volume_fraction: Option<f64>,
    /// Mass fraction of aluminium (2.70 g/cm³) in the dry film, in [0, 1) [default:
    /// 0.05, the paper's loading].
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub mass_loading: Option<f64>,
    /// Density of the dry binder, g/cm³, for --mass-loading [default: 1.2].
    #[arg(long, value_name = "G_CM3", allow_negative_numbers = true)]
    pub binder_density: Option<f64>,
    /// Flake centres uniform between depths A and B (µm below the top interface,
    /// 0 <= A <= B <= --film-um), each restricted so that the flake lies in the film
    /// [default: the whole film].
    #[arg(long = "depth-um", value_name = "A:B", allow_hyphen_values = true)]
    pub depth_um: Option<String>,
    #[command(flatten)]
    pub source: OrientationArgs,
    /// Incidence angles in degrees, in [0, 90): a list `0,30,60`, an inclusive range
    /// `start:stop:step`, or both [default: 0,30,45,60,75].
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_i: Option<String>,
    /// Signed in-plane detector angles in degrees, in (-90, 90); `theta_s = -theta_i`
    /// is specular [default: -70:70:0.5].
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_s: Option<String>,
    /// Out-of-plane detectors: CSV with header `theta_r_deg,phi_r_deg`; replaces
    /// --theta-s.
    #[arg(long, value_name = "FILE", conflicts_with = "theta_s")]
    pub detectors: Option<PathBuf>,
    /// Detector cone half-angle in degrees, in (0, 20] (rays are counted into cones).
    #[arg(
        long,
        value_name = "A",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub aperture: f64,
    /// Rays per incidence (rounded up to a multiple of 64, the batches of the standard
    /// errors).
    #[arg(long, value_name = "N", default_value_t = 1_000_000, value_parser = crate::parse::whole_u64, allow_negative_numbers = true)]
    pub rays: u64,
    /// Seed of the layer and of the rays (separate streams); a run is reproducible
    /// from it alone, for any number of threads.
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = crate::parse::whole_u64, allow_negative_numbers = true)]
    pub seed: u64,
    /// Side of the periodic square tile, µm (larger than the largest flake).
    #[arg(
        long = "tile-um",
        value_name = "UM",
        default_value_t = 1000.0,
        allow_negative_numbers = true
    )]
    pub tile_um: f64,
    /// Reflectance of the substrate under the film, in [0, 1] (0 = black, the default).
    #[arg(
        long,
        value_name = "R",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub substrate_reflectance: f64,
    /// How a reflecting substrate reflects (with --substrate-reflectance > 0).
    #[arg(long, value_enum, value_name = "K", default_value = "lambertian")]
    pub substrate: SubstrateKind,
    /// What flake rims do to a ray.
    #[arg(long, value_enum, value_name = "RULE", default_value = "absorb")]
    pub rims: Rims,
    /// Write the CSV here (`-` = stdout). Without --out and --json the CSV goes to stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout (inputs, energy balance, realised layer, units,
    /// version; the rows unless --out writes them).
    #[arg(long)]
    pub json: bool,
    /// Draw the relative curves and their multiple-scattering part (log axis) to this
    /// .svg or .png file.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

/// Checks a length flag: finite and > 0 µm.
fn positive(flag: &str, v: f64) -> anyhow::Result<f64> {
    if !(v.is_finite() && v > 0.0) {
        bail!("{flag} {v}: expected a finite length > 0 µm");
    }
    Ok(v)
}

/// A fraction flag in [0, 1).
fn fraction(flag: &str, v: f64, what: &str) -> anyhow::Result<f64> {
    if !(v.is_finite() && (0.0..1.0).contains(&v)) {
        bail!("{flag} {v}: expected {what} in [0, 1)");
    }
    Ok(v)
}

impl Args {
    /// The instrument and coating flags in the shape `model` parses them.
    fn instrument_args(&self) -> InstrumentArgs {
        InstrumentArgs {
            optics: OpticsArgs {
                n: self.n,
                aperture: self.aperture,
                transmission: Default::default(),
                weighting: Default::default(),
                flake_index: self.flake_index.clone(),
            },
            theta_i: self.theta_i.clone(),
            theta_s: self.theta_s.clone(),
            detectors: self.detectors.clone(),
            clearcoat: false,
        }
    }

    /// The layer and tracing settings; every error names its flag.
    fn settings(&self) -> anyhow::Result<VolumeSettings> {
        let film = positive("--film-um", self.film_um)?;
        let d = positive("--diameter-um", self.diameter_um)?;
        let sd = self.diameter_rel_sd;
        if !(sd.is_finite() && (0.0..=1.0).contains(&sd)) {
            bail!("--diameter-rel-sd {sd}: expected a relative standard deviation in [0, 1]");
        }
        let t = positive("--thickness-um", self.thickness_um)?;
        if t >= film {
            bail!("--thickness-um {t}: a flake must be thinner than the film (--film-um {film})");
        }
        let amount = match (self.volume_fraction, self.mass_loading) {
            (Some(v), _) => {
                if let Some(b) = self.binder_density {
                    bail!(
                        "--binder-density {b} applies to --mass-loading only; --volume-fraction {v} needs no density"
                    );
                }
                Amount::VolumeFraction(fraction("--volume-fraction", v, "a volume fraction")?)
            }
            (None, m) => {
                let m = fraction("--mass-loading", m.unwrap_or(0.05), "a mass fraction")?;
                let b = self.binder_density.unwrap_or(1.2);
                if !(b.is_finite() && b > 0.0) {
                    bail!("--binder-density {b}: expected a finite density > 0 g/cm³");
                }
                Amount::MassLoading {
                    fraction: m,
                    binder_density_g_cm3: b,
                }
            }
        };
        let depth = match &self.depth_um {
            None => Depth::WholeFilm,
            Some(text) => {
                let parts: Vec<&str> = text.split(':').map(str::trim).collect();
                let values: Option<Vec<f64>> = parts.iter().map(|p| p.parse().ok()).collect();
                let Some([a, b]) = values.as_deref() else {
                    bail!("--depth-um {text}: expected two depths `A:B` in µm, e.g. 0:10");
                };
                let (a, b) = (*a, *b);
                if !(a.is_finite() && b.is_finite() && 0.0 <= a && a <= b) {
                    bail!(
                        "--depth-um {text}: expected finite depths 0 <= A <= B (µm below the top interface)"
                    );
                }
                if b > film {
                    bail!(
                        "--depth-um {text}: B = {b} µm is below the bottom of the film (--film-um {film})"
                    );
                }
                Depth::Uniform {
                    top_um: a,
                    bottom_um: b,
                }
            }
        };
        let tile = positive("--tile-um", self.tile_um)?;
        if self.rays == 0 || self.rays > MAX_RAYS {
            bail!(
                "--rays {}: expected between 1 and 2^40 rays per incidence",
                self.rays
            );
        }
        let r = self.substrate_reflectance;
        if !(r.is_finite() && (0.0..=1.0).contains(&r)) {
            bail!("--substrate-reflectance {r}: expected a reflectance in [0, 1]");
        }
        let substrate = match (r > 0.0, self.substrate) {
            (false, _) => Substrate::Black,
            (true, SubstrateKind::Lambertian) => Substrate::Lambertian(r),
            (true, SubstrateKind::Mirror) => Substrate::Specular(r),
        };
        Ok(VolumeSettings {
            film_um: film,
            diameter: if sd == 0.0 {
                Diameter::Fixed(d)
            } else {
                Diameter::LogNormal {
                    mean_um: d,
                    rel_sd: sd,
                }
            },
            thickness_um: t,
            amount,
            depth,
            tile_um: tile,
            substrate,
            rims: match self.rims {
                Rims::Absorb => RimRule::Absorb,
                Rims::Ignore => RimRule::Ignore,
                Rims::Diffuse => RimRule::Diffuse,
            },
            rays: self.rays,
            seed: self.seed,
            ..VolumeSettings::default()
        })
    }

    /// The flag a loading error is about, as typed.
    fn loading_flag(&self) -> String {
        match (self.volume_fraction, self.mass_loading) {
            (Some(v), _) => format!("--volume-fraction {v}"),
            (None, Some(m)) => format!("--mass-loading {m}"),
            (None, None) => "--mass-loading 0.05 (the default)".to_owned(),
        }
    }
}

/// The facade's error with the flags it is about named.
fn explain(err: PipelineError, args: &Args) -> anyhow::Error {
    use flakescatter::volume::VolumeError as V;
    let flags = match &err {
        PipelineError::Volume(V::LoadingTooHigh { .. } | V::TooManyFlakes { .. }) => format!(
            "{}, --tile-um {}, --film-um {}, --depth-um {}",
            args.loading_flag(),
            args.tile_um,
            args.film_um,
            args.depth_um.as_deref().unwrap_or("(whole film)")
        ),
        PipelineError::Volume(V::TileTooSmall { .. }) => format!(
            "--tile-um {} with --diameter-um {} (largest drawn: 3 × the mean unless --diameter-rel-sd 0)",
            args.tile_um, args.diameter_um
        ),
        PipelineError::Volume(V::DepthRange { .. }) => format!(
            "--depth-um {} with --film-um {}",
            args.depth_um.as_deref().unwrap_or("(whole film)"),
            args.film_um
        ),
        PipelineError::Volume(V::Parameter { name, .. }) => format!("--{}", name.replace('_', "-")),
        _ => return err.into(),
    };
    anyhow::anyhow!("{flags}: {err}")
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    let instrument_args = args.instrument_args();
    instrument_args.inputs(&mut plan);
    args.source.inputs(&mut plan);
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    args.source.validate()?;
    let coating = instrument_args.optics.coating()?;
    if instrument_args.optics.aperture_rad()? <= 0.0 {
        bail!(
            "--aperture 0: the volume model counts rays into detector cones; give a half-angle > 0"
        );
    }
    let settings = args.settings()?;
    let instrument = instrument_args.instrument()?;
    plan.check()?;
    let (orientation, orientation_echo) = args.source.orientation()?;
    let source = OrientationSource::Distribution(orientation);

    // Progress on stderr when it is a terminal and the run is long.
    let rays_total = settings.rays as f64 * instrument.theta_i().len() as f64;
    let bar = (std::io::stderr().is_terminal() && rays_total > 2e6).then(|| {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "tracing {bar:40} {pos}/{len} ray batches {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let progress = |done: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    };
    let curves = volume_curves(&coating, &instrument, &settings, &source, &progress)
        .map_err(|e| explain(e, &args))?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let warnings = volume_warnings(&curves);
    for w in &warnings {
        warn(w);
    }
    let plot_bytes = match &plot {
        Some(Dest::File(p)) => Some((p.clone(), crate::plot::encode(p, &volume_chart(&curves))?)),
        _ => None,
    };
    if let Some(dest) = &table {
        let rows = curves.rows.len();
        plan.write(
            dest,
            |w| write_volume(w, &curves),
            Some(format!("{rows} rows")),
        )?;
    }
    if let Some((p, bytes)) = plot_bytes {
        plan.write(&Dest::File(p), |w| Ok(w.write_all(&bytes)?), None)?;
    }
    plan.finish()?;
    if args.json {
        let mut s = summary(&args, &instrument_args, &curves, orientation_echo);
        s["warnings"] = json!(warnings);
        if table.is_none() {
            s["rows"] = rows_json(&curves);
        } else {
            s["row_count"] = json!(curves.rows.len());
        }
        print_json(&s)?;
    }
    Ok(())
}

/// The CSV columns (docs/cli.md "volume").
pub const COLUMNS: [&str; 14] = [
    "theta_i_deg",
    "theta_s_deg",
    "phi_s_deg",
    "aperture_deg",
    "brdf_per_sr",
    "reflectance",
    "relative",
    "rays",
    "std_err_per_sr",
    "coat_brdf_per_sr",
    "single_bounce_brdf_per_sr",
    "single_bounce_std_err_per_sr",
    "multiple_bounce_brdf_per_sr",
    "multiple_bounce_std_err_per_sr",
];

/// A standard error, empty where no ray reached the detector (not estimable).
fn se(rays: u64, x: f64) -> String {
    if rays == 0 { String::new() } else { num(x) }
}

/// Writes the curve CSV.
fn write_volume(out: &mut dyn Write, c: &VolumeCurves) -> anyhow::Result<()> {
    let mut text = COLUMNS.join(",");
    text.push('\n');
    let aperture = deg(c.instrument.aperture());
    for r in &c.rows {
        let (ts, ps) = detector_rad(&c.instrument, r.detector);
        let cells = [
            deg(r.theta_i),
            deg(ts),
            deg(ps),
            aperture.clone(),
            num(r.brdf),
            num(r.reflectance),
            num(r.relative),
            r.rays.to_string(),
            se(r.rays, r.std_err),
            num(r.coat_brdf),
            num(r.single_bounce_brdf),
            se(r.rays, r.single_bounce_std_err),
            num(r.multiple_bounce_brdf),
            se(r.rays, r.multiple_bounce_std_err),
        ];
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    out.write_all(text.as_bytes())?;
    Ok(())
}

/// Rows as JSON objects (undefined values `null`).
fn rows_json(c: &VolumeCurves) -> Value {
    let finite = |x: f64| x.is_finite().then_some(x);
    let aperture = deg_num(c.instrument.aperture());
    Value::Array(
        c.rows
            .iter()
            .map(|r| {
                let (ts, ps) = detector_rad(&c.instrument, r.detector);
                let se = |x: f64| (r.rays > 0).then_some(x).and_then(finite);
                json!({
                    "theta_i_deg": deg_num(r.theta_i),
                    "theta_s_deg": deg_num(ts),
                    "phi_s_deg": deg_num(ps),
                    "aperture_deg": aperture,
                    "brdf_per_sr": finite(r.brdf),
                    "reflectance": finite(r.reflectance),
                    "relative": finite(r.relative),
                    "rays": r.rays,
                    "std_err_per_sr": se(r.std_err),
                    "coat_brdf_per_sr": finite(r.coat_brdf),
                    "single_bounce_brdf_per_sr": finite(r.single_bounce_brdf),
                    "single_bounce_std_err_per_sr": se(r.single_bounce_std_err),
                    "multiple_bounce_brdf_per_sr": finite(r.multiple_bounce_brdf),
                    "multiple_bounce_std_err_per_sr": se(r.multiple_bounce_std_err),
                })
            })
            .collect(),
    )
}

/// Warnings: undefined `relative`, detectors no ray reached, rows resting on few rays.
fn volume_warnings(c: &VolumeCurves) -> Vec<String> {
    let mut out = Vec::new();
    let mut seen: Vec<f64> = Vec::new();
    for r in c.rows.iter().filter(|r| !r.relative.is_finite()) {
        if !seen.contains(&r.theta_i) {
            seen.push(r.theta_i);
            out.push(format!(
                "theta_i {}°: the detector at the specular direction collects nothing, so `relative` is undefined (empty in the CSV, null in JSON)",
                deg(r.theta_i)
            ));
        }
    }
    let n = c.rows.len();
    let dark = c.rows.iter().filter(|r| r.rays == 0).count();
    if dark > 0 {
        out.push(format!(
            "{dark} of {n} rows: no ray reached the detector, so their flake light is 0 with no standard error (empty std_err cells); more --rays, a wider --aperture or a larger --tile-um"
        ));
    }
    let few = c
        .rows
        .iter()
        .filter(|r| r.rays > 0 && r.rays < FEW_RAYS)
        .count();
    if few > 0 {
        out.push(format!(
            "{few} of {n} rows rest on fewer than {FEW_RAYS} rays (relative standard errors above about 10 %); more --rays would steady them"
        ));
    }
    out
}

fn energy_json(e: &EnergyBalance) -> Value {
    json!({
        "coat_reflected": e.coat_reflected,
        "escaped_single": e.escaped_single,
        "escaped_multiple": e.escaped_multiple,
        "absorbed_substrate": e.absorbed_substrate,
        "absorbed_flakes": e.absorbed_flakes,
        "absorbed_other": e.absorbed_other,
        "absorbed_rims": e.absorbed_rims,
        "cut_off": e.cut_off,
        "escaped_via_substrate": e.escaped_via_substrate,
    })
}

/// The `--json` summary (without the rows).
fn summary(args: &Args, ia: &InstrumentArgs, c: &VolumeCurves, orientation: Value) -> Value {
    let energy: Vec<Value> = c
        .energy
        .iter()
        .zip(&c.energy_std_err)
        .map(|((ti, e), se)| {
            let mut v = energy_json(e);
            v["theta_i_deg"] = json!(deg_num(*ti));
            v["total"] = json!(e.total());
            v["std_err"] = energy_json(se);
            v
        })
        .collect();
    let s = &c.settings;
    let amount = match s.amount {
        Amount::VolumeFraction(v) => json!({"volume_fraction": v}),
        Amount::MassLoading {
            fraction,
            binder_density_g_cm3,
        } => json!({
            "mass_loading": fraction,
            "binder_density_g_cm3": binder_density_g_cm3,
            "aluminium_density_g_cm3": flakescatter::volume_layer::ALUMINIUM_DENSITY_G_CM3,
            "volume_fraction": s.amount.volume_fraction(),
        }),
        Amount::Count(n) => json!({"flakes": n}),
    };
    let depth = match &s.depth {
        Depth::Uniform { top_um, bottom_um } => json!({"top_um": top_um, "bottom_um": bottom_um}),
        _ => json!("whole film"),
    };
    let substrate = match s.substrate {
        Substrate::Black => json!({"kind": "black"}),
        Substrate::Specular(r) => json!({"kind": "mirror", "reflectance": r}),
        Substrate::Lambertian(r) => json!({"kind": "lambertian", "reflectance": r}),
    };
    let l = &c.layer;
    // A sum over no flakes is -0 in floating point; print it as 0.
    let z = |x: f64| x + 0.0;
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "volume",
        "model": "volume",
        "inputs": {
            "film_um": s.film_um,
            "n": c.coating.n,
            "flake_index": args.flake_index.clone().unwrap_or_else(|| "perfect-conductor".into()),
            "diameter_um": args.diameter_um,
            "diameter_rel_sd": args.diameter_rel_sd,
            "thickness_um": s.thickness_um,
            "amount": amount,
            "depth_um": depth,
            "orientation": orientation,
            "theta_i_deg": ia.theta_i_text(),
            "theta_s_deg": if ia.detectors.is_some() { Value::Null } else { json!(ia.theta_s.as_deref().unwrap_or(crate::flags::DEFAULT_THETA_S)) },
            "detectors_file": ia.detectors.as_ref().map(|p| p.display().to_string()),
            "aperture_deg": args.aperture,
            "rays_requested": args.rays,
            "seed": c.seed,
            "tile_um": s.tile_um,
            "substrate": substrate,
            "rims": s.rims.name(),
        },
        "layer": {
            "flakes": l.flakes,
            "requested_volume_fraction": l.requested_volume_fraction,
            "volume_fraction": z(l.volume_fraction),
            "projected_coverage": z(l.projected_coverage),
            "area_coverage": z(l.area_coverage),
            "placement_attempts": l.attempts,
        },
        "seed": c.seed,
        "rays_per_incidence": c.rays_per_incidence,
        "segments": c.segments,
        "energy": energy,
        "units": {
            "columns": {
                "theta_i_deg": "degree, incidence angle from the film normal",
                "theta_s_deg": "degree, signed in-plane detector angle (theta_s = -theta_i is specular); theta_r for out-of-plane detectors",
                "phi_s_deg": "degree, detector azimuth (0 = specular half-plane); 0 for in-plane detectors",
                "aperture_deg": "degree, detector cone half-angle",
                "brdf_per_sr": "1/sr, total BRDF averaged over the detector cone (coat + single + multiple)",
                "reflectance": "fraction of the incident beam power collected by the detector",
                "relative": "collected power relative to the same detector at the specular direction (coat reflection included)",
                "rays": "escapes counted in the detector (rays, not weight)",
                "std_err_per_sr": "1/sr, standard error of brdf_per_sr from 64 batches of rays, for this one layer (the scatter between layers of other --seed values is not in it); null (empty) where no ray reached the detector",
                "coat_brdf_per_sr": "1/sr, first-surface (top interface) reflection, exact; 0 outside the specular cone",
                "single_bounce_brdf_per_sr": "1/sr, light that met exactly one flake face and nothing else",
                "multiple_bounce_brdf_per_sr": "1/sr, every other escaping history: two or more interactions, or an internal reflection at the top interface",
            },
            "energy": "fractions of the incident power per incidence: coat_reflected (exact) + escaped_single + escaped_multiple + absorbed_substrate + absorbed_flakes + absorbed_other = 1; absorbed_other = absorbed_rims + cut_off; escaped_via_substrate is the part of escaped_multiple whose path met the substrate (not in the sum)",
            "layer": "flakes placed; volume fractions (flake volume per film volume); projected_coverage = sum of pi r^2 cos(theta_n) over the tile area, area_coverage = sum of pi r^2 over the tile area (overlaps in projection counted twice)",
            "segments": "straight ray segments traced, all incidences",
        },
        "out": args.out.as_ref().map(|p| p.display().to_string()),
        "plot": args.plot.as_ref().map(|p| p.display().to_string()),
    })
}
