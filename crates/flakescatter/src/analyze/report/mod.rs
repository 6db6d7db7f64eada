//! A sample's report (module docs of [`super`]), one section a room: the tables, the
//! pictures, the caches, `summary.json`, the sample's comparison line and the document.
//! Nothing here computes physics; every number comes from the analysis.

mod charts;
mod index;
mod summary;
mod tables;

use flakescatter_io::measured::MeasuredCurve;
use flakescatter_stats::heightmap::HeightMap;
use serde_json::Value;

use super::cache::{self, MapCache, ModelCache};
use super::paint::PaintOutcome;
use super::{Content, FailedStatistic, OutFile, SampleInput, SampleReport, Work, samples};
use crate::compare::IncidenceComparison;
use crate::instrument::Instrument;
use crate::pipeline::Coating;
use crate::sample::SampleStatistics;

/// What an analysis found, as the report's sections read it.
pub(super) struct Analysis<'a> {
    /// The sample.
    pub(super) input: &'a SampleInput,
    /// The instrument of the models.
    pub(super) instrument: &'a Instrument,
    /// The coating.
    pub(super) coating: &'a Coating,
    /// The pooled statistics.
    pub(super) stats: &'a SampleStatistics,
    /// The maps, in order.
    pub(super) maps: &'a [&'a HeightMap],
    /// The model results.
    pub(super) models: &'a ModelCache,
    /// The measured curve, if any.
    pub(super) measured: Option<&'a MeasuredCurve>,
    /// Each model compared with the measured curve: `(model, per incidence)`.
    pub(super) comparisons: &'a [(String, Vec<IncidenceComparison>)],
    /// The SHA-256 of each measured file.
    pub(super) measured_hashes: &'a [String],
    /// Each map's segmentation as the cache keeps it.
    pub(super) map_caches: &'a [MapCache],
    /// The optional statistics that failed.
    pub(super) failed: &'a [FailedStatistic],
    /// The program build's identity.
    pub(super) build: &'a str,
}

/// The report of an analysis: its files in order (the paint part's, the tables, the
/// pictures, the caches, `summary.json`), its document and its comparison line.
pub(super) fn build_report(
    a: &Analysis,
    work: Work,
    warnings: Vec<String>,
    map_info: Vec<Value>,
    paint: Option<PaintOutcome>,
) -> SampleReport {
    let input = a.input;
    let p = &a.stats.pooled;
    let mut files: Vec<OutFile> = Vec::new();
    let mut warnings = warnings;
    let (paint_blocks, paint_summary, fitted_paint) = match paint {
        Some(o) => {
            files.extend(o.files);
            warnings.extend(o.warnings);
            (o.blocks, o.summary, Some(o.params))
        }
        None => (Vec::new(), Value::Null, None),
    };
    let preview = match fitted_paint {
        Some(p) => Some(super::PreviewModel::Paint(Box::new(p))),
        None => p
            .flake_level
            .orientation()
            .ok()
            .map(|orientation| super::PreviewModel::Flakes {
                orientation,
                coating: a.coating.clone(),
                settings: crate::Settings::default(),
            }),
    };
    files.extend(tables::tables(a));
    // The quoted interval: map level where there is one.
    let (qci, qname) = match p.map_level {
        Some(ml) => (ml.sigma_ci95, "map level"),
        None => (p.flake_level.sigma_ci95, "flake level"),
    };
    files.push(charts::histogram(a, qci, qname));
    let (curve_files, curve_images) = charts::curves(a);
    files.extend(curve_files);
    files.extend(charts::overlays(a));
    files.extend(cache::files(&input.map_names, a.map_caches, a.models));
    let row = samples::row(
        &input.name,
        input.map_names.len(),
        a.stats,
        a.models,
        a.comparisons,
        qname,
    );
    let mut summary = summary::summary(a, work, &warnings, map_info, paint_summary, &files);
    // The sample's line of a comparison across samples (`samples.csv`), for a batch
    // assembled from reports made apart (Python `flakescatter.dask.analyze_many`).
    summary["comparison_row"] = serde_json::to_value(&row).unwrap_or(Value::Null);
    // Keys sorted at every level, whatever serde_json's `preserve_order` (turned on by
    // zarrs) would keep.
    summary.sort_all_objects();
    files.push(OutFile {
        path: "summary.json".into(),
        content: Content::Text(serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n"),
    });
    let document = index::document(a, qname, &curve_images, paint_blocks, &warnings, work);
    SampleReport {
        name: input.name.clone(),
        files,
        document,
        summary,
        work,
        warnings,
        row,
        preview,
    }
}
