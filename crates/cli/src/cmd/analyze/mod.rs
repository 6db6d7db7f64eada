//! `flakescatter analyze SAMPLE.toml [...] --out DIR`: one command per sample (or a
//! batch of samples) from its manifest to a report directory, composed by
//! [`flakescatter::analyze`]. This command resolves the manifests' file lists (the
//! rules of `segment`'s MAP arguments, relative to each manifest's directory), draws
//! charts and overlays as PNG, writes `index.md` and a self-contained `index.html`, and
//! shows progress.
//!
//! Layout: one manifest writes its report into DIR; several (or a directory of
//! manifests) write each sample into `DIR/<name>/` and a comparison across samples
//! (`samples.csv`, `index.md`, `index.html`) into DIR ([`batch`]).
//!
//! A report directory is owned (`output::owned`): it is built whole beside its place
//! and swapped in when complete, so it holds exactly one run's files and a run that
//! fails leaves the previous report as it was. Only a missing or empty directory or an
//! earlier report holding nothing else is replaced; a directory holding the run's
//! inputs, or other files, is refused before any work. The previous report's `cache/`
//! is read before the new one is built, so a rerun still reuses its work. Each
//! sample's directory of a batch is swapped in when that sample is complete, so an
//! interrupted batch keeps the samples it finished and a rerun reuses their work.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use base64::Engine as _;
use flakescatter::analyze::document::Block;
use flakescatter::analyze::{
    Content, Manifest, SampleInput, analyze_sample, comparison_report, default_name, read_cache,
};
use flakescatter::inputs::short_names;
use flakescatter::io::files::read_text;
use serde_json::json;

use crate::maps::{Pairing, Repeats, check_duplicates, dangling, expand, pair};
use crate::output::{Dest, Plan, note, print_json, warn};

mod batch;
mod preview;

/// Analyses samples from their manifests: segmentation of every map, pooled statistics
/// with flake-level and map-level intervals, the distribution model (pooled width and
/// histogram), the topographic model, comparison with the measured curve, the width
/// fitted to it, the multi-angle readout; writes index.md, index.html (images inline),
/// summary.json, CSV tables, plots and overlays. Reruns reuse what has not changed.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Sample manifests (TOML, docs/guide.md "One sample, one command"), or directories
    /// holding them (`*.toml`).
    #[arg(value_name = "SAMPLE.toml", required = true)]
    pub manifests: Vec<PathBuf>,
    /// Report directory: created, or replaced whole when the run succeeds if it is empty
    /// or an earlier report (a run that fails leaves it as it was); a directory holding
    /// the run's inputs or other files is refused.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Print a JSON summary on stdout: per sample its directory, pooled width, warnings
    /// and the work counter.
    #[arg(long)]
    pub json: bool,
    /// No rendered preview. By default each report shows its paint (the fitted
    /// `[paint]`, else the flakes of the pooled width) as a sphere rendered by the Python
    /// package's flakescatter.mitsuba when `$FLAKESCATTER_PYTHON` (default python3) has
    /// it and Mitsuba (`pip install flakescatter[render]`), and says so when it has not.
    #[arg(long)]
    pub no_preview: bool,
}

/// The manifest files of the arguments: files as given, directories' `*.toml` files in
/// name order.
fn manifest_files(items: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in items {
        if p.is_dir() {
            let mut v: Vec<PathBuf> = Vec::new();
            for f in flakescatter::io::files::list_dir(p)
                .with_context(|| format!("SAMPLE {}: cannot list the directory", p.display()))?
            {
                if f.extension().is_none_or(|e| e != "toml") {
                    continue;
                }
                if let Some(why) = dangling(&f) {
                    bail!("SAMPLE {}: {why}", p.display());
                }
                if f.is_file() {
                    v.push(f);
                }
            }
            v.sort();
            if v.is_empty() {
                bail!(
                    "SAMPLE {}: the directory holds no .toml manifest",
                    p.display()
                );
            }
            out.extend(v);
        } else if p.is_file() {
            out.push(p.clone());
        } else if let Some(why) = dangling(p) {
            bail!("SAMPLE: {why}");
        } else {
            bail!("SAMPLE {}: no such file or directory", p.display());
        }
    }
    Ok(out)
}

/// Parses and resolves one manifest (every file must exist), before any work.
fn resolve(file: &Path) -> anyhow::Result<SampleInput> {
    let shown = file.display().to_string();
    let text = read_text(file)?;
    let manifest = Manifest::from_toml(&text, &shown)?;
    let base = file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let m = &manifest.maps;
    let pairing = match (&m.intensity_suffix, m.intensity.is_empty()) {
        (Some(s), _) => Pairing::Suffix {
            height: m.height_suffix.clone(),
            intensity: s.clone(),
        },
        (None, false) => Pairing::Explicit(
            m.intensity
                .iter()
                .map(|p| {
                    if p.is_relative() {
                        base.join(p)
                    } else {
                        p.clone()
                    }
                })
                .collect(),
        ),
        (None, true) => Pairing::None,
    };
    let flag = format!("{shown}: key `maps.files`");
    let repeats = if m.allow_duplicates {
        Repeats::Warn
    } else {
        Repeats::Refuse
    };
    let files = expand(&flag, &m.files, Some(base), &pairing, repeats)?;
    let (channel, intensity_channel) = m.channels().map_err(|e| anyhow::anyhow!("{shown}: {e}"))?;
    let maps: Vec<_> = pair(&files, &pairing)
        .with_context(|| format!("{shown}: key `maps`"))?
        .into_iter()
        .map(|s| s.with_channels(channel.clone(), intensity_channel.clone()))
        .collect();
    if !m.allow_duplicates {
        // Up front, before any sample's work (the report's warnings say when allowed).
        check_duplicates(&flag, &maps, repeats, "set `maps.allow_duplicates = true`")?;
    }
    if m.cutoff.is_some()
        && let Some(s) = maps.iter().find(|s| {
            s.intensity.is_none()
                && s.intensity_channel.is_none()
                && s.kind == flakescatter::inputs::SourceKind::Map
        })
    {
        bail!(
            "{shown}: key `maps.cutoff` needs an intensity map for {} (`maps.intensity`, `maps.intensity_suffix` or `maps.intensity_channel`)",
            s.height.display()
        );
    }
    let measured: Vec<PathBuf> = manifest
        .measured
        .as_ref()
        .map(|ms| {
            ms.files
                .iter()
                .map(|p| {
                    if p.is_relative() {
                        base.join(p)
                    } else {
                        p.clone()
                    }
                })
                .collect()
        })
        .unwrap_or_default();
    for f in &measured {
        if !f.is_file() {
            bail!(
                "{shown}: key `measured.files`: {} does not exist",
                f.display()
            );
        }
    }
    let paint = match &manifest.paint {
        Some(ps) => {
            let p = if ps.file.is_relative() {
                base.join(&ps.file)
            } else {
                ps.file.clone()
            };
            if !p.is_file() {
                bail!("{shown}: key `paint.file`: {} does not exist", p.display());
            }
            Some(p)
        }
        None => None,
    };
    let name = manifest.name.clone().unwrap_or_else(|| default_name(file));
    let map_names = short_names(&maps);
    Ok(SampleInput {
        manifest,
        file: file.to_path_buf(),
        name,
        maps,
        map_names,
        measured,
        paint,
    })
}

fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// The owner recorded in a sample report's marker (`output::owned`).
pub const OWNER: &str = "analyze";

/// The files of a sample's report: `report.files` drawn, `index.md` and `index.html`.
fn render(
    s: &SampleInput,
    report: &flakescatter::analyze::SampleReport,
    dir: &Path,
    shown: Shown,
) -> anyhow::Result<Vec<(PathBuf, Vec<u8>)>> {
    let mut out: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let mut images: Vec<(String, Vec<u8>)> = Vec::new();
    let mut document = report.document.clone();
    document.blocks.extend(shown.blocks);
    // The summary lists the preview's files too, and says what the picture shows.
    let mut summary = report.summary.clone();
    summary["preview"] = shown.summary;
    if let Some(list) = summary["files"].as_array_mut() {
        list.extend(shown.files.iter().map(|(p, _)| json!(p)));
    }
    // Keys sorted, as every JSON output (serde_json keeps insertion order here).
    summary.sort_all_objects();
    for (path, bytes) in shown.files {
        if path.ends_with(".png") {
            images.push((path.clone(), bytes.clone()));
        }
        out.push((PathBuf::from(path), bytes));
    }
    for f in &report.files {
        let target = dir.join(&f.path).display().to_string();
        let bytes = match &f.content {
            Content::Text(_) if f.path == "summary.json" => {
                (serde_json::to_string_pretty(&summary)? + "\n").into_bytes()
            }
            Content::Text(t) => t.clone().into_bytes(),
            Content::Chart(c) => crate::plot::png(c, &target)?,
            Content::Overlay(o, title) => crate::picture::overlay_png(o, title, &target)?,
            Content::ResidualMaps(maps, table) => {
                crate::plot::residual_maps_png(maps, table, &target)?
            }
        };
        if f.path.ends_with(".png") {
            images.push((f.path.clone(), bytes.clone()));
        }
        out.push((PathBuf::from(&f.path), bytes));
    }
    let md = document.to_markdown();
    let html = document.to_html(&format!("Sample {}", s.name), &|name| {
        images
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| data_uri(b))
    });
    out.push((PathBuf::from("index.md"), md.into_bytes()));
    out.push((PathBuf::from("index.html"), html.into_bytes()));
    Ok(out)
}

/// The plan of the run: every manifest's inputs, `--out` and `--json`, checked.
fn plan(samples: &[SampleInput], args: &Args, batch: bool) -> anyhow::Result<Plan> {
    let mut plan = Plan::new();
    for s in samples {
        plan.input("SAMPLE", &s.file);
        for m in &s.maps {
            plan.input("maps.files", &m.height);
            if let Some(i) = &m.intensity {
                plan.input("maps.intensity", i);
            }
        }
        for f in &s.measured {
            plan.input("measured.files", f);
        }
        if let Some(f) = &s.paint {
            plan.input("paint.file", f);
        }
    }
    plan.output_dir(
        "--out",
        &args.out,
        if batch { batch::BATCH_OWNER } else { OWNER },
    );
    if args.json {
        plan.stdout("--json");
    }
    plan.check()?;
    Ok(plan)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let files = manifest_files(&args.manifests)?;
    let mut samples = Vec::with_capacity(files.len());
    for f in &files {
        samples.push(resolve(f)?);
    }
    let batch = samples.len() > 1;
    if batch {
        let names: Vec<(&str, &Path)> = samples
            .iter()
            .map(|s| (s.name.as_str(), s.file.as_path()))
            .collect();
        batch::check_names(&names)?;
    }
    let mut plan = plan(&samples, &args, batch)?;
    // The identity of this build (build.rs): part of every cache key.
    let build = env!("FLAKESCATTER_BUILD");

    let bar = crate::output::progress::bar("{prefix} {msg} {bar:30} {pos}/{len}", true);
    let renderer = (!args.no_preview).then(preview::probe);
    let mut previews: Vec<(String, Vec<u8>)> = Vec::new();
    let mut rows = Vec::new();
    let mut echoes = Vec::new();
    let mut open_batch: Option<crate::output::batch::Batch> = None;
    for (k, s) in samples.iter().enumerate() {
        let dir = if batch {
            args.out.join(&s.name)
        } else {
            args.out.clone()
        };
        if let Some(b) = &bar {
            b.set_prefix(format!("[{}/{}] {}", k + 1, samples.len(), s.name));
        }
        let progress = |stage: &str, done: usize, total: usize| {
            if let Some(b) = &bar {
                b.set_message(stage.to_owned());
                b.set_length(total as u64);
                b.set_position(done as u64);
            }
        };
        // The previous report (checked to be one) is read for its cache only.
        let cache = read_cache(&dir, &s.map_names);
        let report = analyze_sample(s, &cache, build, &progress)
            .with_context(|| format!("sample {} ({})", s.name, s.file.display()))?;
        if let Some(b) = &bar {
            b.set_message("preview");
        }
        let shown = show_preview(renderer.as_ref(), &report, &dir, build);
        if let Some(png) = &shown.png {
            previews.push((s.name.clone(), png.clone()));
        }
        let out = render(s, &report, &dir, shown)?;
        for w in &report.warnings {
            warn(&format!("{}: {w}", s.name));
        }
        let detail = Some(format!("{} files", out.len()));
        if batch {
            if open_batch.is_none() {
                open_batch = Some(batch::open(&args.out)?);
            }
            // Each sample is swapped in when complete (module docs).
            let mut p = Plan::new();
            p.write_dir("--out", &dir, OWNER, &out, detail)?;
            p.finish()?;
            if let Some(b) = open_batch.as_mut() {
                b.added(&s.name)?;
            }
        } else {
            plan.write_dir("--out", &dir, OWNER, &out, detail)?;
        }
        note(&format!(
            "{}: hwhm {:.3}° {}; work: {} map(s) segmented, {} reused, {} model run(s){}",
            s.name,
            report.row.hwhm_deg,
            report.row.interval,
            report.work.maps_segmented,
            report.work.maps_reused,
            report.work.model_work() - report.work.maps_segmented,
            if report.work.models_reused {
                " (model results reused)"
            } else {
                ""
            }
        ));
        echoes.push(json!({
            "sample": s.name,
            "manifest": s.file.display().to_string(),
            "dir": dir.display().to_string(),
            "hwhm_deg": report.row.hwhm_deg,
            "hwhm_ci95_deg": [report.row.hwhm_ci95_deg.0, report.row.hwhm_ci95_deg.1],
            "interval": report.row.interval,
            "work": report.summary["work"],
            "failed_statistics": report.summary["failed_statistics"],
            "warnings": report.warnings,
        }));
        rows.push(report.row);
    }
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    if let Some(b) = open_batch {
        let (csv, mut doc) = comparison_report(&rows);
        let montage = side_by_side(renderer.as_ref(), &previews, &mut doc);
        let html = doc.to_html("Samples compared", &|name| {
            (name == SIDE_BY_SIDE)
                .then_some(montage.as_deref())
                .flatten()
                .map(data_uri)
        });
        if let Some(png) = &montage {
            let dest = Dest::File(args.out.join(SIDE_BY_SIDE));
            plan.write(&dest, |w| Ok(w.write_all(png)?), None)?;
        }
        let detail = format!("{} samples compared", rows.len());
        for (name, text, detail) in [
            ("samples.csv", csv, Some(detail)),
            ("index.md", doc.to_markdown(), None),
            ("index.html", html, None),
        ] {
            let dest = Dest::File(args.out.join(name));
            plan.write(&dest, |w| Ok(w.write_all(text.as_bytes())?), detail)?;
        }
        plan.finish()?;
        b.finish()?;
    } else {
        plan.finish()?;
    }
    if args.json {
        print_json(&json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "analyze",
            "out": args.out.display().to_string(),
            "samples": echoes,
        }))?;
    }
    Ok(())
}

/// The batch report's picture of every sample's preview side by side.
const SIDE_BY_SIDE: &str = batch::COMPARISON_FILES[3];

/// A sample report's preview: its files, its section, and the PNG for a comparison.
struct Shown {
    files: Vec<(String, Vec<u8>)>,
    blocks: Vec<Block>,
    png: Option<Vec<u8>>,
    /// `summary.json`'s `"preview"`: the picture, the model and the renderer, or why
    /// there is none (`null` with `--no-preview`).
    summary: serde_json::Value,
}

/// The preview section of a report (module `preview`): the cached or newly rendered
/// sphere, or a note saying why there is none. A failed rendering is a warning and a
/// note, not a failed report.
fn show_preview(
    renderer: Option<&preview::Availability>,
    report: &flakescatter::analyze::SampleReport,
    dir: &Path,
    build: &str,
) -> Shown {
    let mut blocks = vec![Block::Heading(2, "Preview".into())];
    let note = |why: String| Shown {
        files: Vec::new(),
        blocks: vec![
            Block::Heading(2, "Preview".into()),
            Block::Para(why.clone()),
        ],
        png: None,
        summary: json!({"png": null, "note": why}),
    };
    let Some(renderer) = renderer else {
        return Shown {
            files: Vec::new(),
            blocks: Vec::new(),
            png: None,
            summary: serde_json::Value::Null,
        };
    };
    let Some(model) = &report.preview else {
        return note("No preview: the pooled width gives no orientation distribution and there is no fitted paint.".into());
    };
    let r = match renderer {
        preview::Availability::Ready(r) => r,
        preview::Availability::Missing(why) => {
            return note(format!(
                "No preview: rendering needs the Python package with Mitsuba 3 (`pip install flakescatter[render]`, and `FLAKESCATTER_PYTHON` naming that Python if it is not `python3`): {why}."
            ));
        }
    };
    let key = r.key(model, build);
    let png = match preview::cached(dir, &key) {
        Some(png) => png,
        None => match r.preview(model) {
            Ok(png) => png,
            Err(e) => {
                warn(&format!("{}: preview: {e:#}", report.name));
                return note(format!("No preview: rendering failed: {e:#}."));
            }
        },
    };
    blocks.push(Block::Image(
        "preview.png".into(),
        format!(
            "{}, as a sphere under a sun 45° from the view and a uniform sky (flakescatter.mitsuba.render_preview; Mitsuba {})",
            model.describe(),
            r.identity()["mitsuba"].as_str().unwrap_or("?")
        ),
    ));
    Shown {
        files: vec![
            ("preview.png".into(), png.clone()),
            (
                "cache/preview.json".into(),
                preview::cache_text(&key, r.identity()).into_bytes(),
            ),
        ],
        blocks,
        png: Some(png),
        summary: json!({
            "png": "preview.png",
            "model": model.describe(),
            "renderer": r.identity(),
            "light": "a sun of irradiance 1 from 45° off the view (up left) and a uniform sky of radiance 0.05 (flakescatter.mitsuba.render_preview)",
        }),
    }
}

/// The samples' previews side by side in the comparison, or a note; the PNG's bytes.
fn side_by_side(
    renderer: Option<&preview::Availability>,
    previews: &[(String, Vec<u8>)],
    doc: &mut flakescatter::analyze::document::Document,
) -> Option<Vec<u8>> {
    let Some(preview::Availability::Ready(r)) = renderer else {
        return None;
    };
    if previews.is_empty() {
        return None;
    }
    let pngs: Vec<Vec<u8>> = previews.iter().map(|(_, p)| p.clone()).collect();
    let names: Vec<&str> = previews.iter().map(|(n, _)| n.as_str()).collect();
    doc.push(Block::Heading(2, "Previews".into()));
    match r.montage(&pngs) {
        Ok(png) => {
            doc.push(Block::Image(
                SIDE_BY_SIDE.into(),
                format!("Left to right: {}", names.join(", ")),
            ));
            Some(png)
        }
        Err(e) => {
            warn(&format!("previews side by side: {e:#}"));
            doc.push(Block::Para(format!("No side-by-side picture: {e:#}.")));
            None
        }
    }
}
