//! `flakescatter reproduce --out DIR`: the paper's Figs. 4, 7, 9 and 10 in kind, from the
//! shipped fixtures and seeded synthetic layers. Every curve goes to a CSV with
//! unit-suffixed headers, every figure to SVG and PNG, and `index.md` says what each
//! shows; `comparison.json` holds the per-region residuals. There are no NIST
//! measurements here: the "measured" curve is the topographic model on rough synthetic
//! layers plus 0.7 % noise, and every figure says so.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use flakescatter::compare::{
    IncidenceComparison, MeasuredKind, ModelPoint, Region, compare, distribution_points,
};
use flakescatter::io::measured::MeasuredCurve;
use flakescatter::io::{ReadOptions, read_intensity, read_map};
use flakescatter::optics::polarization::Weighting;
use flakescatter::reproduce::{SyntheticSample, synthetic_measurement};
use flakescatter::stats::fit::fit_gaussian_ml;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::histogram::AreaHistogram;
use flakescatter::stats::segment::{SegmentParams, segment};
use flakescatter::stats::{Flake, GaussianWidth, Orientation};
use flakescatter::{
    Coating, Curves, DetectorSet, Instrument, OrientationSource, PipelineError, Settings,
    TopoSettings, distribution_curves, p_tilde_about_specular, topographic_curves,
};
use serde_json::{Value, json};

use crate::common::Failure;
use crate::plot::{Figure, Series, Style, draw};

/// Reproduces the paper's figures in kind (Figs. 4, 7, 9, 10) into a directory: CSV for
/// every curve, SVG and PNG plots, `index.md` and `comparison.json`. Deterministic
/// (fixed seeds); run from the repository root (or give --fixtures).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created if missing; files in it are overwritten).
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

/// The fixtures: file stem, generating hwhm (degrees), short label.
const FIXTURES: [(&str, f64, &str); 2] = [
    ("synth-hwhm3-smooth", 3.0, "fixture hwhm 3° smooth"),
    ("synth-hwhm6-rough", 6.0, "fixture hwhm 6° rough"),
];
/// Intensity cutoff of the fixtures (fixtures/README.md: midway between the levels).
const CUTOFF: f64 = 0.49;
/// Detector half-angle, degrees (the paper's instrument).
const APERTURE_DEG: f64 = 1.5;
/// Incidences of Figs. 4, 9 and 10, degrees.
const INCIDENCES: [f64; 2] = [30.0, 60.0];
/// Relative noise of the synthetic measured curve (the paper's 0.7 %).
const NOISE: f64 = 0.007;
/// Seed of that noise.
const NOISE_SEED: u64 = 2002;
/// The synthetic note every Fig. 9/10 plot carries.
const SYNTHETIC_NOTE: &str = "\"Measured\" = SYNTHETIC: topographic model on rough synthetic layers + 0.7 % noise (no NIST data)";

/// Runs the reproduction (module docs).
pub fn run(args: Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let say = |msg: &str| eprintln!("reproduce [{:5.1} s] {msg}", start.elapsed().as_secs_f64());
    std::fs::create_dir_all(&args.out)
        .map_err(|e| Failure(format!("cannot create --out {}: {e}", args.out.display())))?;
    for (stem, _, _) in FIXTURES {
        for suffix in ["height.x3p", "intensity.x3p", "truth.csv"] {
            let p = args.fixtures.join(format!("{stem}.{suffix}"));
            if !p.is_file() {
                bail!(
                    "--fixtures {}: missing {} (run from the repository root, or point --fixtures at the fixtures/ folder)",
                    args.fixtures.display(),
                    p.display()
                );
            }
        }
    }
    let ctx = Ctx {
        out: args.out.clone(),
        theta_s_deg: (-140..=140).map(|k| f64::from(k) * 0.5).collect(),
        weighting: args.weighting,
    };
    let mut index = Index::default();
    let mut comparisons = serde_json::Map::new();

    say("Fig. 4: distribution model, w = 4° and 10°");
    fig4(&ctx, &mut index)?;
    say("Fig. 7: p~ histograms of the fixtures (truth tables and segmentation)");
    let fig7_fits = fig7(&ctx, &args.fixtures, &mut index)?;

    let sample = if args.quick {
        SyntheticSample::quick()
    } else {
        SyntheticSample::reproduce_default()
    };
    let instrument = ctx.instrument()?;
    let measured_settings = Settings {
        clearcoat: true,
        ..Settings::default()
    };
    let m = synthetic_measurement(
        &sample,
        &Coating::default(),
        &measured_settings,
        &instrument,
        NOISE,
        NOISE_SEED,
        &|s| say(s),
    )
    .context("building the synthetic measured curve")?;
    write_measured(&ctx.out.join("measured.csv"), &m.curve)?;
    let measured_desc = format!(
        "the topographic model (physics.md §5, clear coat on, physical weighting, n = 1.5, \
         α = {APERTURE_DEG}°) on {maps} synthetic layers of {size}² pixels at {pitch} µm \
         (flake hwhm {hwhm}°, roughness rms {rr} µm with correlation length {rc} µm, z step \
         {zs} µm, height noise {hn} µm, seeds {s0}–{s1}, intensity cutoff at the midpoint \
         0.49): {flakes} visible flakes, {usable} usable pixels of {pixels}; then each BRDF \
         × (1 + {NOISE} · N(0,1)), noise seed {NOISE_SEED}; {dropped} detectors that no \
         ray reached left out",
        maps = sample.maps,
        size = sample.size,
        pitch = sample.pitch_um,
        hwhm = sample.hwhm.to_degrees().round(),
        rr = sample.roughness_rms_um,
        rc = sample.roughness_correlation_um,
        zs = sample.z_step_um,
        hn = sample.height_noise_um,
        s0 = sample.seed,
        s1 = sample.seed + sample.maps as u64 - 1,
        flakes = m.visible_flakes,
        usable = m.topo.usable_pixels,
        pixels = m.topo.pixels,
        dropped = m.dropped_points,
    );
    index.measured = measured_desc.clone();

    say("Fig. 9: distribution model (hwhm 3° and 6°) against the synthetic measured curve");
    comparisons.insert("fig9".into(), fig9(&ctx, &m.curve, &mut index)?);
    say("Fig. 10: topographic model of the fixture maps against the synthetic measured curve");
    comparisons.insert(
        "fig10".into(),
        fig10(&ctx, &args.fixtures, &m.curve, &mut index, &say)?,
    );

    let summary = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": command_line(&args),
        "measured": {
            "file": "measured.csv",
            "kind": MeasuredKind::Brdf.name(),
            "description": measured_desc,
            "visible_flakes": m.visible_flakes,
            "pixels": m.topo.pixels,
            "usable_pixels": m.topo.usable_pixels,
            "noise_relative_sd": NOISE,
            "noise_seed": NOISE_SEED,
        },
        "fig7_fitted_hwhm_deg": fig7_fits,
        "comparisons": Value::Object(comparisons),
        "units": {
            "theta_i_deg": "degree, incidence angle",
            "scale": "fitted vertical scale of the model (measured ≈ scale × model 5°–40° from specular)",
            "rms_log10": "root mean square of log10(measured) − log10(scaled model) in the region (0.1 = a factor 1.26)",
            "mean_log10": "mean of the same residuals",
        },
    });
    write_text(
        &ctx.out.join("comparison.json"),
        &(serde_json::to_string_pretty(&summary)? + "\n"),
    )?;
    index.write(&ctx.out.join("index.md"), &args, &summary)?;
    say(&format!(
        "done: {} figures in {}",
        index.figures.len(),
        args.out.display()
    ));
    Ok(())
}

/// Shared settings of the run.
struct Ctx {
    out: PathBuf,
    theta_s_deg: Vec<f64>,
    weighting: Weighting,
}

impl Ctx {
    fn theta_s(&self) -> Vec<f64> {
        self.theta_s_deg.iter().map(|d| d.to_radians()).collect()
    }

    fn instrument(&self) -> anyhow::Result<Instrument> {
        Ok(Instrument::new(
            INCIDENCES.iter().map(|d| d.to_radians()).collect(),
            DetectorSet::InPlane(self.theta_s()),
            APERTURE_DEG.to_radians(),
        )?)
    }

    fn settings(&self, clearcoat: bool) -> Settings {
        Settings {
            weighting: self.weighting,
            clearcoat,
            ..Settings::default()
        }
    }

    fn weighting_name(&self) -> &'static str {
        match self.weighting {
            Weighting::PaperPrinted => "paper-printed",
            _ => "physical",
        }
    }

    /// Draw `fig` as `<stem>.svg` and `<stem>.png`.
    fn draw(&self, stem: &str, fig: &Figure) -> anyhow::Result<()> {
        draw(&self.out.join(format!("{stem}.svg")), fig)?;
        draw(&self.out.join(format!("{stem}.png")), fig)
    }
}

/// One figure's entry in `index.md`.
struct FigureEntry {
    title: String,
    files: Vec<String>,
    text: String,
}

#[derive(Default)]
struct Index {
    figures: Vec<FigureEntry>,
    measured: String,
}

impl Index {
    fn add(&mut self, title: &str, files: &[String], text: String) {
        self.figures.push(FigureEntry {
            title: title.into(),
            files: files.to_vec(),
            text,
        });
    }

    fn write(&self, path: &Path, args: &Args, summary: &Value) -> anyhow::Result<()> {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# Reproduced figures (Sung et al. 2002, Figs. 4, 7, 9, 10 in kind)\n"
        );
        let _ = writeln!(
            s,
            "Generated by `{}` (flakescatter {}). Deterministic: every random draw has a \
             fixed seed, so a rerun gives the same numbers. Angles in degrees, θs signed \
             with θs = −θi the specular direction; detectors are cones of half-angle \
             {APERTURE_DEG}°; clear-coat index n = 1.5; flakes are perfect conductors; \
             model weighting `{}` (`--weighting paper-printed` gives the paper's printed \
             eqs. 9/13, for shapes only).\n",
            command_line(args),
            env!("CARGO_PKG_VERSION"),
            match args.weighting {
                Weighting::PaperPrinted => "paper-printed",
                _ => "physical",
            }
        );
        let _ = writeln!(
            s,
            "**No NIST measurement is used.** The \"measured\" curve of Figs. 9 and 10 \
             (`measured.csv`, columns `theta_i_deg, theta_s_deg, value, uncertainty`, value \
             = BRDF in sr⁻¹, uncertainty = one standard uncertainty in sr⁻¹; readable by \
             `flakescatter compare --measured`) is SYNTHETIC: {}.\n",
            self.measured
        );
        for (k, f) in self.figures.iter().enumerate() {
            let _ = writeln!(s, "## {}. {}\n", k + 1, f.title);
            let _ = writeln!(
                s,
                "Files: {}\n",
                f.files
                    .iter()
                    .map(|x| format!("`{x}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            if let Some(png) = f.files.iter().find(|x| x.ends_with(".png")) {
                let _ = writeln!(s, "![{}]({png})\n", f.title);
            }
            let _ = writeln!(s, "{}\n", f.text);
        }
        let _ = writeln!(s, "## Comparison numbers\n");
        let _ = writeln!(
            s,
            "Residual `r = log10(measured) − log10(scale × model)` per region (specular: \
             within 5° of specular; near: 5°–40°; far: beyond 40°). `scale` is fitted on the \
             near-specular points (mean log ratio). rms 0.1 is a factor of 1.26. Also in \
             `comparison.json`.\n"
        );
        let _ = writeln!(
            s,
            "| figure | model | θi (°) | scale | rms specular | rms near | rms far | points |\n| --- | --- | --- | --- | --- | --- | --- | --- |"
        );
        if let Some(c) = summary["comparisons"].as_object() {
            for (fig, rows) in c {
                for r in rows.as_array().into_iter().flatten() {
                    let rms = |name: &str| {
                        r["regions"]
                            .as_array()
                            .and_then(|v| v.iter().find(|x| x["region"] == name))
                            .and_then(|x| x["rms_log10"].as_f64())
                            .map_or_else(|| "–".into(), |v| format!("{v:.3}"))
                    };
                    let _ = writeln!(
                        s,
                        "| {fig} | {} | {} | {:.4e} | {} | {} | {} | {} |",
                        r["model"].as_str().unwrap_or(""),
                        r["theta_i_deg"],
                        r["scale"].as_f64().unwrap_or(f64::NAN),
                        rms("specular"),
                        rms("near-specular"),
                        rms("far"),
                        r["points"],
                    );
                }
            }
        }
        write_text(path, &s)
    }
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

fn write_text(path: &Path, text: &str) -> anyhow::Result<()> {
    std::fs::write(path, text)
        .map_err(|e| anyhow::Error::new(Failure(format!("cannot write {}: {e}", path.display()))))
}

fn write_measured(path: &Path, curve: &MeasuredCurve) -> anyhow::Result<()> {
    let mut s = String::from("theta_i_deg,theta_s_deg,value,uncertainty\n");
    for p in &curve.points {
        let _ = writeln!(
            s,
            "{},{},{:.9e},{:.3e}",
            deg(p.theta_i),
            deg(p.theta_s),
            p.value,
            p.uncertainty.unwrap_or(0.0)
        );
    }
    write_text(path, &s)
}

/// Degrees without float noise (`-69.5`).
fn deg(rad: f64) -> f64 {
    (rad.to_degrees() * 1e6).round() / 1e6 + 0.0
}

fn gaussian(hwhm_deg: f64) -> anyhow::Result<Orientation> {
    Ok(Orientation::gaussian(GaussianWidth::Hwhm(
        hwhm_deg.to_radians(),
    ))?)
}

/// Fig. 4: relative curves for w = 4°, 10° at 30°, 60°, p̃ about specular.
fn fig4(ctx: &Ctx, index: &mut Index) -> anyhow::Result<()> {
    let widths = [4.0, 10.0];
    let instrument = ctx.instrument()?;
    let mut csv = String::from(
        "hwhm_deg,theta_i_deg,theta_s_deg,aperture_deg,brdf_per_sr,relative,p_tilde_about_specular\n",
    );
    let mut per_incidence: Vec<Vec<Series>> = vec![Vec::new(); INCIDENCES.len()];
    for (c, &w) in widths.iter().enumerate() {
        let o = gaussian(w)?;
        let curves = distribution_curves(
            &Coating::default(),
            &instrument,
            &ctx.settings(false),
            &OrientationSource::Distribution(o.clone()),
        )?;
        for (k, &ti) in INCIDENCES.iter().enumerate() {
            let rows = rows_at(&curves, ti);
            let mut model = Vec::new();
            let mut pt = Vec::new();
            for r in rows {
                let ts = ctx.theta_s_deg[r.detector];
                let p = p_tilde_about_specular(&o, ti.to_radians(), ts.to_radians());
                let _ = writeln!(
                    csv,
                    "{w},{ti},{ts},{APERTURE_DEG},{:.9e},{:.9e},{:.9e}",
                    r.brdf, r.relative, p
                );
                model.push((ts, r.relative));
                pt.push((ts, p));
            }
            per_incidence[k].push(Series {
                label: format!("model, w = {w}°"),
                points: model,
                style: Style::Line,
                colour: c,
            });
            per_incidence[k].push(Series {
                label: format!("p~(θs + θi), w = {w}°"),
                points: pt,
                style: Style::Dashed,
                colour: c,
            });
        }
    }
    write_text(&ctx.out.join("fig4.csv"), &csv)?;
    let mut files = vec!["fig4.csv".to_string()];
    for (k, series) in per_incidence.into_iter().enumerate() {
        let ti = INCIDENCES[k];
        let stem = format!("fig4_theta{ti}");
        ctx.draw(
            &stem,
            &Figure {
                title: format!(
                    "Fig. 4 analogue: distribution model, θi = {ti}°\nsolid: collected power relative to specular; dashed: Gaussian p~ drawn about specular; {} weighting, α = {APERTURE_DEG}°",
                    ctx.weighting_name()
                ),
                x_label: "θs (degrees; θs = −θi is specular)".into(),
                y_label: "relative reflectance (1 at specular)".into(),
                log_y: true,
                series,
            },
        )?;
        files.push(format!("{stem}.svg"));
        files.push(format!("{stem}.png"));
    }
    index.add(
        "Fig. 4 — distribution model for two widths at two incidences",
        &files,
        format!(
            "The distribution model (physics.md §4, no clear-coat reflection) for Gaussian \
             p̃ with hwhm w = 4° and 10° (the paper's widths) at θi = 30° and 60°: solid \
             lines are the power collected by a {APERTURE_DEG}° cone relative to the same \
             cone at specular (exact cone integral, not the paper's constant-integrand \
             approximation), dashed lines are p̃(θs + θi)/p̃(0), the orientation \
             distribution drawn about the specular direction. The reflected curve is much \
             wider than p̃ (refraction and the doubling of reflection angles), and for \
             w = 10° its maximum leaves the specular direction toward the normal (by about \
             4° at 30° and 15° at 60°, physics.md §4). `fig4.csv`: `hwhm_deg, theta_i_deg, \
             theta_s_deg, aperture_deg, brdf_per_sr` (cone-averaged BRDF, sr⁻¹), \
             `relative` (1 at specular), `p_tilde_about_specular` (p̃(|θs + θi|)/p̃(0), \
             dimensionless). Weighting: {}.",
            ctx.weighting_name()
        ),
    );
    Ok(())
}

/// Rows of `curves` at incidence `ti_deg`.
fn rows_at(curves: &Curves, ti_deg: f64) -> Vec<flakescatter::CurveRow> {
    curves
        .rows
        .iter()
        .filter(|r| (r.theta_i.to_degrees() - ti_deg).abs() < 1e-9)
        .copied()
        .collect()
}

/// Fig. 7: histograms of p̃ from the truth tables and from segmentation of the maps.
fn fig7(ctx: &Ctx, fixtures: &Path, index: &mut Index) -> anyhow::Result<Value> {
    let bin = 1f64.to_radians();
    let mut csv = String::from(
        "source,flakes,hwhm_fit_deg,theta_lo_deg,theta_hi_deg,area_fraction,p_tilde\n",
    );
    let mut series = Vec::new();
    let mut fits = serde_json::Map::new();
    let mut notes = Vec::new();
    for (c, (stem, hwhm, _)) in FIXTURES.iter().enumerate() {
        let truth_path = fixtures.join(format!("{stem}.truth.csv"));
        let truth = flakescatter::io::flakes::read_flakes(&truth_path)
            .with_context(|| format!("reading {}", truth_path.display()))?
            .flakes;
        let map = read_masked(fixtures, stem)?;
        let seg = segment(&map, &SegmentParams::for_instrument(0.3, 0.0))
            .with_context(|| format!("segmenting {stem}.height.x3p"))?;
        let found: Vec<Flake> = seg.flakes.iter().map(|f| f.to_flake()).collect();
        for (source, flakes, style) in [
            (format!("{stem}.truth.csv"), &truth, Style::Line),
            (format!("segment {stem}.height.x3p"), &found, Style::Dashed),
        ] {
            let hist = AreaHistogram::from_flakes(flakes, bin)
                .with_context(|| format!("histogram of {source}"))?;
            let samples: Vec<(f64, f64)> = flakes
                .iter()
                .map(|f| (f.normal.z.clamp(-1.0, 1.0).acos(), f.area_um2))
                .collect();
            let fit = fit_gaussian_ml(&samples).with_context(|| format!("width of {source}"))?;
            let w = fit.hwhm().to_degrees();
            fits.insert(source.clone(), json!(w));
            notes.push(format!(
                "{source}: {} flakes, fitted hwhm {w:.2}°",
                flakes.len()
            ));
            let mut pts = Vec::new();
            for b in hist.bins() {
                let _ = writeln!(
                    csv,
                    "{source},{},{w:.4},{},{},{:.9e},{:.9e}",
                    flakes.len(),
                    deg(b.theta_lo),
                    deg(b.theta_hi),
                    b.area_fraction,
                    b.p_tilde
                );
                if b.theta_lo.to_degrees() < 20.0 - 1e-9 {
                    // Steps: flat over each bin.
                    pts.push((b.theta_lo.to_degrees(), b.p_tilde));
                    pts.push((b.theta_hi.to_degrees(), b.p_tilde));
                }
            }
            let what = if style == Style::Line {
                "truth"
            } else {
                "segmented"
            };
            series.push(Series {
                label: format!("{what} {hwhm}° ({} flakes): fit hwhm {w:.1}°", flakes.len()),
                points: pts,
                style,
                colour: c,
            });
        }
        let o = gaussian(*hwhm)?;
        series.push(Series {
            label: format!("generator's Gaussian p~, hwhm {hwhm}°"),
            points: (0..=200)
                .map(|k| {
                    let t = f64::from(k) * 0.1;
                    (t, o.p_tilde(t.to_radians()))
                })
                .collect(),
            style: Style::Line,
            colour: c + 4,
        });
    }
    write_text(&ctx.out.join("fig7.csv"), &csv)?;
    ctx.draw(
        "fig7",
        &Figure {
            title: "Fig. 7 analogue: area-weighted p~ histograms (1° bins) of the fixture maps\nsolid steps: truth tables; dashed steps: automatic segmentation of the height maps; smooth: generator's p~".into(),
            x_label: "θn, flake tilt from the coating normal (degrees)".into(),
            y_label: "p~(θn) = area fraction / (cos θlo − cos θhi)".into(),
            log_y: false,
            series,
        },
    )?;
    index.add(
        "Fig. 7 — histograms of p̃ from flake tables",
        &["fig7.csv".into(), "fig7.svg".into(), "fig7.png".into()],
        format!(
            "Area-weighted histograms of the modified orientation distribution p̃(θn) in \
             1° bins (physics.md §3: per bin `area_fraction / (cos θlo − cos θhi)`, so \
             Σ p̃ · (cos θlo − cos θhi) = 1), for the two shipped fixtures \
             (`fixtures/synth-hwhm3-smooth.*`, `fixtures/synth-hwhm6-rough.*`, 512² pixels \
             at 0.18 µm): from their truth tables and from `segment` on their height maps \
             (intensity cutoff {CUTOFF}, thresholds for a 0.3 µm z step). The legend gives \
             the maximum-likelihood Gaussian hwhm of each flake set; the smooth curves are \
             the generators' Gaussians. With ~70 flakes per map the histograms are as noisy \
             as the paper's (340 and 700 flakes). {}. `fig7.csv`: `source, flakes, \
             hwhm_fit_deg, theta_lo_deg, theta_hi_deg, area_fraction, p_tilde`.",
            notes.join("; ")
        ),
    );
    Ok(Value::Object(fits))
}

/// A fixture's height map with its intensity cutoff applied.
fn read_masked(fixtures: &Path, stem: &str) -> anyhow::Result<HeightMap> {
    let hp = fixtures.join(format!("{stem}.height.x3p"));
    let ip = fixtures.join(format!("{stem}.intensity.x3p"));
    let opts = ReadOptions::default();
    let (mut map, _) = read_map(&hp, &opts).with_context(|| format!("reading {}", hp.display()))?;
    let (intensity, _) =
        read_intensity(&ip, &opts).with_context(|| format!("reading {}", ip.display()))?;
    map.apply_intensity_cutoff(&intensity, CUTOFF)
        .with_context(|| format!("{} with cutoff {CUTOFF}", ip.display()))?;
    Ok(map)
}

/// JSON of one comparison row.
fn comparison_json(model: &str, c: &IncidenceComparison, dropped: usize) -> Value {
    json!({
        "model": model,
        "theta_i_deg": deg(c.theta_i),
        "scale": c.scale,
        "points": c.points.len(),
        "points_without_model_rays": dropped,
        "regions": c.regions.iter().map(|r| json!({
            "region": r.region.name(),
            "points": r.points,
            "rms_log10": r.rms_log10,
            "mean_log10": r.mean_log10,
        })).collect::<Vec<_>>(),
    })
}

/// Measured points of one incidence as `(θs°, value)`.
fn measured_series(curve: &MeasuredCurve, ti_deg: f64) -> Series {
    Series {
        label: "\"measured\" (synthetic)".into(),
        points: curve
            .points
            .iter()
            .filter(|p| (p.theta_i.to_degrees() - ti_deg).abs() < 1e-9)
            .map(|p| (deg(p.theta_s), p.value))
            .collect(),
        style: Style::Points,
        colour: 7,
    }
}

/// Fig. 9: distribution model, hwhm 3° and 6°, clear coat on, scaled to the measured curve.
fn fig9(ctx: &Ctx, measured: &MeasuredCurve, index: &mut Index) -> anyhow::Result<Value> {
    let coating = Coating::default();
    let settings = ctx.settings(true);
    let aperture = APERTURE_DEG.to_radians();
    let widths = [3.0, 6.0];
    let mut results = Vec::new();
    for &w in &widths {
        let o = gaussian(w)?;
        let model = |ti: f64, ts: &[f64]| -> Result<Vec<ModelPoint>, PipelineError> {
            distribution_points(&coating, &settings, aperture, &o, ti, ts)
        };
        results.push(compare(measured, MeasuredKind::Brdf, &model)?);
    }
    let mut csv = String::from(
        "theta_i_deg,theta_s_deg,region,measured_brdf_per_sr,model_hwhm3_scaled_brdf_per_sr,model_hwhm6_scaled_brdf_per_sr\n",
    );
    let mut json_rows = Vec::new();
    let mut files = vec!["fig9.csv".to_string()];
    for (a, b) in results[0].iter().zip(&results[1]) {
        let ti = a.theta_i.to_degrees().round();
        for (p, q) in a.points.iter().zip(&b.points) {
            let _ = writeln!(
                csv,
                "{ti},{},{},{:.9e},{:.9e},{:.9e}",
                deg(p.theta_s),
                p.region.name(),
                p.measured,
                p.model,
                q.model
            );
        }
        let mut series = Vec::new();
        for (c, (r, w)) in [(a, 3.0), (b, 6.0)].into_iter().enumerate() {
            json_rows.push(comparison_json(&format!("distribution, hwhm {w}°"), r, 0));
            let near = r
                .regions
                .iter()
                .find(|x| x.region.name() == "near-specular");
            series.push(Series {
                label: format!(
                    "model hwhm {w}° (× {:.3}; rms near {:.2})",
                    r.scale,
                    near.and_then(|x| x.rms_log10).unwrap_or(f64::NAN)
                ),
                points: r.points.iter().map(|p| (deg(p.theta_s), p.model)).collect(),
                style: if c == 0 { Style::Line } else { Style::Dashed },
                colour: c,
            });
        }
        series.push(measured_series(measured, ti));
        let stem = format!("fig9_theta{ti}");
        ctx.draw(
            &stem,
            &Figure {
                title: format!(
                    "Fig. 9 analogue: distribution model (clear coat on) vs \"measured\", θi = {ti}°\n{SYNTHETIC_NOTE}"
                ),
                x_label: "θs (degrees; θs = −θi is specular)".into(),
                y_label: "BRDF (1/sr), models scaled 5°–40° from specular".into(),
                log_y: true,
                series,
            },
        )?;
        files.push(format!("{stem}.svg"));
        files.push(format!("{stem}.png"));
    }
    write_text(&ctx.out.join("fig9.csv"), &csv)?;
    index.add(
        "Fig. 9 — distribution model with hwhm 3° and 6° against the \"measured\" curve",
        &files,
        "The distribution model (clear coat on: its specular reflection adds the narrow \
         peak, physics.md §6) for Gaussian p̃ of hwhm 3° (solid; the width of the flake \
         histograms, as in the paper) and 6° (dashed), each multiplied by a scale fitted \
         to the measured curve 5°–40° from specular (`flakescatter compare`'s rule), on a \
         log axis, at θi = 30° and 60°. The dots are the SYNTHETIC measured curve \
         (`measured.csv`, see above): its flakes have hwhm 3° but rough surfaces, so — as \
         in the paper — the 3° model is too narrow and the 6° model follows the \
         near-specular fall-off better. `fig9.csv`: `theta_i_deg, theta_s_deg, region` \
         (specular / near-specular / far), `measured_brdf_per_sr` and both scaled models \
         (sr⁻¹). Scales and per-region residuals: table below and `comparison.json`."
            .into(),
    );
    Ok(Value::Array(json_rows))
}

/// Fig. 10: topographic model of each fixture (clear coat on) against the measured curve.
fn fig10(
    ctx: &Ctx,
    fixtures: &Path,
    measured: &MeasuredCurve,
    index: &mut Index,
    say: &dyn Fn(&str),
) -> anyhow::Result<Value> {
    let instrument = ctx.instrument()?;
    let settings = ctx.settings(true);
    let mut json_rows = Vec::new();
    let mut per_incidence: Vec<Vec<Series>> = vec![Vec::new(); INCIDENCES.len()];
    let mut csv = String::from(
        "map,theta_i_deg,theta_s_deg,region,measured_brdf_per_sr,model_scaled_brdf_per_sr,model_scaled_std_err_per_sr,rays,scale\n",
    );
    let mut notes = Vec::new();
    for (c, (stem, _, label)) in FIXTURES.iter().enumerate() {
        say(&format!("  topographic model of {stem}"));
        let map = read_masked(fixtures, stem)?;
        let (curves, topo) = topographic_curves(
            &Coating::default(),
            &instrument,
            &settings,
            &TopoSettings::default(),
            &[&map],
            &|_, _| {},
        )
        .with_context(|| format!("topographic model of {stem}"))?;
        notes.push(format!(
            "`{stem}`: {} usable pixels of {}",
            topo.usable_pixels, topo.pixels
        ));
        // The model at the measured points; detectors where no ray arrived are left out of
        // the comparison (a zero cannot be compared on a log scale) and counted.
        let lookup = |ti: f64, ts: f64| {
            curves.rows.iter().find(|r| {
                (r.theta_i - ti).abs() < 1e-9
                    && (ctx.theta_s_deg[r.detector].to_radians() - ts).abs() < 1e-9
            })
        };
        let mut kept = MeasuredCurve {
            file: measured.file.clone(),
            points: measured
                .points
                .iter()
                .filter(|p| lookup(p.theta_i, p.theta_s).is_some_and(|r| r.brdf > 0.0))
                .copied()
                .collect(),
        };
        // With ~70 flakes a map may send no ray at all 5°–40° from specular at some
        // incidence (the smooth fixture's terraces send light to specular or far from
        // it): there is no scale to fit, so that incidence is not shown for this map.
        for ti in kept.incidences() {
            let fittable = kept
                .points
                .iter()
                .any(|p| p.theta_i == ti && Region::of(ti, p.theta_s) == Region::NearSpecular);
            if !fittable {
                kept.points.retain(|p| p.theta_i != ti);
                notes.push(format!(
                    "`{stem}` at θi = {}°: no ray 5°–40° from specular, so no scale to fit; not shown",
                    ti.to_degrees().round()
                ));
            }
        }
        if kept.points.is_empty() {
            continue;
        }
        let model = |ti: f64, ts: &[f64]| -> Result<Vec<ModelPoint>, PipelineError> {
            ts.iter()
                .map(|&t| {
                    lookup(ti, t)
                        .map(|r| {
                            ModelPoint::from_row(
                                r.brdf,
                                r.relative,
                                r.reflectance,
                                APERTURE_DEG.to_radians(),
                            )
                        })
                        .ok_or_else(|| {
                            PipelineError::Measurement(format!(
                                "no model detector at θs = {:.3}°",
                                t.to_degrees()
                            ))
                        })
                })
                .collect()
        };
        let result = compare(&kept, MeasuredKind::Brdf, &model)?;
        for r in &result {
            let ti = r.theta_i.to_degrees().round();
            let k = INCIDENCES
                .iter()
                .position(|&d| d == ti)
                .context("compare returned an incidence the figure was not asked for")?;
            let total = measured
                .points
                .iter()
                .filter(|p| (p.theta_i - r.theta_i).abs() < 1e-12)
                .count();
            let dropped = total - r.points.len();
            json_rows.push(comparison_json(&format!("topographic, {stem}"), r, dropped));
            for p in &r.points {
                let row = lookup(p.theta_i, p.theta_s).copied();
                let se = row.and_then(|x| x.std_err).unwrap_or(0.0) * r.scale;
                let _ = writeln!(
                    csv,
                    "{stem},{ti},{},{},{:.9e},{:.9e},{:.3e},{},{:.6e}",
                    deg(p.theta_s),
                    p.region.name(),
                    p.measured,
                    p.model,
                    se,
                    row.and_then(|x| x.rays).unwrap_or(0),
                    r.scale
                );
            }
            // Every detector, zeros included: the line breaks where no ray arrived.
            let line = rows_at(&curves, ti)
                .iter()
                .map(|row| (ctx.theta_s_deg[row.detector], r.scale * row.brdf))
                .collect();
            let near = r
                .regions
                .iter()
                .find(|x| x.region.name() == "near-specular");
            per_incidence[k].push(Series {
                label: format!(
                    "{label} (× {:.3}; rms near {:.2})",
                    r.scale,
                    near.and_then(|x| x.rms_log10).unwrap_or(f64::NAN)
                ),
                points: line,
                style: Style::Line,
                colour: c,
            });
            if dropped > 0 {
                notes.push(format!(
                    "`{stem}` at θi = {ti}°: {dropped} of {total} detectors received no ray"
                ));
            }
        }
    }
    let mut files = vec!["fig10.csv".to_string()];
    for (k, mut series) in per_incidence.into_iter().enumerate() {
        let ti = INCIDENCES[k];
        series.push(measured_series(measured, ti));
        let stem = format!("fig10_theta{ti}");
        ctx.draw(
            &stem,
            &Figure {
                title: format!(
                    "Fig. 10 analogue: topographic model of the fixture maps vs \"measured\", θi = {ti}°\n{SYNTHETIC_NOTE}. Model: ~70 flakes per map, noisy"
                ),
                x_label: "θs (degrees; θs = −θi is specular)".into(),
                y_label: "BRDF (1/sr), models scaled 5°–40° from specular".into(),
                log_y: true,
                series,
            },
        )?;
        files.push(format!("{stem}.svg"));
        files.push(format!("{stem}.png"));
    }
    write_text(&ctx.out.join("fig10.csv"), &csv)?;
    index.add(
        "Fig. 10 — topographic model of the fixture maps against the \"measured\" curve",
        &files,
        format!(
            "The topographic model (physics.md §5: 5 × 5 least-squares normals, one ray \
             per usable pixel, clear coat on) of each shipped fixture map alone (intensity \
             cutoff {CUTOFF}), scaled to the SYNTHETIC measured curve 5°–40° from specular. \
             Each map holds only ~70 flakes, so its curve is noisy (physics.md §5: ~10⁴ \
             flakes give ~10 % rms in a small cone) and falls to zero where no flake \
             sends a ray (gaps in the lines); the standard error of each point, from the \
             spread over 32 µm tiles, is in `fig10.csv`. Detectors that received no ray \
             are left out of the comparison. The smooth fixture's 0.3 µm z steps make \
             flat terraces whose normals are exactly vertical: the huge specular peak of its \
             curve is this artefact (the paper saw the same from its microscope's \
             interpolation), on top of the clear coat's reflection. The smooth fixture \
             (hwhm 3°, flat flakes) gives a curve narrower than the rough \"measured\" \
             sample; the rough fixture is closer. {}. `fig10.csv`: `map, theta_i_deg, \
             theta_s_deg, region, measured_brdf_per_sr, model_scaled_brdf_per_sr, \
             model_scaled_std_err_per_sr` (sr⁻¹), `rays` (rays counted by the detector), \
             `scale`.",
            notes.join("; ")
        ),
    );
    Ok(Value::Array(json_rows))
}
