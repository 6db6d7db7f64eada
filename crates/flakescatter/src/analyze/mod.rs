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
//!
//! The rooms: [`manifest`] (the manifest and its checks), `settings` (what the manifest
//! sets), `plan` (the steps of an analysis), `cache` (what a rerun reuses), `models`
//! (the model runs), `report` (one file per report section), `samples` (the comparison
//! across samples), `paint` (the `[paint]` part) and `optional` (statistics whose
//! failure is reported rather than fatal), `preview` (the model a rendered preview
//! shows).

mod cache;
pub mod document;
mod format;
mod keys;
pub mod manifest;
mod models;
mod optional;
mod paint;
mod plan;
mod preview;
mod report;
mod samples;
mod settings;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::PipelineError;
use crate::chart::Chart;
use crate::inputs::MapSource;
use crate::overlay::Overlay;
pub use cache::{Cache, read_cache};
use document::Document;
pub use manifest::{Manifest, ManifestError, TopoKind};
pub use optional::FailedStatistic;
pub use plan::analyze_sample;
pub use preview::PreviewModel;
pub use samples::{SampleRow, comparison_report};
pub use settings::load_options;

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
    /// The environment variable `FLAKESCATTER_SIMD` holds a value other than unset,
    /// `auto` or `portable`: refused before any work, as the model commands refuse it,
    /// rather than reporting every model as failed.
    #[error(transparent)]
    SimdSwitch(#[from] flakescatter_numerics::simd::SimdSwitchError),
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
    /// What a rendered preview of the sample shows (`None` when the pooled width gives
    /// no distribution and there is no fitted paint).
    pub preview: Option<PreviewModel>,
}

fn input_err(e: impl std::fmt::Display) -> AnalyzeError {
    AnalyzeError::Input(e.to_string())
}

fn stage(stage: &'static str) -> impl Fn(PipelineError) -> AnalyzeError {
    move |source| AnalyzeError::Pipeline { stage, source }
}

/// Refuses sample names that cannot each have their own folder in a batch's directory
/// (`names`: each sample's name and its manifest): two equal names, two names equal but
/// for case (one folder on case-insensitive file systems, macOS and Windows), and names
/// of the batch's own files `reserved` (in any case). Called before any work.
///
/// # Errors
/// A message naming the manifests and names at fault.
pub fn check_sample_names(names: &[(&str, &Path)], reserved: &[&str]) -> Result<(), String> {
    for (k, (name, file)) in names.iter().enumerate() {
        let lower = name.to_lowercase();
        if let Some(own) = reserved.iter().find(|f| f.to_lowercase() == lower) {
            return Err(format!(
                "sample {} is named `{name}`, the name of the batch's own file `{own}` in its folder: give it another `name`",
                file.display()
            ));
        }
        if let Some((other, ofile)) = names[..k].iter().find(|(o, _)| o.to_lowercase() == lower) {
            return Err(if other == name {
                format!(
                    "samples {} and {} are both named `{name}`: give one of them another `name`",
                    ofile.display(),
                    file.display(),
                )
            } else {
                format!(
                    "samples {} and {} are named `{other}` and `{name}`, one folder on file systems that ignore case (macOS, Windows): give one of them another `name`",
                    ofile.display(),
                    file.display(),
                )
            });
        }
    }
    Ok(())
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
