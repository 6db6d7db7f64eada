//! The paper's Figs. 4, 7, 9 and 10 in kind (`flakescatter reproduce`), composed here so
//! that they can be tested without the command-line tool: what each figure computes,
//! its CSV text, its [`Chart`]s, `comparison.json` and `index.md`. The caller reads the
//! fixture files (through [`crate::io`]) and writes the [`Report`]'s files.
//!
//! There are no NIST measurements here: the "measured" curve is the topographic model,
//! averaged over the sample's rotation, on rough synthetic layers plus 0.7 % noise
//! ([`crate::reproduce`]), and every figure says so. Everything is seeded; a rerun gives
//! the same files bit for bit on the same platform. Numbers in the files are rounded to
//! stated digits (CSV values to 10 significant digits, `comparison.json` to
//! [`JSON_DIGITS`]) so that another maths library changes at most a last digit.
//!
//! Conventions: radians in every API; degrees in the files and charts (x axes, CSV
//! columns ending in `_deg`), as their headers say.

mod comparisons;
mod interference;
mod paper;
mod volume;

pub use comparisons::{FIG10_HEIGHT_NOISE_UM, Fig10Sample, fig10_samples};

use std::fmt::Write as _;

use flakescatter_optics::polarization::Weighting;
use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use flakescatter_stats::{Flake, GaussianWidth, Orientation};
use serde_json::{Value, json};

use crate::PipelineError;
use crate::chart::Chart;
use crate::compare::MeasuredKind;
use crate::instrument::{DetectorSet, Instrument};
use crate::pipeline::{Coating, Settings};
use crate::reproduce::{
    ReproduceError, SyntheticMeasurement, SyntheticSample, synthetic_measurement,
};

/// The shipped fixtures the figures use: file stem, generating hwhm (degrees), label.
pub const FIXTURES: [(&str, f64, &str); 2] = [
    ("synth-hwhm3-smooth", 3.0, "fixture hwhm 3° smooth"),
    ("synth-hwhm6-rough", 6.0, "fixture hwhm 6° rough"),
];
/// The files of each fixture, after `<stem>.`: height map, intensity map, truth table.
pub const FIXTURE_FILES: [&str; 3] = ["height.x3p", "intensity.x3p", "truth.csv"];
/// Intensity cutoff of the fixtures (fixtures/README.md: midway between the levels).
pub const CUTOFF: f64 = 0.49;
/// Detector half-angle, degrees (the paper's instrument).
const APERTURE_DEG: f64 = 1.5;
/// Incidences of Figs. 4, 9 and 10, degrees.
const INCIDENCES: [f64; 2] = [30.0, 60.0];
/// Relative noise of the synthetic measured curve (the paper's 0.7 %).
const NOISE: f64 = 0.007;
/// Seed of that noise.
const NOISE_SEED: u64 = 2002;
/// Significant digits of the numbers in `comparison.json`.
pub const JSON_DIGITS: usize = 6;
/// The synthetic note every Fig. 9/10 plot carries.
const SYNTHETIC_NOTE: &str = "\"Measured\" = SYNTHETIC: topographic model on rough synthetic layers + 0.7 % noise (no NIST data)";

/// One shipped fixture, as read from its files.
#[derive(Debug, Clone)]
pub struct Fixture {
    /// File stem (one of [`FIXTURES`]).
    pub stem: String,
    /// The height map, µm, unmasked.
    pub height: HeightMap,
    /// Its intensity map (masked at [`CUTOFF`]).
    pub intensity: HeightMap,
    /// The flakes of its truth table.
    pub truth: Vec<Flake>,
}

/// What to reproduce.
#[derive(Debug, Clone)]
pub struct FiguresSpec {
    /// The smaller synthetic sample ([`SyntheticSample::quick`]).
    pub quick: bool,
    /// Ray weighting of every model curve.
    pub weighting: Weighting,
    /// The command line that produced the files, for `index.md` and `comparison.json`.
    pub command: String,
}

/// The content of one output file.
#[derive(Debug, Clone)]
pub enum Content {
    /// A text file (CSV, JSON, Markdown).
    Text(String),
    /// A chart, drawn as `<name>.svg` and `<name>.png`.
    Chart(Chart),
}

/// One output file (or, for a chart, the pair of image files).
#[derive(Debug, Clone)]
pub struct ReportFile {
    /// File name (for a chart: the stem of its `.svg` and `.png`).
    pub name: String,
    /// What goes into it.
    pub content: Content,
}

/// Everything `reproduce` writes.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// The files, in the order they were made.
    pub files: Vec<ReportFile>,
}

impl Report {
    fn text(&mut self, name: &str, text: String) {
        self.files.push(ReportFile {
            name: name.into(),
            content: Content::Text(text),
        });
    }

    fn chart(&mut self, stem: &str, chart: Chart) {
        self.files.push(ReportFile {
            name: stem.into(),
            content: Content::Chart(chart),
        });
    }

    /// The text file `name`, if the report has it.
    #[must_use]
    pub fn text_of(&self, name: &str) -> Option<&str> {
        self.files.iter().find_map(|f| match &f.content {
            Content::Text(t) if f.name == name => Some(t.as_str()),
            _ => None,
        })
    }

    /// The chart `stem`, if the report has it.
    #[must_use]
    pub fn chart_of(&self, stem: &str) -> Option<&Chart> {
        self.files.iter().find_map(|f| match &f.content {
            Content::Chart(c) if f.name == stem => Some(c),
            _ => None,
        })
    }
}

/// Errors of [`reproduce`].
#[derive(Debug, thiserror::Error)]
pub enum FiguresError {
    /// The fixtures given are not the ones the figures need.
    #[error("fixtures: {0}")]
    Fixtures(String),
    /// A fixture's intensity mask cannot be applied.
    #[error("fixture {stem}: intensity mask: {source}")]
    Mask {
        /// The fixture.
        stem: String,
        /// What went wrong.
        source: HeightMapError,
    },
    /// A figure's computation failed.
    #[error("{figure}: {message}")]
    Figure {
        /// Which figure.
        figure: &'static str,
        /// What went wrong.
        message: String,
    },
    /// The synthetic measured curve could not be built.
    #[error("building the synthetic measured curve: {0}")]
    Measurement(#[from] ReproduceError),
    /// The pipeline failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
}

/// Shared settings of the run.
struct Ctx {
    theta_s_deg: Vec<f64>,
    weighting: Weighting,
}

impl Ctx {
    fn theta_s(&self) -> Vec<f64> {
        self.theta_s_deg.iter().map(|d| d.to_radians()).collect()
    }

    fn instrument(&self) -> Result<Instrument, PipelineError> {
        Instrument::new(
            INCIDENCES.iter().map(|d| d.to_radians()).collect(),
            DetectorSet::InPlane(self.theta_s()),
            APERTURE_DEG.to_radians(),
        )
    }

    fn settings(&self, clearcoat: bool) -> Settings {
        Settings {
            weighting: self.weighting,
            clearcoat,
            ..Settings::default()
        }
    }

    fn weighting_name(&self) -> &'static str {
        weighting_name(self.weighting)
    }
}

fn weighting_name(w: Weighting) -> &'static str {
    match w {
        Weighting::PaperPrinted => "paper-printed",
        _ => "physical",
    }
}

/// One figure's entry in `index.md`.
struct FigureEntry {
    title: String,
    files: Vec<String>,
    text: String,
}

/// `index.md` in the making.
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
}

/// Reproduces the figures from `fixtures` (both of [`FIXTURES`], in that order).
/// `progress(stage)` is told what is being done.
///
/// # Errors
/// [`FiguresError`] for missing fixtures or a failing computation.
pub fn reproduce(
    fixtures: &[Fixture],
    spec: &FiguresSpec,
    progress: &dyn Fn(&str),
) -> Result<Report, FiguresError> {
    let masked = masked_maps(fixtures)?;
    let ctx = Ctx {
        theta_s_deg: (-140..=140).map(|k| f64::from(k) * 0.5).collect(),
        weighting: spec.weighting,
    };
    let mut report = Report::default();
    let mut index = Index::default();
    let mut comparisons = serde_json::Map::new();

    progress("Fig. 4: distribution model, w = 4° and 10°");
    paper::fig4(&ctx, &mut report, &mut index)?;
    progress("Fig. 7: p~ histograms of the fixtures (truth tables and segmentation)");
    let fig7_fits = paper::fig7(fixtures, &masked, &mut report, &mut index)?;

    let sample = if spec.quick {
        SyntheticSample::quick()
    } else {
        SyntheticSample::reproduce_default()
    };
    let measured_settings = Settings {
        clearcoat: true,
        ..Settings::default()
    };
    let m = synthetic_measurement(
        &sample,
        &Coating::default(),
        &measured_settings,
        &ctx.instrument()?,
        NOISE,
        NOISE_SEED,
        progress,
    )?;
    report.text("measured.csv", comparisons::measured_csv(&m.curve));
    index.measured = describe_measurement(&ctx, &sample, &m);

    progress("Fig. 9: distribution model (hwhm 3° and 6°) against the synthetic measured curve");
    comparisons.insert(
        "fig9".into(),
        comparisons::fig9(&ctx, &m.curve, &mut report, &mut index)?,
    );
    progress(
        "Fig. 10: isotropic topographic model of a smooth- and a rough-flake sample against the synthetic measured curve",
    );
    comparisons.insert(
        "fig10".into(),
        comparisons::fig10(
            &ctx,
            spec.quick,
            &m.curve,
            &mut report,
            &mut index,
            progress,
        )?,
    );

    progress(
        "Multiple scattering: volume model of the paper's coating, share per angle from specular",
    );
    let multiple = volume::multiple_scattering(spec.quick, &mut report, &mut index)?;

    progress("Beyond the paper: interference (TiO2-on-mica) pigments, colour travel");
    interference::interference(&mut report, &mut index)?;

    let summary = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": spec.command,
        "measured": {
            "file": "measured.csv",
            "kind": MeasuredKind::Brdf.name(),
            "description": index.measured,
            "visible_flakes": m.visible_flakes,
            "pixels": m.topo.pixels,
            "usable_pixels": m.topo.usable_pixels,
            "noise_relative_sd": NOISE,
            "noise_seed": NOISE_SEED,
        },
        "fig7_fitted_hwhm_deg": fig7_fits,
        "comparisons": Value::Object(comparisons),
        "rounding": format!("scale and fitted widths to {JSON_DIGITS} significant digits, rms_log10 and mean_log10 to 1e-6"),
        "units": {
            "theta_i_deg": "degree, incidence angle",
            "scale": "fitted vertical scale of the model (measured ≈ scale × model 5°–40° from specular)",
            "rms_log10": "root mean square of log10(measured) − log10(scaled model) in the region (0.1 = a factor 1.26)",
            "mean_log10": "mean of the same residuals",
        },
    });
    let mut summary = summary;
    summary["multiple_scattering"] = multiple;
    // Keys sorted at every level, whatever serde_json's `preserve_order` (turned on by
    // zarrs) would keep: the file and the index's table order stay as they were.
    summary.sort_all_objects();
    let json_text = serde_json::to_string_pretty(&summary).map_err(|e| FiguresError::Figure {
        figure: "comparison.json",
        message: e.to_string(),
    })? + "\n";
    report.text("comparison.json", json_text);
    let index_text = index_md(&index, spec, &summary);
    report.text("index.md", index_text);
    Ok(report)
}

/// The fixtures' height maps with the intensity cutoff applied, after checking that
/// they are [`FIXTURES`] in that order.
fn masked_maps(fixtures: &[Fixture]) -> Result<Vec<HeightMap>, FiguresError> {
    let stems: Vec<&str> = fixtures.iter().map(|f| f.stem.as_str()).collect();
    let want: Vec<&str> = FIXTURES.iter().map(|f| f.0).collect();
    if stems != want {
        return Err(FiguresError::Fixtures(format!(
            "expected {} in this order, got {}",
            want.join(", "),
            stems.join(", ")
        )));
    }
    fixtures
        .iter()
        .map(|f| {
            let mut map = f.height.clone();
            map.apply_intensity_cutoff(&f.intensity, CUTOFF)
                .map_err(|source| FiguresError::Mask {
                    stem: f.stem.clone(),
                    source,
                })?;
            Ok(map)
        })
        .collect::<Result<Vec<_>, FiguresError>>()
}

/// How the synthetic measured curve `m` of `sample` was made (`index.md`, and
/// `comparison.json`'s `measured.description`).
fn describe_measurement(ctx: &Ctx, sample: &SyntheticSample, m: &SyntheticMeasurement) -> String {
    // The measured curve's own sampling error near specular (median of se / value).
    let mut rel: Vec<f64> = m
        .clean
        .rows
        .iter()
        .filter(|r| {
            let ts = ctx.theta_s_deg[r.detector].to_radians();
            crate::compare::Region::of(r.theta_i, ts) == crate::compare::Region::NearSpecular
        })
        .filter_map(|r| r.std_err.filter(|_| r.brdf > 0.0).map(|e| e / r.brdf))
        .collect();
    rel.sort_by(f64::total_cmp);
    let median_se = rel.get(rel.len() / 2).copied().unwrap_or(f64::NAN);
    format!(
        "the topographic model averaged over the sample's rotation (physics.md §5.1: \
         every pixel's ring of rays at every azimuth, as a goniometer sees an isotropic \
         sample; clear coat on, physical weighting, n = 1.5, α = {APERTURE_DEG}°) on the \
         exact surfaces (no z quantisation, no height noise) of {maps} synthetic layers of \
         {size}² pixels at {pitch} µm (flake hwhm {hwhm}°, roughness rms {rr} µm with \
         correlation length {rc} µm, seeds {s0}–{s1}, intensity cutoff at the midpoint \
         0.49): {flakes} visible flakes, {usable} usable pixels of {pixels}; then each BRDF \
         × (1 + {NOISE} · N(0,1)), noise seed {NOISE_SEED}. The `uncertainty` column is \
         that noise and the clean curve's own sampling error (the spread between its 32 µm \
         tiles; median {se:.1} % 5°–40° from specular) in quadrature; {dropped} detectors \
         that no ray reached left out",
        maps = sample.maps,
        size = sample.size,
        pitch = sample.pitch_um,
        hwhm = sample.hwhm.to_degrees().round(),
        rr = sample.roughness_rms_um,
        rc = sample.roughness_correlation_um,
        s0 = sample.seed,
        s1 = sample.seed + sample.maps as u64 - 1,
        flakes = m.visible_flakes,
        usable = m.topo.usable_pixels,
        pixels = m.topo.pixels,
        se = 100.0 * median_se,
        dropped = m.dropped_points,
    )
}

/// `x` rounded to `JSON_DIGITS` significant digits (non-finite values unchanged).
pub(crate) fn sig(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    let d = JSON_DIGITS - 1;
    format!("{x:.d$e}").parse().unwrap_or(x)
}

/// `x` rounded to 6 decimals (log10 residuals: 1e-6 is a factor 1.0000023), `-0` as 0.
pub(crate) fn micro(x: f64) -> f64 {
    (x * 1e6).round() / 1e6 + 0.0
}

/// Degrees without float noise (`-69.5`).
pub(crate) fn deg(rad: f64) -> f64 {
    (rad.to_degrees() * 1e6).round() / 1e6 + 0.0
}

fn gaussian(hwhm_deg: f64) -> Result<Orientation, PipelineError> {
    Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians()))
        .map_err(|e| PipelineError::Orientation(e.to_string()))
}

/// The text of `index.md`.
fn index_md(index: &Index, spec: &FiguresSpec, summary: &Value) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Reproduced figures (Sung et al. 2002, Figs. 4, 7, 9, 10 in kind, and its multiple-scattering question)\n"
    );
    let _ = writeln!(
        s,
        "Generated by `{}` (flakescatter {}). Deterministic: every random draw has a \
         fixed seed, so a rerun gives the same numbers. Angles in degrees, θs signed \
         with θs = −θi the specular direction; detectors are cones of half-angle \
         {APERTURE_DEG}°; clear-coat index n = 1.5; flakes are perfect conductors; \
         model weighting `{}` (`--weighting paper-printed` gives the paper's printed \
         eqs. 9/13, for shapes only).\n",
        spec.command,
        env!("CARGO_PKG_VERSION"),
        weighting_name(spec.weighting)
    );
    let _ = writeln!(
        s,
        "**Reproducibility.** On the same platform a rerun writes every file bit for bit \
         (fixed seeds; results do not depend on the number of threads). Another platform's \
         maths library (`sin`, `exp`, `ln`, ...) may round a last bit differently, so the \
         numbers are written rounded: CSV values to 10 significant digits, \
         `comparison.json` to {JSON_DIGITS} significant digits for scales and widths and to \
         1e-6 for log10 residuals (whose mean is zero up to rounding where the scale is \
         fitted), the table below to 3–5. Such a difference \
         then changes at most a last digit of a CSV or JSON number (and rarely a pixel of \
         a plot); `cargo xtask figures --check` compares a fresh run with the committed \
         files number by number to a relative tolerance of 1e-6 and checks that every \
         plot is present and decodes, so it passes across machines.\n"
    );
    let _ = writeln!(
        s,
        "**No NIST measurement is used.** The \"measured\" curve of Figs. 9 and 10 \
         (`measured.csv`, columns `theta_i_deg, theta_s_deg, value, uncertainty`, value \
         = BRDF in sr⁻¹, uncertainty = one standard uncertainty in sr⁻¹; readable by \
         `flakescatter compare --measured`) is SYNTHETIC: {}.\n",
        index.measured
    );
    for (k, f) in index.figures.iter().enumerate() {
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
    s
}
