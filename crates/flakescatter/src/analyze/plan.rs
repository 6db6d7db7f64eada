//! The plan of an analysis (module docs of [`super`]): read and key the inputs, segment
//! each map (or take its segmentation from the cache), pool the statistics, run the
//! models (or take them from the cache), compare them with the measured curve, fit the
//! paint, and hand everything to the report.

use std::path::PathBuf;

use flakescatter_io::files::{sha256_bytes, sha256_file};
use flakescatter_io::measured::{MeasuredCurve, read_measured};
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::segment::{SegmentParams, Segmentation};
use serde_json::{Value, json};

use super::cache::{Cache, MapCache, ModelCache};
use super::models::run_models;
use super::report::{Analysis, build_report};
use super::settings::{
    coating_of, in_plane_angles, instrument_of, load_options, measured_kind, segment_params,
};
use super::{
    AnalyzeError, FailedStatistic, SampleInput, SampleReport, Work, input_err, optional, paint,
    stage,
};
use crate::compare::{IncidenceComparison, ModelPoint, compare, tabulated_points};
use crate::inputs::{LoadOptions, load_map};
use crate::instrument::Instrument;
use crate::sample::{SampleSettings, SampleStatistics, segment_maps, statistics_of};

/// Analyses one sample (module docs); `cache` is what [`read_cache`](super::read_cache) found in its
/// report directory; `build` identifies the program build (any text that changes
/// whenever the code, its dependencies, the compiler or the profile do: it enters
/// every cache key); `progress(stage, done, total)` is told what is being done.
///
/// # Errors
/// [`AnalyzeError::Input`] for an input that cannot be read (naming it),
/// [`AnalyzeError::Pipeline`] for a statistics step that fails (no flake in any map),
/// [`AnalyzeError::SimdSwitch`] for a bad `FLAKESCATTER_SIMD` (checked first).
/// A model that fails is reported in the summary and the others still run.
pub fn analyze_sample(
    input: &SampleInput,
    cache: &Cache,
    build: &str,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<SampleReport, AnalyzeError> {
    flakescatter_numerics::simd::Kernels::from_env()?;
    let m = &input.manifest;
    let file = input.file.display().to_string();
    let options = load_options(m).map_err(|e| AnalyzeError::Input(format!("{file}: {e}")))?;
    let coating = coating_of(m).map_err(|e| AnalyzeError::Input(format!("{file}: {e}")))?;
    let params = segment_params(m);
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

    let inputs = read_inputs(input, &options, build, progress)?;
    let refs: Vec<&HeightMap> = inputs.maps.iter().collect();
    let measured = read_measured_files(&input.measured)?;
    let measured_hashes: Vec<String> = input
        .measured
        .iter()
        .map(sha256_file)
        .collect::<Result<_, _>>()
        .map_err(input_err)?;
    let (segs, map_caches) = segment(
        input,
        cache,
        &refs,
        &inputs.keys,
        &params,
        &mut work,
        &mut warnings,
        progress,
    )?;
    let (stats, failed) = statistics(input, &refs, segs, params, &mut warnings, progress)?;

    // Models, from the cache where the key matches.
    let instrument = instrument_of(m, measured.as_ref())?;
    let models_key = hash_json(&json!({
        "version": env!("CARGO_PKG_VERSION"),
        "build": build,
        "maps": inputs.keys,
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

    let comparisons = comparisons(
        input,
        &instrument,
        &models,
        measured.as_ref(),
        &mut warnings,
    );
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
    let analysis = Analysis {
        input,
        instrument: &instrument,
        coating: &coating,
        stats: &stats,
        maps: &refs,
        models: &models,
        measured: measured.as_ref(),
        comparisons: &comparisons,
        measured_hashes: &measured_hashes,
        map_caches: &map_caches,
        failed: &failed,
        build,
    };
    Ok(build_report(
        &analysis,
        work,
        warnings,
        inputs.map_info,
        paint,
    ))
}

/// The maps of a sample, read, with their cache keys and their lines of
/// `summary.json`'s `inputs.maps`.
struct Inputs {
    maps: Vec<HeightMap>,
    keys: Vec<String>,
    map_info: Vec<Value>,
}

/// Reads every map, hashing its files into its cache key (module docs).
fn read_inputs(
    input: &SampleInput,
    options: &LoadOptions,
    build: &str,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Inputs, AnalyzeError> {
    let m = &input.manifest;
    let version = env!("CARGO_PKG_VERSION");
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
        let loaded = load_map(src, options, &|_, _| {}).map_err(input_err)?;
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
    Ok(Inputs {
        maps,
        keys,
        map_info,
    })
}

/// Segments every map, or takes its segmentation from the cache where the key
/// matches; returns the segmentations and what the cache is to keep of them.
#[allow(clippy::too_many_arguments)]
fn segment(
    input: &SampleInput,
    cache: &Cache,
    refs: &[&HeightMap],
    keys: &[String],
    params: &SegmentParams,
    work: &mut Work,
    warnings: &mut Vec<String>,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<(Vec<Segmentation>, Vec<MapCache>), AnalyzeError> {
    let mut segs = Vec::with_capacity(refs.len());
    let mut map_caches = Vec::with_capacity(refs.len());
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
                progress("segmenting maps", k, refs.len());
                work.maps_segmented += 1;
                segment_maps(&[map], params, &|_, _| {})
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
    Ok((segs, map_caches))
}

/// The pooled statistics of the segmentations, and the optional statistics that
/// failed (optional module docs).
fn statistics(
    input: &SampleInput,
    refs: &[&HeightMap],
    segs: Vec<Segmentation>,
    params: SegmentParams,
    warnings: &mut Vec<String>,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<(SampleStatistics, Vec<FailedStatistic>), AnalyzeError> {
    let m = &input.manifest;
    let file = input.file.display().to_string();
    progress("pooled statistics", 0, 1);
    optional::require_flakes(m, refs, &input.map_names, &segs)
        .map_err(|e| AnalyzeError::Input(format!("{file}: {e}")))?;
    // The pixel-level statistics are optional: computed apart, so that their failure
    // is reported rather than fatal (optional module docs).
    let sample_settings = SampleSettings {
        segment: params,
        bin_width: m.stats.bin_deg.to_radians(),
        pixel_normals: None,
    };
    let mut stats = statistics_of(refs, segs, &sample_settings).map_err(stage("statistics"))?;
    warnings.extend(stats.pooled.warnings.iter().map(ToString::to_string));
    let failed = optional::optional_statistics(m, refs, &input.map_names, &mut stats);
    warnings.extend(failed.iter().map(FailedStatistic::warning));

    Ok((stats, failed))
}

/// Each model's curve compared with the measured curve by region, at the measured
/// points the model has angles for.
fn comparisons(
    input: &SampleInput,
    instrument: &Instrument,
    models: &ModelCache,
    measured: Option<&MeasuredCurve>,
    warnings: &mut Vec<String>,
) -> Vec<(String, Vec<IncidenceComparison>)> {
    let m = &input.manifest;
    let kind = measured_kind(m);
    let aperture = instrument.aperture();
    let ts_list = in_plane_angles(instrument);
    let mut comparisons: Vec<(String, Vec<IncidenceComparison>)> = Vec::new();
    if let Some(curve) = measured {
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
    comparisons
}

pub(super) fn hash_json(v: &Value) -> String {
    sha256_bytes(v.to_string().as_bytes())
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
