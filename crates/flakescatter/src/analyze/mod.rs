//! `flakescatter analyze`: one sample (a manifest of its maps and measured curve) in one
//! run — segmentation of every map → pooled statistics with both intervals → the
//! distribution model from the pooled width and from the pooled histogram → the
//! topographic model → comparison with the measured curve by region → the width fitted
//! to the measured curve → the multi-angle readout — and the report's content: tables,
//! charts, overlays, `summary.json` and a document written as `index.md` and
//! `index.html`. The caller resolves the manifest's file lists, writes the files and
//! draws charts and overlays.
//!
//! **Resuming.** Each map's segmentation is kept in the report (`cache/maps/NAME.json`)
//! under a key, the SHA-256 of its inputs' bytes, of the settings that shape it, of
//! the program version and of the build's identity (the caller's, e.g. the CLI's hash
//! of its sources, compiler and profile: a new build never reuses an older build's
//! results); the model results likewise (`cache/models.json`) under a key of every map
//! key, the model settings and the measured curve's bytes. A rerun with the
//! same key takes them from the cache instead of computing them, so a batch can be
//! resumed; [`Work`] (`summary.json` key `work`) counts what was computed and what was
//! reused. The statistics, comparisons and report are always recomputed from those
//! (they take milliseconds).
//!
//! Conventions: radians and micrometres inside; degrees and µm in the files, as their
//! column names say.

pub mod document;
mod keys;
pub mod manifest;
mod optional;
mod paint;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use flakescatter_io::files::{read_text, sha256_bytes, sha256_file};
use flakescatter_io::measured::{MeasuredCurve, read_measured};
use flakescatter_io::stack::{PageOrder, StackOptions};
use flakescatter_io::{ReadOptions, ZUnit};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_stats::flake::UnitVec3;
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::nalgebra::{Unit, Vector3};
use flakescatter_stats::segment::{SegmentParams, SegmentWarning, Segmentation, SegmentedFlake};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use crate::PipelineError;
use crate::chart::{Chart, Series, Style, THETA_S_LABEL, histogram_chart};
use crate::compare::{IncidenceComparison, MeasuredKind, ModelPoint, compare, tabulated_points};
use crate::fit::{FitSetup, fit_gaussian};
use crate::inputs::{LoadOptions, MapSource, load_map};
use crate::instrument::{DetectorSet, Instrument};
use crate::multiangle::multi_angle;
use crate::overlay::{Overlay, overlay};
use crate::pipeline::{
    Coating, CurveRow, Curves, OrientationSource, Settings, TopoSettings, distribution_curves,
    isotropic_curves, topographic_curves,
};
use crate::sample::{SampleSettings, SampleStatistics, segment_maps, statistics_of};
use document::{Block, Document};
pub use manifest::{Manifest, ManifestError, TopoKind};
pub use optional::FailedStatistic;

/// Errors of an analysis.
#[derive(Debug, thiserror::Error)]
pub enum AnalyzeError {
    /// An input file could not be read (names it).
    #[error("{0}")]
    Input(String),
    /// A computation failed.
    #[error("{stage}: {source}")]
    Pipeline {
        /// Which step.
        stage: &'static str,
        /// What went wrong.
        source: PipelineError,
    },
}

/// One sample, its manifest resolved into files.
#[derive(Debug, Clone)]
pub struct SampleInput {
    /// The manifest.
    pub manifest: Manifest,
    /// Its file.
    pub file: PathBuf,
    /// The sample's name (the manifest's `name`, or its file stem).
    pub name: String,
    /// The maps in order, with their intensity partners.
    pub maps: Vec<MapSource>,
    /// Short names of the maps (unique; file names of overlays and caches).
    pub map_names: Vec<String>,
    /// The measured curve files, resolved.
    pub measured: Vec<PathBuf>,
    /// The `[paint]` BRDF table, resolved.
    pub paint: Option<PathBuf>,
}

/// What one output file holds.
#[derive(Debug, Clone)]
pub enum Content {
    /// Text (CSV, JSON, Markdown).
    Text(String),
    /// A chart, drawn as PNG.
    Chart(Chart),
    /// A segmentation overlay with its title, drawn as PNG.
    Overlay(Box<Overlay>, String),
    /// Maps of out-of-plane residuals, one panel per incidence `(θi radians, cells
    /// (θr°, φr°, log10 residual))`, and the table's name, drawn as PNG.
    ResidualMaps(Vec<crate::paint::report::ResidualPanel>, String),
}

/// One output file, its path relative to the sample's report directory.
#[derive(Debug, Clone)]
pub struct OutFile {
    /// Relative path (`/`-separated).
    pub path: String,
    /// What goes into it.
    pub content: Content,
}

/// How much work a run did and how much it took from the cache.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Work {
    /// Maps in the sample.
    pub maps: usize,
    /// Maps segmented in this run.
    pub maps_segmented: usize,
    /// Maps whose segmentation came from the cache.
    pub maps_reused: usize,
    /// Distribution-model curve sets computed.
    pub distribution_runs: usize,
    /// Topographic-model runs.
    pub topographic_runs: usize,
    /// Width fits to the measured curve.
    pub fits: usize,
    /// Multi-angle readouts.
    pub multi_angle_runs: usize,
    /// Whether the model results came from the cache.
    pub models_reused: bool,
    /// Paint fits to the `[paint]` table (0 when the cached paint was reused).
    #[serde(default)]
    pub paint_fits: usize,
}

impl Work {
    /// Model work done: segmentations plus model runs (0 when everything was reused).
    #[must_use]
    pub fn model_work(&self) -> usize {
        self.maps_segmented
            + self.distribution_runs
            + self.topographic_runs
            + self.fits
            + self.multi_angle_runs
            + self.paint_fits
    }
}

/// One sample's line in a comparison across samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleRow {
    /// Sample name.
    pub name: String,
    /// Maps.
    pub maps: usize,
    /// Flakes.
    pub flakes: usize,
    /// Pooled hwhm, degrees.
    pub hwhm_deg: f64,
    /// Its quoted 95 % interval, degrees (`None` for an infinite end).
    pub hwhm_ci95_deg: (Option<f64>, Option<f64>),
    /// Which interval that is (`map level` or `flake level`).
    pub interval: String,
    /// Width fitted to the measured curve, degrees, with its standard uncertainty.
    pub fitted_hwhm_deg: Option<(f64, f64)>,
    /// Near-specular rms log10 residual per model and incidence: `(model, θi°, rms)`.
    pub near_specular: Vec<(String, f64, Option<f64>)>,
    /// Multi-angle lightness at 15°, 45°, 110° aspecular, and the flop index.
    pub lightness: Option<(f64, f64, f64, Option<f64>)>,
}

/// Everything a sample's report holds.
#[derive(Debug, Clone)]
pub struct SampleReport {
    /// The sample's name.
    pub name: String,
    /// The files (besides `index.md` and `index.html`, which the caller writes from
    /// `document`).
    pub files: Vec<OutFile>,
    /// The report document (`index.md`, `index.html`).
    pub document: Document,
    /// `summary.json` as a value (also among `files`).
    pub summary: Value,
    /// What was computed and reused.
    pub work: Work,
    /// Warnings, for the terminal (also in `summary.json`).
    pub warnings: Vec<String>,
    /// The sample's line in a comparison across samples.
    pub row: SampleRow,
}

// ---- cache ----------------------------------------------------------------------------

/// A segmented flake as kept in the cache (every field of [`SegmentedFlake`], bit for
/// bit through JSON).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct FlakeRec {
    normal: [f64; 3],
    theta_n: f64,
    phi_n: f64,
    centre_um: [f64; 2],
    pixels: usize,
    inliers: usize,
    projected_area_um2: f64,
    area_um2: f64,
    equivalent_diameter_um: f64,
    rms_um: f64,
    tilt_se: f64,
    touches_border: bool,
    quality: f64,
}

impl FlakeRec {
    fn of(f: &SegmentedFlake) -> Self {
        Self {
            normal: [f.normal.x, f.normal.y, f.normal.z],
            theta_n: f.theta_n,
            phi_n: f.phi_n,
            centre_um: f.centre_um,
            pixels: f.pixels,
            inliers: f.inliers,
            projected_area_um2: f.projected_area_um2,
            area_um2: f.area_um2,
            equivalent_diameter_um: f.equivalent_diameter_um,
            rms_um: f.rms_um,
            tilt_se: f.tilt_se,
            touches_border: f.touches_border,
            quality: f.quality,
        }
    }

    fn flake(&self) -> SegmentedFlake {
        let n: UnitVec3 =
            Unit::new_unchecked(Vector3::new(self.normal[0], self.normal[1], self.normal[2]));
        SegmentedFlake {
            normal: n,
            theta_n: self.theta_n,
            phi_n: self.phi_n,
            centre_um: self.centre_um,
            pixels: self.pixels,
            inliers: self.inliers,
            projected_area_um2: self.projected_area_um2,
            area_um2: self.area_um2,
            equivalent_diameter_um: self.equivalent_diameter_um,
            rms_um: self.rms_um,
            tilt_se: self.tilt_se,
            touches_border: self.touches_border,
            quality: self.quality,
        }
    }
}

/// A map's segmentation as kept in the cache.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct MapCache {
    key: String,
    flakes: Vec<FlakeRec>,
    /// Label map as runs `(label, count)` in raster order.
    labels: Vec<(u32, u32)>,
    valid_pixels: usize,
    dropped_pixels: usize,
    warning: Option<String>,
}

impl MapCache {
    fn of(key: String, s: &Segmentation) -> Self {
        let mut runs: Vec<(u32, u32)> = Vec::new();
        for &l in &s.labels {
            match runs.last_mut() {
                Some((v, n)) if *v == l && *n < u32::MAX => *n += 1,
                _ => runs.push((l, 1)),
            }
        }
        Self {
            key,
            flakes: s.flakes.iter().map(FlakeRec::of).collect(),
            labels: runs,
            valid_pixels: s.valid_pixels,
            dropped_pixels: s.dropped_pixels,
            warning: s.warning.map(|w| match w {
                SegmentWarning::NoValidPixels => "no-valid-pixels".into(),
                SegmentWarning::NoFlakes => "no-flakes".into(),
            }),
        }
    }

    /// The segmentation, if the cache is consistent with a map of `len` pixels.
    fn segmentation(&self, len: usize) -> Option<Segmentation> {
        let mut labels = Vec::with_capacity(len);
        for &(l, n) in &self.labels {
            if l as usize > self.flakes.len() || labels.len() + n as usize > len {
                return None;
            }
            labels.extend(std::iter::repeat_n(l, n as usize));
        }
        (labels.len() == len).then(|| Segmentation {
            flakes: self.flakes.iter().map(FlakeRec::flake).collect(),
            labels,
            valid_pixels: self.valid_pixels,
            dropped_pixels: self.dropped_pixels,
            warning: match self.warning.as_deref() {
                Some("no-valid-pixels") => Some(SegmentWarning::NoValidPixels),
                Some(_) => Some(SegmentWarning::NoFlakes),
                None => None,
            },
        })
    }
}

/// One curve row as kept in the cache.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
struct RowRec {
    theta_i: f64,
    detector: usize,
    brdf: f64,
    reflectance: Option<f64>,
    relative: f64,
    rays: Option<u64>,
    std_err: Option<f64>,
}

/// A model's curves as kept in the cache.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CurveRec {
    /// `distribution (pooled width)`, `distribution (pooled histogram)`, `topographic`
    /// or `topographic (isotropic)`.
    label: String,
    model: String,
    source: String,
    rows: Vec<RowRec>,
}

/// The width fit as kept.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct FitRec {
    hwhm: f64,
    hwhm_std: f64,
    scales: Vec<(f64, f64)>,
    chi2: f64,
    dof: usize,
    points: usize,
    iterations: usize,
    uncertainty_basis: String,
    uncertainty_scale: f64,
    warnings: Vec<String>,
}

/// The multi-angle readout as kept.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct MultiRec {
    theta_i: f64,
    /// `(aspecular, reflectance factor, L*)`.
    readouts: Vec<(f64, f64, f64)>,
    flop_index: Option<f64>,
}

/// The model results as kept.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ModelCache {
    key: String,
    curves: Vec<CurveRec>,
    /// Failures of single models (the others still run), `(model, message)`.
    failures: Vec<(String, String)>,
    fit: Option<Result<FitRec, String>>,
    multi_angle: Option<Result<MultiRec, String>>,
    topo_warnings: Vec<String>,
}

/// What an earlier run of the same report directory left (module docs).
#[derive(Debug, Clone, Default)]
pub struct Cache {
    maps: BTreeMap<String, MapCache>,
    models: Option<ModelCache>,
    paint: Option<Value>,
}

/// Reads the cache of the report directory `dir` (the sample's own directory): files
/// that are missing or cannot be parsed are ignored (the work is then redone).
#[must_use]
pub fn read_cache(dir: &Path, map_names: &[String]) -> Cache {
    let mut c = Cache::default();
    for name in map_names {
        let p = dir.join("cache").join("maps").join(format!("{name}.json"));
        if let Some(m) = read_text(&p)
            .ok()
            .and_then(|t| serde_json::from_str::<MapCache>(&t).ok())
        {
            c.maps.insert(name.clone(), m);
        }
    }
    c.models = read_text(dir.join("cache").join("models.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    c.paint = read_text(dir.join("cache").join("paint.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    c
}

// ---- settings -------------------------------------------------------------------------

/// The loader options of a manifest.
///
/// # Errors
/// A message naming the key for values [`Manifest::validate`] lets through but the
/// readers refuse (e.g. an unknown z unit).
pub fn load_options(m: &Manifest) -> Result<LoadOptions, String> {
    let z_unit = match &m.maps.z_unit {
        Some(z) => Some(
            z.parse::<ZUnit>()
                .map_err(|e| format!("key `maps.z_unit`: {e}"))?,
        ),
        None => None,
    };
    let read = ReadOptions {
        pixel_um: m.maps.pixel_um.map(|[x, y]| (x, y)),
        z_unit,
        ..ReadOptions::default()
    };
    let peak = flakescatter_confocal::PeakOptions {
        method: flakescatter_confocal::PeakMethod::from_name(&m.stack.peak)
            .ok_or_else(|| format!("key `stack.peak`: `{}` is not a method", m.stack.peak))?,
        min_signal: m
            .stack
            .min_signal
            .map_or(flakescatter_confocal::MinSignal::Estimated, |v| {
                flakescatter_confocal::MinSignal::Level(v)
            }),
        ..flakescatter_confocal::PeakOptions::default()
    };
    Ok(LoadOptions {
        read,
        cutoff: m.maps.cutoff,
        stack: StackOptions {
            pixel_um: read.pixel_um,
            z_step_um: m.stack.z_step_um,
            first_page: match m.stack.first_page.as_deref() {
                Some("top") => Some(PageOrder::TopFirst),
                Some(_) => Some(PageOrder::BottomFirst),
                None => None,
            },
        },
        peak,
    })
}

fn segment_params(m: &Manifest) -> SegmentParams {
    let mut p = SegmentParams::for_instrument(m.instrument.z_step_um, m.instrument.noise_um);
    p.min_pixels = m.instrument.min_pixels;
    p
}

fn coating_of(m: &Manifest) -> Result<Coating, String> {
    Ok(Coating {
        n: m.coating.n,
        flake: match m.coating.flake_index {
            None => FlakeReflectance::PerfectConductor,
            Some([n, k]) => FlakeReflectance::complex(n, k)
                .map_err(|e| format!("key `coating.flake_index`: {e}"))?,
        },
    })
}

fn hash_json(v: &Value) -> String {
    sha256_bytes(v.to_string().as_bytes())
}

fn input_err(e: impl std::fmt::Display) -> AnalyzeError {
    AnalyzeError::Input(e.to_string())
}

fn stage(stage: &'static str) -> impl Fn(PipelineError) -> AnalyzeError {
    move |source| AnalyzeError::Pipeline { stage, source }
}

/// Joins the measured files into one curve; a point measured twice is an error naming
/// both files.
fn read_measured_files(files: &[PathBuf]) -> Result<Option<MeasuredCurve>, AnalyzeError> {
    if files.is_empty() {
        return Ok(None);
    }
    let mut points = Vec::new();
    let mut from: Vec<String> = Vec::new();
    let mut names = Vec::new();
    for f in files {
        let c = read_measured(f).map_err(input_err)?;
        for p in c.points {
            if let Some(k) =
                points
                    .iter()
                    .position(|q: &flakescatter_io::measured::MeasuredPoint| {
                        (q.theta_i - p.theta_i).abs() < 1e-9 && (q.theta_s - p.theta_s).abs() < 1e-9
                    })
            {
                return Err(AnalyzeError::Input(format!(
                    "measured point theta_i {:.6}°, theta_s {:.6}° is in {} (line {}) and in {} (line {})",
                    p.theta_i.to_degrees(),
                    p.theta_s.to_degrees(),
                    from[k],
                    points[k].line,
                    f.display(),
                    p.line
                )));
            }
            points.push(p);
            from.push(f.display().to_string());
        }
        names.push(f.display().to_string());
    }
    Ok(Some(MeasuredCurve {
        file: names.join(" + "),
        points,
    }))
}

/// The instrument of the models: the manifest's incidences (default the measured
/// ones, else 30° and 60°) and detectors.
fn instrument_of(
    m: &Manifest,
    measured: Option<&MeasuredCurve>,
) -> Result<Instrument, AnalyzeError> {
    let ti: Vec<f64> = match (&m.models.theta_i_deg, measured) {
        (Some(t), _) => t.iter().map(|d| d.to_radians()).collect(),
        (None, Some(c)) => c.incidences(),
        (None, None) => vec![30f64.to_radians(), 60f64.to_radians()],
    };
    let ts: Vec<f64> = match &m.models.theta_s_deg {
        Some(a) => a
            .degrees("models.theta_s_deg")
            .map_err(AnalyzeError::Input)?
            .iter()
            .map(|d| d.to_radians())
            .collect(),
        None => (-140..=140)
            .map(|k| (f64::from(k) * 0.5).to_radians())
            .collect(),
    };
    Instrument::new(
        ti,
        DetectorSet::InPlane(ts),
        m.models.aperture_deg.to_radians(),
    )
    .map_err(stage("instrument"))
}

fn row_rec(r: &CurveRow) -> RowRec {
    RowRec {
        theta_i: r.theta_i,
        detector: r.detector,
        brdf: r.brdf,
        reflectance: r.reflectance,
        relative: r.relative,
        rays: r.rays,
        std_err: r.std_err,
    }
}

fn curve_rec(label: &str, c: &Curves) -> CurveRec {
    CurveRec {
        label: label.to_owned(),
        model: c.model.to_owned(),
        source: c.source.clone(),
        rows: c.rows.iter().map(row_rec).collect(),
    }
}

/// Runs every model the manifest asks for (module docs).
#[allow(clippy::too_many_arguments)]
fn run_models(
    m: &Manifest,
    key: String,
    instrument: &Instrument,
    coating: &Coating,
    stats: &SampleStatistics,
    maps: &[&HeightMap],
    measured: Option<&MeasuredCurve>,
    work: &mut Work,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<ModelCache, AnalyzeError> {
    let settings = Settings {
        clearcoat: m.models.clearcoat,
        ..Settings::default()
    };
    let mut curves = Vec::new();
    let mut failures = Vec::new();
    let width = stats
        .pooled
        .flake_level
        .orientation()
        .map_err(|e| stage("pooled width")(PipelineError::Orientation(e.to_string())))?;
    if m.models.distribution_fitted {
        progress("distribution model, pooled width", 0, 1);
        work.distribution_runs += 1;
        match distribution_curves(
            coating,
            instrument,
            &settings,
            &OrientationSource::Distribution(width.clone()),
        ) {
            Ok(c) => curves.push(curve_rec("distribution (pooled width)", &c)),
            Err(e) => failures.push(("distribution (pooled width)".into(), e.to_string())),
        }
    }
    if m.models.distribution_histogram {
        progress("distribution model, pooled histogram", 0, 1);
        work.distribution_runs += 1;
        match stats
            .histogram
            .to_orientation()
            .map_err(|e| PipelineError::Orientation(e.to_string()))
            .and_then(|o| {
                distribution_curves(
                    coating,
                    instrument,
                    &settings,
                    &OrientationSource::Distribution(o),
                )
            }) {
            Ok(c) => curves.push(curve_rec("distribution (pooled histogram)", &c)),
            Err(e) => failures.push(("distribution (pooled histogram)".into(), e.to_string())),
        }
    }
    let topo = TopoSettings {
        window: m.models.window,
        tile_um: m.models.tile_um,
    };
    let mut topo_warnings = Vec::new();
    let tick = |done: u64, total: u64| progress("topographic model", done as usize, total as usize);
    match m.models.topographic {
        TopoKind::None => {}
        TopoKind::Plain => {
            work.topographic_runs += 1;
            match topographic_curves(coating, instrument, &settings, &topo, maps, &tick) {
                Ok((c, r)) => {
                    topo_warnings.extend(r.warnings.iter().map(ToString::to_string));
                    curves.push(curve_rec("topographic", &c));
                }
                Err(e) => failures.push(("topographic".into(), e.to_string())),
            }
        }
        TopoKind::Isotropic => {
            work.topographic_runs += 1;
            match isotropic_curves(coating, instrument, &settings, &topo, None, maps, &tick) {
                Ok((c, r)) => {
                    topo_warnings.extend(r.warnings.iter().map(ToString::to_string));
                    curves.push(curve_rec("topographic (isotropic)", &c));
                }
                Err(e) => failures.push(("topographic (isotropic)".into(), e.to_string())),
            }
        }
    }
    let fit = match (m.models.fit, measured) {
        (true, Some(curve)) => {
            progress("width fit to the measured curve", 0, 1);
            work.fits += 1;
            let kind: MeasuredKind = m
                .measured
                .as_ref()
                .and_then(|s| s.kind.parse().ok())
                .unwrap_or_default();
            let setup = FitSetup::new(coating.clone(), settings, instrument.aperture(), kind);
            Some(
                fit_gaussian(curve, &setup, stats.pooled.hwhm(), false)
                    .map(|f| FitRec {
                        hwhm: f.hwhm,
                        hwhm_std: f.hwhm_std,
                        scales: f.scales.clone(),
                        chi2: f.chi2,
                        dof: f.dof,
                        points: f.points,
                        iterations: f.iterations,
                        uncertainty_basis: f.uncertainty_basis.describe().to_owned(),
                        uncertainty_scale: f.uncertainty_scale,
                        warnings: f.warnings.iter().map(ToString::to_string).collect(),
                    })
                    .map_err(|e| e.to_string()),
            )
        }
        _ => None,
    };
    let multi = m.models.multi_angle.then(|| {
        progress("multi-angle readout", 0, 1);
        work.multi_angle_runs += 1;
        multi_angle(
            coating,
            &settings,
            &OrientationSource::Distribution(width),
            instrument.aperture(),
        )
        .map(|r| MultiRec {
            theta_i: r.theta_i,
            readouts: r
                .readouts
                .iter()
                .map(|x| (x.aspecular, x.reflectance_factor, x.lightness))
                .collect(),
            flop_index: r.flop_index,
        })
        .map_err(|e| e.to_string())
    });
    Ok(ModelCache {
        key,
        curves,
        failures,
        fit,
        multi_angle: multi,
        topo_warnings,
    })
}

/// Analyses one sample (module docs); `cache` is what [`read_cache`] found in its
/// report directory; `build` identifies the program build (any text that changes
/// whenever the code, its dependencies, the compiler or the profile do: it enters
/// every cache key); `progress(stage, done, total)` is told what is being done.
///
/// # Errors
/// [`AnalyzeError::Input`] for an input that cannot be read (naming it),
/// [`AnalyzeError::Pipeline`] for a statistics step that fails (no flake in any map).
/// A model that fails is reported in the summary and the others still run.
#[allow(clippy::too_many_lines)]
pub fn analyze_sample(
    input: &SampleInput,
    cache: &Cache,
    build: &str,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<SampleReport, AnalyzeError> {
    let m = &input.manifest;
    let file = input.file.display().to_string();
    let options = load_options(m).map_err(|e| AnalyzeError::Input(format!("{file}: {e}")))?;
    let coating = coating_of(m).map_err(|e| AnalyzeError::Input(format!("{file}: {e}")))?;
    let params = segment_params(m);
    let version = env!("CARGO_PKG_VERSION");
    let mut work = Work {
        maps: input.maps.len(),
        ..Work::default()
    };
    let mut warnings: Vec<String> = crate::inputs::distinct::check_distinct_maps(
        &input.maps,
        m.maps.allow_duplicates,
        "set `maps.allow_duplicates = true`",
    )
    .map_err(|e| AnalyzeError::Input(format!("{file}: key `maps.files`: {e}")))?;

    // Inputs: hashes, maps, keys.
    let mut maps = Vec::with_capacity(input.maps.len());
    let mut keys = Vec::with_capacity(input.maps.len());
    let mut map_info = Vec::new();
    for (k, src) in input.maps.iter().enumerate() {
        progress("reading maps", k, input.maps.len());
        let h = sha256_file(&src.height).map_err(input_err)?;
        let ih = match &src.intensity {
            Some(p) => Some(sha256_file(p).map_err(input_err)?),
            None => None,
        };
        let loaded = load_map(src, &options, &|_, _| {}).map_err(input_err)?;
        let key = hash_json(&json!({
            "version": version,
            "build": build,
            "height_sha256": h,
            "intensity_sha256": ih,
            "maps": {
                "cutoff": m.maps.cutoff, "pixel_um": m.maps.pixel_um, "z_unit": m.maps.z_unit,
                "channel": m.maps.channel, "intensity_channel": m.maps.intensity_channel,
            },
            "stack": m.stack,
            "instrument": m.instrument,
        }));
        map_info.push(json!({
            "name": input.map_names[k],
            "file": src.height.display().to_string(),
            "sha256": h,
            "intensity": src.intensity.as_ref().map(|p| p.display().to_string()),
            "intensity_sha256": ih,
            "format": loaded.format,
            "nx": loaded.map.nx(),
            "ny": loaded.map.ny(),
            "dx_um": loaded.map.dx(),
            "dy_um": loaded.map.dy(),
            "valid_pixels_before_cutoff": loaded.valid_before_cutoff,
            "valid_pixels": loaded.map.valid_count(),
            "cache_key": key,
        }));
        keys.push(key);
        maps.push(loaded.map);
    }
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let measured = read_measured_files(&input.measured)?;
    let measured_hashes: Vec<String> = input
        .measured
        .iter()
        .map(sha256_file)
        .collect::<Result<_, _>>()
        .map_err(input_err)?;

    // Segmentation, from the cache where the key matches.
    let mut segs = Vec::with_capacity(maps.len());
    let mut map_caches = Vec::with_capacity(maps.len());
    for (k, map) in refs.iter().enumerate() {
        let name = &input.map_names[k];
        let cached = cache
            .maps
            .get(name)
            .filter(|c| c.key == keys[k])
            .and_then(|c| c.segmentation(map.len()));
        let seg = match cached {
            Some(s) => {
                work.maps_reused += 1;
                s
            }
            None => {
                progress("segmenting maps", k, maps.len());
                work.maps_segmented += 1;
                segment_maps(&[map], &params, &|_, _| {})
                    .map_err(stage("segmentation"))?
                    .remove(0)
            }
        };
        if let Some(w) = seg.warning {
            warnings.push(format!("map {name}: {w}"));
        }
        map_caches.push(MapCache::of(keys[k].clone(), &seg));
        segs.push(seg);
    }
    progress("pooled statistics", 0, 1);
    optional::require_flakes(m, &refs, &input.map_names, &segs)
        .map_err(|e| AnalyzeError::Input(format!("{file}: {e}")))?;
    // The pixel-level statistics are optional: computed apart, so that their failure
    // is reported rather than fatal (optional module docs).
    let sample_settings = SampleSettings {
        segment: params,
        bin_width: m.stats.bin_deg.to_radians(),
        pixel_normals: None,
    };
    let mut stats = statistics_of(&refs, segs, &sample_settings).map_err(stage("statistics"))?;
    warnings.extend(stats.pooled.warnings.iter().map(ToString::to_string));
    let failed = optional::optional_statistics(m, &refs, &input.map_names, &mut stats);
    warnings.extend(failed.iter().map(FailedStatistic::warning));

    // Models, from the cache where the key matches.
    let instrument = instrument_of(m, measured.as_ref())?;
    let models_key = hash_json(&json!({
        "version": version,
        "build": build,
        "maps": keys,
        "models": m.models,
        "coating": m.coating,
        "stats": m.stats.bin_deg,
        "measured": measured_hashes,
        "kind": m.measured.as_ref().map(|s| s.kind.clone()),
    }));
    let models = match cache.models.as_ref().filter(|c| c.key == models_key) {
        Some(c) => {
            work.models_reused = true;
            c.clone()
        }
        None => run_models(
            m,
            models_key,
            &instrument,
            &coating,
            &stats,
            &refs,
            measured.as_ref(),
            &mut work,
            progress,
        )?,
    };
    for (model, e) in &models.failures {
        warnings.push(format!("{model}: {e}"));
    }
    let tiles = optional::tile_hint(m, &refs, &input.map_names);
    warnings.extend(models.topo_warnings.iter().map(|w| match &tiles {
        Some(h) if w.contains("tile") => format!("{w} ({h})"),
        _ => w.clone(),
    }));

    // Comparisons.
    let kind: MeasuredKind = m
        .measured
        .as_ref()
        .and_then(|s| s.kind.parse().ok())
        .unwrap_or_default();
    let aperture = instrument.aperture();
    let ts_list = match instrument.detectors() {
        DetectorSet::InPlane(ts) => ts.clone(),
        DetectorSet::OutOfPlane(_) => Vec::new(),
    };
    let mut comparisons: Vec<(String, Vec<IncidenceComparison>)> = Vec::new();
    if let Some(curve) = &measured {
        for rec in &models.curves {
            let table: Vec<(f64, f64, ModelPoint)> = rec
                .rows
                .iter()
                .map(|r| {
                    (
                        r.theta_i,
                        ts_list[r.detector],
                        ModelPoint::from_row(r.brdf, r.relative, r.reflectance, aperture),
                    )
                })
                .collect();
            // Only measured points at the model's angles are compared.
            let tol = 1e-6f64.to_radians();
            let covered: Vec<_> = curve
                .points
                .iter()
                .filter(|p| {
                    table
                        .iter()
                        .any(|(a, b, _)| (a - p.theta_i).abs() < tol && (b - p.theta_s).abs() < tol)
                })
                .copied()
                .collect();
            if covered.len() < curve.points.len() {
                warnings.push(format!(
                    "{}: {} of {} measured points lie outside the models' angles and are not compared",
                    rec.label,
                    curve.points.len() - covered.len(),
                    curve.points.len()
                ));
            }
            let sub = MeasuredCurve {
                file: curve.file.clone(),
                points: covered,
            };
            let f = |ti: f64, ts: &[f64]| tabulated_points(&table, &rec.label, ti, ts);
            match compare(&sub, kind, &f) {
                Ok(c) => comparisons.push((rec.label.clone(), c)),
                Err(e) => warnings.push(format!("comparison with {}: {e}", rec.label)),
            }
        }
    }

    let paint = match (&m.paint, &input.paint) {
        (Some(section), Some(file)) => {
            let p = paint::paint_part(
                section,
                file,
                coating.n,
                cache.paint.as_ref(),
                build,
                progress,
            )?;
            if p.fitted {
                work.paint_fits += 1;
            }
            Some(p)
        }
        _ => None,
    };
    let report = build_report(
        input,
        &instrument,
        &coating,
        &stats,
        &refs,
        &models,
        measured.as_ref(),
        &comparisons,
        work,
        warnings,
        map_info,
        &measured_hashes,
        &map_caches,
        paint,
        &failed,
        build,
    );
    Ok(report)
}

// ---- report ---------------------------------------------------------------------------

fn num(x: f64) -> String {
    if !x.is_finite() {
        String::new()
    } else if x == 0.0 {
        "0".into()
    } else {
        format!("{x:e}")
    }
}

fn opt(x: Option<f64>) -> String {
    x.map(num).unwrap_or_default()
}

/// Degrees without float noise.
fn deg(rad: f64) -> f64 {
    (rad.to_degrees() * 1e9).round() / 1e9 + 0.0
}

fn ci_deg(ci: (f64, f64)) -> (Option<f64>, Option<f64>) {
    let f = |x: f64| x.is_finite().then(|| x.to_degrees());
    (f(ci.0), f(ci.1))
}

fn fmt_ci(ci: (Option<f64>, Option<f64>)) -> String {
    let f = |x: Option<f64>| x.map_or_else(|| "∞".to_owned(), |v| format!("{v:.2}"));
    format!("[{}, {}]", f(ci.0), f(ci.1))
}

#[allow(clippy::too_many_arguments, clippy::too_many_lines)]
fn build_report(
    input: &SampleInput,
    instrument: &Instrument,
    coating: &Coating,
    stats: &SampleStatistics,
    maps: &[&HeightMap],
    models: &ModelCache,
    measured: Option<&MeasuredCurve>,
    comparisons: &[(String, Vec<IncidenceComparison>)],
    work: Work,
    warnings: Vec<String>,
    map_info: Vec<Value>,
    measured_hashes: &[String],
    map_caches: &[MapCache],
    paint: Option<paint::PaintOutcome>,
    failed: &[FailedStatistic],
    build: &str,
) -> SampleReport {
    let m = &input.manifest;
    let p = &stats.pooled;
    let names = &input.map_names;
    let mut files: Vec<OutFile> = Vec::new();
    let mut warnings = warnings;
    let (paint_blocks, paint_summary) = match paint {
        Some(o) => {
            files.extend(o.files);
            warnings.extend(o.warnings);
            (o.blocks, o.summary)
        }
        None => (Vec::new(), Value::Null),
    };
    let text = |path: &str, t: String| OutFile {
        path: path.to_owned(),
        content: Content::Text(t),
    };
    let ts_list = match instrument.detectors() {
        DetectorSet::InPlane(ts) => ts.clone(),
        DetectorSet::OutOfPlane(_) => Vec::new(),
    };
    let kind: MeasuredKind = m
        .measured
        .as_ref()
        .and_then(|s| s.kind.parse().ok())
        .unwrap_or_default();

    // maps.csv
    let mut t = String::from(
        "map,file,flakes,area_um2,effective_flakes,hwhm_deg,hwhm_ci95_lo_deg,hwhm_ci95_hi_deg,z,flagged,valid_pixels,dropped_pixels\n",
    );
    for (k, w) in p.maps.iter().enumerate() {
        let (h, lo, hi) = w.fit.map_or((f64::NAN, f64::NAN, f64::NAN), |f| {
            let c = f.hwhm_ci95();
            (f.hwhm().to_degrees(), c.0.to_degrees(), c.1.to_degrees())
        });
        let _ = writeln!(
            t,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            names[k],
            input.maps[k].height.display(),
            w.flakes,
            num(w.area_um2),
            num(w.effective_n),
            num(h),
            num(lo),
            num(hi),
            opt(w.z),
            w.flagged,
            stats.segmentations[k].valid_pixels,
            stats.segmentations[k].dropped_pixels
        );
    }
    files.push(text("maps.csv", t));

    // flakes.csv
    let mut t = String::from(
        "map,flake,x_um,y_um,nx,ny,nz,area_um2,theta_n_deg,phi_n_deg,projected_area_um2,equivalent_diameter_um,rms_um,tilt_se_deg,pixels,inliers,touches_border,quality\n",
    );
    for (k, s) in stats.segmentations.iter().enumerate() {
        for (i, f) in s.flakes.iter().enumerate() {
            let _ = writeln!(
                t,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                names[k],
                i + 1,
                num(f.centre_um[0]),
                num(f.centre_um[1]),
                num(f.normal.x),
                num(f.normal.y),
                num(f.normal.z),
                num(f.area_um2),
                num(f.theta_n.to_degrees()),
                num(f.phi_n.to_degrees()),
                num(f.projected_area_um2),
                num(f.equivalent_diameter_um),
                num(f.rms_um),
                num(f.tilt_se.to_degrees()),
                f.pixels,
                f.inliers,
                f.touches_border,
                num(f.quality)
            );
        }
    }
    files.push(text("flakes.csv", t));

    // histogram.csv
    let mut t = String::from("theta_lo_deg,theta_hi_deg,area_fraction,p_per_rad,p_tilde\n");
    for b in stats.histogram.bins() {
        let _ = writeln!(
            t,
            "{},{},{},{},{}",
            deg(b.theta_lo),
            deg(b.theta_hi),
            num(b.area_fraction),
            num(b.p_per_rad),
            num(b.p_tilde)
        );
    }
    files.push(text("histogram.csv", t));

    // curves.csv
    let mut t = String::from(
        "model,theta_i_deg,theta_s_deg,aperture_deg,brdf_per_sr,std_err_per_sr,reflectance,relative,rays\n",
    );
    for c in &models.curves {
        for r in &c.rows {
            let _ = writeln!(
                t,
                "{},{},{},{},{},{},{},{},{}",
                c.label,
                deg(r.theta_i),
                deg(ts_list[r.detector]),
                deg(instrument.aperture()),
                num(r.brdf),
                opt(r.std_err),
                opt(r.reflectance),
                num(r.relative),
                r.rays.map(|x| x.to_string()).unwrap_or_default()
            );
        }
    }
    files.push(text("curves.csv", t));

    // comparison.csv
    if !comparisons.is_empty() {
        let mut t = String::from(
            "model,theta_i_deg,scale,region,points,points_without_model,rms_log10,mean_log10\n",
        );
        for (label, cs) in comparisons {
            for c in cs {
                for r in &c.regions {
                    let _ = writeln!(
                        t,
                        "{label},{},{},{},{},{},{},{}",
                        deg(c.theta_i),
                        num(c.scale),
                        r.region.name(),
                        r.points,
                        r.no_model,
                        opt(r.rms_log10),
                        opt(r.mean_log10)
                    );
                }
            }
        }
        files.push(text("comparison.csv", t));
    }

    // Charts: histogram, curves per incidence.
    let (qci, qname) = match p.map_level {
        Some(ml) => (ml.sigma_ci95, "map level"),
        None => (p.flake_level.sigma_ci95, "flake level"),
    };
    files.push(OutFile {
        path: "histogram.png".into(),
        content: Content::Chart(histogram_chart(
            &stats.histogram,
            p.flake_level.sigma,
            qci,
            qname,
            &format!(
                "{}: area-weighted flake tilts, {} maps",
                input.name,
                names.len()
            ),
        )),
    });
    let mut curve_images = Vec::new();
    for (k, &ti) in instrument.theta_i().iter().enumerate() {
        let mut series = Vec::new();
        let ti_deg = deg(ti);
        if let Some(curve) = measured {
            series.push(Series {
                label: "measured".into(),
                points: curve
                    .points
                    .iter()
                    .filter(|p| (p.theta_i - ti).abs() < 1e-9)
                    .map(|p| (p.theta_s.to_degrees(), p.value))
                    .collect(),
                style: Style::Points,
                colour: 7,
            });
        }
        for (j, c) in models.curves.iter().enumerate() {
            // Scaled to the measurement where there is one (the comparison's scale).
            let scale = comparisons
                .iter()
                .find(|(l, _)| *l == c.label)
                .and_then(|(_, cs)| cs.iter().find(|x| (x.theta_i - ti).abs() < 1e-9))
                .map(|x| x.scale);
            let value = |r: &RowRec| -> f64 {
                match scale {
                    Some(s) => {
                        s * ModelPoint::from_row(
                            r.brdf,
                            r.relative,
                            r.reflectance,
                            instrument.aperture(),
                        )
                        .in_kind(kind)
                    }
                    None => r.relative,
                }
            };
            let rows: Vec<&RowRec> = c.rows.iter().filter(|r| r.theta_i == ti).collect();
            series.push(Series {
                label: match scale {
                    Some(s) => format!("{} × {s:.3e}", c.label),
                    None => c.label.clone(),
                },
                points: rows
                    .iter()
                    .map(|r| (ts_list[r.detector].to_degrees(), value(r)))
                    .collect(),
                style: if c.label.contains("histogram") {
                    Style::Dashed
                } else {
                    Style::Line
                },
                colour: j,
            });
            let bars: Vec<(f64, f64)> = rows
                .iter()
                .filter_map(|r| {
                    let se = r.std_err?;
                    (se.is_finite() && r.brdf > 0.0 && c.model.starts_with("topographic")).then(
                        || {
                            let y = value(r);
                            let d = y * se / r.brdf;
                            [
                                (ts_list[r.detector].to_degrees(), y - d),
                                (ts_list[r.detector].to_degrees(), y + d),
                            ]
                        },
                    )
                })
                .flatten()
                .collect();
            if !bars.is_empty() {
                series.push(Series {
                    label: String::new(),
                    points: bars,
                    style: Style::ErrorBars,
                    colour: j,
                });
            }
        }
        let path = format!("curves-theta{}.png", ti_deg);
        files.push(OutFile {
            path: path.clone(),
            content: Content::Chart(Chart {
                title: format!(
                    "{}: θi = {ti_deg}°, aperture {:.2}°{}\n{}",
                    input.name,
                    instrument.aperture().to_degrees(),
                    if measured.is_some() {
                        ", models scaled 5°–40° from specular"
                    } else {
                        ""
                    },
                    "topographic curve with ±1 standard error bars from map tiles"
                ),
                x_label: THETA_S_LABEL.into(),
                y_label: if measured.is_some() {
                    format!("{} ({})", "measured quantity", kind.name())
                } else {
                    "relative reflectance (1 at specular)".into()
                },
                log_y: true,
                series,
            }),
        });
        curve_images.push((path, ti_deg, k));
    }
    // Overlays.
    for (k, map) in maps.iter().enumerate() {
        files.push(OutFile {
            path: format!("overlays/{}.png", names[k]),
            content: Content::Overlay(
                Box::new(overlay(
                    map,
                    &stats.segmentations[k],
                    m.stats.overlay_max_deg.to_radians(),
                )),
                names[k].clone(),
            ),
        });
    }
    // Caches.
    for (k, c) in map_caches.iter().enumerate() {
        files.push(text(
            &format!("cache/maps/{}.json", names[k]),
            serde_json::to_string(c).unwrap_or_default() + "\n",
        ));
    }
    files.push(text(
        "cache/models.json",
        serde_json::to_string(models).unwrap_or_default() + "\n",
    ));

    // summary.json
    let flake = &p.flake_level;
    let pixel_failure = failed
        .iter()
        .find(|f| f.statistic == "statistics.pixel_level");
    let statistics = json!({
        "flakes": stats.histogram.flakes(),
        "total_area_um2": stats.histogram.total_area_um2(),
        "hwhm_deg": flake.hwhm().to_degrees(),
        "sigma_deg": flake.sigma.to_degrees(),
        "flake_level": {
            "hwhm_ci95_deg": ci_deg(flake.hwhm_ci95()),
            "method": flake.ci_method.describe(),
            "effective_flakes": flake.effective_n,
        },
        "map_level": p.map_level.map(|ml| json!({
            "hwhm_ci95_deg": ci_deg(ml.hwhm_ci95()),
            "method": ml.describe(),
            "maps": ml.maps,
            "dof": ml.dof,
            "t_quantile": ml.t_quantile,
        })),
        "quoted_interval": if p.map_level.is_some() { "map_level" } else { "flake_level" },
        "heterogeneity": p.heterogeneity.map(|h| json!({"cochran_q": h.q, "dof": h.dof, "p": h.p, "i2": h.i2})),
        "z_bound": p.z_bound,
        "histogram_fit_hwhm_deg": stats.histogram_fit.as_ref().ok().map(|h| h.hwhm().to_degrees()),
        "histogram_fit_error": stats.histogram_fit.as_ref().err(),
        "maps": p.maps.iter().enumerate().map(|(k, w)| json!({
            "map": names[k],
            "flakes": w.flakes,
            "area_um2": w.area_um2,
            "effective_flakes": w.effective_n,
            "hwhm_deg": w.fit.map(|f| f.hwhm().to_degrees()),
            "hwhm_ci95_deg": w.fit.map(|f| ci_deg(f.hwhm_ci95())),
            "z": w.z,
            "flagged": w.flagged,
        })).collect::<Vec<_>>(),
        "pixel_level": stats.pixel.as_ref().map_or_else(|| pixel_failure.map(|f| json!({"error": f.error})), |px| Some(json!({
            "usable_pixels": px.orientation.tilts.usable_pixels,
            "hwhm_deg": px.orientation.width.map(|w| w.hwhm().to_degrees()),
            "hwhm_ci95_deg": px.orientation.width.map(|w| ci_deg(w.hwhm_ci95())),
            "histogram_fit_hwhm_deg": px.orientation.histogram_fit.as_ref().ok().map(|h| h.hwhm().to_degrees()),
            "histogram_fit_error": px.orientation.histogram_fit.as_ref().err(),
            "inside_flakes_hwhm_deg": px.sources.as_ref().ok().map(|w| w.inside.hwhm().to_degrees()),
            "within_flake_sigma_deg": px.sources.as_ref().ok().and_then(|w| w.within_flake_sigma).map(f64::to_degrees),
            "error": px.sources.as_ref().err(),
        }))),
    });
    let comparison_json: Vec<Value> = comparisons
        .iter()
        .flat_map(|(label, cs)| {
            cs.iter().map(move |c| {
                json!({
                    "model": label,
                    "theta_i_deg": deg(c.theta_i),
                    "scale": c.scale,
                    "regions": c.regions.iter().map(|r| json!({
                        "region": r.region.name(),
                        "points": r.points,
                        "points_without_model": r.no_model,
                        "rms_log10": r.rms_log10,
                        "mean_log10": r.mean_log10,
                    })).collect::<Vec<_>>(),
                })
            })
        })
        .collect();
    let fit_json = models.fit.as_ref().map(|f| match f {
        Ok(f) => json!({
            "hwhm_deg": f.hwhm.to_degrees(),
            "hwhm_std_deg": f.hwhm_std.to_degrees(),
            "scales": f.scales.iter().map(|(t, s)| json!({"theta_i_deg": if t.is_finite() { Some(deg(*t)) } else { None }, "scale": s})).collect::<Vec<_>>(),
            "chi2": f.chi2,
            "dof": f.dof,
            "points": f.points,
            "iterations": f.iterations,
            "uncertainty_basis": f.uncertainty_basis,
            "uncertainty_scale": f.uncertainty_scale,
            "warnings": f.warnings,
        }),
        Err(e) => json!({"error": e}),
    });
    let multi_json = models.multi_angle.as_ref().map(|r| match r {
        Ok(r) => json!({
            "theta_i_deg": deg(r.theta_i),
            "readouts": r.readouts.iter().map(|(a, rf, l)| json!({
                "aspecular_deg": deg(*a), "reflectance_factor": rf, "lightness": l,
            })).collect::<Vec<_>>(),
            "flop_index": r.flop_index,
            "note": "distribution model with the pooled width; single-wavelength lightness (multiangle module docs)",
        }),
        Err(e) => json!({"error": e}),
    });
    let file_list: Vec<String> = ["index.md", "index.html", "summary.json"]
        .iter()
        .map(|s| (*s).to_owned())
        .chain(files.iter().map(|f| f.path.clone()))
        .collect();
    let summary = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "build": build,
        "sample": input.name,
        "manifest": input.file.display().to_string(),
        "description": m.description,
        "inputs": {
            "maps": map_info,
            "measured": input.measured.iter().zip(measured_hashes).map(|(f, h)| json!({"file": f.display().to_string(), "sha256": h})).collect::<Vec<_>>(),
            "settings": m,
        },
        "instrument": {
            "theta_i_deg": instrument.theta_i().iter().map(|t| deg(*t)).collect::<Vec<_>>(),
            "detectors": ts_list.len(),
            "aperture_deg": deg(instrument.aperture()),
            "n": coating.n,
            "clearcoat": m.models.clearcoat,
        },
        "statistics": statistics,
        "models": models.curves.iter().map(|c| json!({"model": c.label, "source": c.source, "rows": c.rows.len()})).collect::<Vec<_>>(),
        "model_failures": models.failures.iter().map(|(a, b)| json!({"model": a, "error": b})).collect::<Vec<_>>(),
        "comparison": comparison_json,
        "fit": fit_json,
        "multi_angle": multi_json,
        "paint": paint_summary,
        "work": {
            "maps": work.maps,
            "maps_segmented": work.maps_segmented,
            "maps_reused": work.maps_reused,
            "distribution_runs": work.distribution_runs,
            "topographic_runs": work.topographic_runs,
            "fits": work.fits,
            "multi_angle_runs": work.multi_angle_runs,
            "models_reused": work.models_reused,
            "paint_fits": work.paint_fits,
            "model_work": work.model_work(),
        },
        "failed_statistics": failed.iter().map(FailedStatistic::to_json).collect::<Vec<_>>(),
        "warnings": warnings,
        "files": file_list,
        "units": {
            "hwhm_deg": "degree, half-width at half-maximum of the Gaussian p~ (the paper's w)",
            "hwhm_ci95_deg": "degree, 95 % interval; null for an infinite end",
            "area_um2": "µm², true (visible) flake area",
            "scale": "fitted vertical scale of the model (measured ≈ scale × model 5°–40° from specular)",
            "rms_log10": "root mean square of log10(measured) − log10(scaled model) in the region (0.1 = a factor 1.26)",
            "brdf_per_sr": "1/sr",
            "lightness": "CIE L* of the reflectance factor at one wavelength",
        },
    });
    files.push(text(
        "summary.json",
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
    ));

    // The comparison row.
    let fitted = models
        .fit
        .as_ref()
        .and_then(|f| f.as_ref().ok())
        .map(|f| (f.hwhm.to_degrees(), f.hwhm_std.to_degrees()));
    let near: Vec<(String, f64, Option<f64>)> = comparisons
        .iter()
        .flat_map(|(label, cs)| {
            cs.iter().map(move |c| {
                (
                    label.clone(),
                    deg(c.theta_i),
                    c.regions
                        .iter()
                        .find(|r| r.region.name() == "near-specular")
                        .and_then(|r| r.rms_log10),
                )
            })
        })
        .collect();
    let lightness = models
        .multi_angle
        .as_ref()
        .and_then(|r| r.as_ref().ok())
        .map(|r| {
            let l = |k: usize| r.readouts.get(k).map_or(f64::NAN, |x| x.2);
            (l(1), l(3), l(5), r.flop_index)
        });
    let row = SampleRow {
        name: input.name.clone(),
        maps: names.len(),
        flakes: stats.histogram.flakes(),
        hwhm_deg: p.hwhm().to_degrees(),
        hwhm_ci95_deg: ci_deg(p.map_level.map_or(flake.hwhm_ci95(), |ml| ml.hwhm_ci95())),
        interval: qname.into(),
        fitted_hwhm_deg: fitted,
        near_specular: near,
        lightness,
    };

    // The document.
    let mut d = Document::default();
    d.push(Block::Heading(1, format!("Sample {}", input.name)));
    d.push(Block::Para(format!(
        "Manifest `{}`, {} map(s), flakescatter {}. {}",
        input.file.display(),
        names.len(),
        env!("CARGO_PKG_VERSION"),
        m.description.clone().unwrap_or_default()
    )));
    d.push(Block::Heading(2, "Orientation statistics".into()));
    d.push(Block::Para(format!(
        "{} flakes over {} map(s). Pooled Gaussian width (maximum likelihood, area-weighted): hwhm **{:.3}°**. \
         95 % intervals: flake level {} (flakes as independent draws, profile likelihood); map level {} \
         (maps as the independent units, Student's t on maps − 1 degrees of freedom). The interval to quote is the {}.",
        stats.histogram.flakes(),
        names.len(),
        flake.hwhm().to_degrees(),
        fmt_ci(ci_deg(flake.hwhm_ci95())),
        p.map_level.map_or_else(|| "— (one map)".to_owned(), |ml| fmt_ci(ci_deg(ml.hwhm_ci95()))),
        qname
    )));
    if let Some(h) = p.heterogeneity {
        d.push(Block::Para(format!(
            "Do the maps agree? Cochran's Q = {:.2} on {} degrees of freedom (p = {:.3}), I² = {:.0} %. \
             A map is flagged when its width is inconsistent with the other maps' pool (|z| > {:.2}, Bonferroni over the maps).",
            h.q,
            h.dof,
            h.p,
            100.0 * h.i2,
            p.z_bound.unwrap_or(f64::NAN)
        )));
    }
    d.push(Block::Table(
        vec![
            "map".into(),
            "flakes".into(),
            "hwhm (°)".into(),
            "95 % interval (°)".into(),
            "z".into(),
            "flagged".into(),
        ],
        p.maps
            .iter()
            .enumerate()
            .map(|(k, w)| {
                vec![
                    names[k].clone(),
                    w.flakes.to_string(),
                    w.fit
                        .map_or_else(String::new, |f| format!("{:.3}", f.hwhm().to_degrees())),
                    w.fit
                        .map_or_else(String::new, |f| fmt_ci(ci_deg(f.hwhm_ci95()))),
                    w.z.map_or_else(String::new, |z| format!("{z:+.2}")),
                    if w.flagged {
                        "**yes**".into()
                    } else {
                        "no".into()
                    },
                ]
            })
            .collect(),
    ));
    if let Some(px) = &stats.pixel {
        let w = px.sources.as_ref().ok();
        d.push(Block::Para(format!(
            "Where the width comes from: flake level hwhm {:.3}°; pixel level (local {}×{} normals of all usable pixels) {}; \
             pixels inside single flakes {}; within-flake roughness as a tilt spread per component {}.",
            flake.hwhm().to_degrees(),
            m.models.window,
            m.models.window,
            px.orientation.width.map_or_else(
                || "none (windows across flake edges, tilted near 90°, dominate the mean square tilt)".into(),
                |w| format!("{:.3}°", w.hwhm().to_degrees())
            ),
            w.map_or_else(|| "—".into(), |w| format!("{:.3}°", w.inside.hwhm().to_degrees())),
            w.and_then(|w| w.within_flake_sigma)
                .map_or_else(|| "—".into(), |s| format!("{:.3}°", s.to_degrees()))
        )));
    }
    if !failed.is_empty() {
        d.push(Block::Para(
            "Statistics that failed (the rest of the report stands without them):".into(),
        ));
        d.push(Block::List(
            failed
                .iter()
                .map(|f| format!("`{}` (manifest key `{}`): {}", f.statistic, f.key, f.error))
                .collect(),
        ));
    }
    d.push(Block::Image(
        "histogram.png".into(),
        format!(
            "Area-weighted histogram of p̃ with the fitted Gaussian and its 95 % band ({qname})."
        ),
    ));
    d.push(Block::Heading(2, "Models against the measurement".into()));
    d.push(Block::Para(format!(
        "Models: {}. Detectors: in-plane cones of half-angle {:.2}°; clear coat n = {}{}. {}",
        models
            .curves
            .iter()
            .map(|c| c.label.clone())
            .collect::<Vec<_>>()
            .join(", "),
        instrument.aperture().to_degrees(),
        coating.n,
        if m.models.clearcoat { " with its own reflection" } else { "" },
        match measured {
            Some(c) => format!(
                "Measured curve: {} ({} points, `{}`); each model is scaled to it 5°–40° from specular.",
                c.file,
                c.points.len(),
                kind_name(m)
            ),
            None => "No measured curve: the plots show each model relative to its specular value.".into(),
        }
    )));
    if !comparisons.is_empty() {
        d.push(Block::Table(
            vec![
                "model".into(),
                "θi (°)".into(),
                "scale".into(),
                "rms specular".into(),
                "rms near-specular".into(),
                "rms far".into(),
            ],
            comparisons
                .iter()
                .flat_map(|(label, cs)| {
                    cs.iter().map(move |c| {
                        let r = |name: &str| {
                            c.regions
                                .iter()
                                .find(|r| r.region.name() == name)
                                .and_then(|r| r.rms_log10)
                                .map_or_else(|| "—".into(), |v| format!("{v:.3}"))
                        };
                        vec![
                            label.clone(),
                            format!("{}", deg(c.theta_i)),
                            format!("{:.4e}", c.scale),
                            r("specular"),
                            r("near-specular"),
                            r("far"),
                        ]
                    })
                })
                .collect(),
        ));
        d.push(Block::Para(
            "rms = root mean square of log10(measured) − log10(scale × model) per region (specular: within 5° of specular; near: 5°–40°; far: beyond 40°); 0.1 is a factor 1.26.".into(),
        ));
    }
    for (path, ti_deg, _) in &curve_images {
        d.push(Block::Image(
            path.clone(),
            format!(
                "θi = {ti_deg}°: {}model curves; topographic curve with ±1 standard error bars.",
                if measured.is_some() {
                    "measured points and "
                } else {
                    ""
                }
            ),
        ));
    }
    if let Some(f) = &models.fit {
        d.push(Block::Heading(
            2,
            "Width fitted to the measured curve".into(),
        ));
        d.push(Block::Para(match f {
            Ok(f) => format!(
                "hwhm {:.3}° ± {:.3}° (one standard uncertainty, {}), χ² = {:.3} on {} degrees of freedom, {} points 5°–40° from specular. \
                 The flakes themselves have hwhm {:.3}°: a wider fitted width is the roughness of the flakes acting as extra tilt (the paper's conclusion).{}",
                f.hwhm.to_degrees(),
                f.hwhm_std.to_degrees(),
                f.uncertainty_basis,
                f.chi2,
                f.dof,
                f.points,
                flake.hwhm().to_degrees(),
                if f.warnings.is_empty() { String::new() } else { format!(" Warnings: {}.", f.warnings.join("; ")) }
            ),
            Err(e) => format!("The fit failed: {e}"),
        }));
    }
    if let Some(Ok(r)) = &models.multi_angle {
        d.push(Block::Heading(2, "Multi-angle readout".into()));
        d.push(Block::Table(
            vec![
                "aspecular (°)".into(),
                "reflectance factor".into(),
                "L*".into(),
            ],
            r.readouts
                .iter()
                .map(|(a, rf, l)| {
                    vec![
                        format!("{}", deg(*a)),
                        format!("{rf:.4e}"),
                        format!("{l:.2}"),
                    ]
                })
                .collect(),
        ));
        d.push(Block::Para(format!(
            "At θi = {}° with the pooled width (distribution model); flop index {}. Single-wavelength lightness: the reflectance factor stands in for the luminance factor.",
            deg(r.theta_i),
            r.flop_index.map_or_else(|| "—".into(), |f| format!("{f:.2}"))
        )));
    }
    d.push(Block::Heading(2, "Segmentation overlays".into()));
    d.push(Block::Para(
        "Each map in grey, each flake filled with the colour of its tilt θn (colour bar in degrees) and outlined in black, \
         flake numbers (the `flake` column of `flakes.csv`) on large flakes, valid pixels in no flake hatched orange, \
         pixels without data or below the intensity cutoff dark."
            .into(),
    ));
    for n in names {
        d.push(Block::Image(
            format!("overlays/{n}.png"),
            format!("map {n}"),
        ));
    }
    for b in paint_blocks {
        d.push(b);
    }
    if !warnings.is_empty() {
        d.push(Block::Heading(2, "Warnings".into()));
        d.push(Block::List(warnings.clone()));
    }
    d.push(Block::Heading(2, "Files".into()));
    d.push(Block::List(vec![
        "`summary.json`: every number with its uncertainty, the inputs with their SHA-256, the work counter (`work`)".into(),
        "`maps.csv`: per map its flakes, width, interval, z and flag".into(),
        "`flakes.csv`: every flake (map, flake number, centre µm, normal, area µm², θn, φn, ...)".into(),
        "`histogram.csv`: the pooled area-weighted histogram (readable by `model --orientation table`)".into(),
        "`curves.csv`: every model curve (brdf_per_sr with std_err_per_sr, reflectance, relative, rays)".into(),
        "`comparison.csv`: per model, incidence and region the fitted scale and log10 residuals".into(),
        "`histogram.png`, `curves-theta*.png`, `overlays/*.png`: the plots and overlays shown here".into(),
        "`paint/` (with `[paint]`): the fitted paint's parameter file `params.json` (read by `model --params`), the per-point table `points.csv` and its plots".into(),
        "`cache/`: what a rerun reuses (segmentations, model results and the paint fit, with the keys of their inputs)".into(),
    ]));
    d.push(Block::Para(format!(
        "Work done in this run: {} map(s) segmented, {} reused; {} distribution, {} topographic, {} fit, {} multi-angle run(s){}.",
        work.maps_segmented,
        work.maps_reused,
        work.distribution_runs,
        work.topographic_runs,
        work.fits,
        work.multi_angle_runs,
        if work.models_reused { "; model results reused from the cache" } else { "" }
    )));

    SampleReport {
        name: input.name.clone(),
        files,
        document: d,
        summary,
        work,
        warnings,
        row,
    }
}

fn kind_name(m: &Manifest) -> String {
    m.measured
        .as_ref()
        .map_or_else(|| "brdf".into(), |s| s.kind.clone())
}

/// The comparison across samples: `samples.csv` and a document (`index.md`,
/// `index.html` of the batch directory) with one line per sample.
#[must_use]
pub fn comparison_report(rows: &[SampleRow]) -> (String, Document) {
    let models: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for r in rows {
            for (m, t, _) in &r.near_specular {
                let k = format!("{m} θi {t}");
                if !v.contains(&k) {
                    v.push(k);
                }
            }
        }
        v
    };
    let mut csv = String::from(
        "sample,maps,flakes,hwhm_deg,hwhm_ci95_lo_deg,hwhm_ci95_hi_deg,interval,fitted_hwhm_deg,fitted_hwhm_std_deg,l15,l45,l110,flop_index",
    );
    for m in &models {
        let _ = write!(csv, ",rms_near_specular[{m}]");
    }
    csv.push('\n');
    let o = |x: Option<f64>| x.map(num).unwrap_or_default();
    let mut table = Vec::new();
    for r in rows {
        let l = r.lightness;
        let _ = write!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.name,
            r.maps,
            r.flakes,
            num(r.hwhm_deg),
            o(r.hwhm_ci95_deg.0),
            o(r.hwhm_ci95_deg.1),
            r.interval,
            o(r.fitted_hwhm_deg.map(|f| f.0)),
            o(r.fitted_hwhm_deg.map(|f| f.1)),
            o(l.map(|l| l.0)),
            o(l.map(|l| l.1)),
            o(l.map(|l| l.2)),
            o(l.and_then(|l| l.3)),
        );
        let mut near_cells = Vec::new();
        for m in &models {
            let v = r
                .near_specular
                .iter()
                .find(|(a, t, _)| format!("{a} θi {t}") == *m)
                .and_then(|x| x.2);
            let _ = write!(csv, ",{}", o(v));
            near_cells.push(v.map_or_else(|| "—".into(), |v| format!("{v:.3}")));
        }
        csv.push('\n');
        let mut cells = vec![
            format!("[{0}]({0}/index.md)", r.name),
            r.maps.to_string(),
            r.flakes.to_string(),
            format!("{:.3}", r.hwhm_deg),
            format!("{} ({})", fmt_ci(r.hwhm_ci95_deg), r.interval),
            r.fitted_hwhm_deg
                .map_or_else(|| "—".into(), |f| format!("{:.3} ± {:.3}", f.0, f.1)),
            l.map_or_else(
                || "—".into(),
                |l| format!("{:.1} / {:.1} / {:.1}", l.0, l.1, l.2),
            ),
        ];
        cells.extend(near_cells);
        table.push(cells);
    }
    let mut d = Document::default();
    d.push(Block::Heading(
        1,
        format!("{} samples compared", rows.len()),
    ));
    d.push(Block::Para(
        "Per sample: the pooled flake width with its quoted 95 % interval (map level when the sample has two or more maps), \
         the width fitted to its measured curve, the multi-angle lightness L* at 15°/45°/110° aspecular (distribution model with the pooled width) \
         and the near-specular rms log10 residual of each model. Each sample's own report is linked; `samples.csv` holds the same numbers."
            .into(),
    ));
    let mut header = vec![
        "sample".into(),
        "maps".into(),
        "flakes".into(),
        "hwhm (°)".into(),
        "95 % interval (°)".into(),
        "fitted hwhm (°)".into(),
        "L* 15/45/110".into(),
    ];
    header.extend(models.iter().map(|m| format!("rms near-specular, {m}")));
    d.push(Block::Table(header, table));
    (csv, d)
}

/// A manifest's default sample name: its file name without `.toml`, made safe.
#[must_use]
pub fn default_name(file: &Path) -> String {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let s: String = stem
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with('.') {
        format!("sample{s}")
    } else {
        s
    }
}
