//! The report document (`index.md`, `index.html`): the orientation statistics, the
//! models against the measurement, the fitted width and the multi-angle readout, the
//! overlays, the paint section, the warnings and the list of files.

use super::Analysis;
use crate::analyze::Work;
use crate::analyze::document::{Block, Document};
use crate::analyze::format::{ci_deg, deg, fmt_ci};
use crate::analyze::settings::kind_name;

/// The document; `qname` names the quoted interval, `curve_images` are the curve charts
/// (path, θi°, index), `paint_blocks` the paint section.
pub(super) fn document(
    a: &Analysis,
    qname: &str,
    curve_images: &[(String, f64, usize)],
    paint_blocks: Vec<Block>,
    warnings: &[String],
    work: Work,
) -> Document {
    let mut d = Document::default();
    statistics(&mut d, a, qname);
    models(&mut d, a, curve_images);
    fit_and_readout(&mut d, a);
    closing(&mut d, a, paint_blocks, warnings, work);
    d
}

/// The heading and the orientation statistics.
fn statistics(d: &mut Document, a: &Analysis, qname: &str) {
    let (input, stats) = (a.input, a.stats);
    let m = &input.manifest;
    let p = &stats.pooled;
    let flake = &p.flake_level;
    let names = &input.map_names;
    let failed = a.failed;
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
}

/// The models against the measurement: the comparison table and the curve charts.
fn models(d: &mut Document, a: &Analysis, curve_images: &[(String, f64, usize)]) {
    let (input, instrument, coating, models, measured, comparisons) = (
        a.input,
        a.instrument,
        a.coating,
        a.models,
        a.measured,
        a.comparisons,
    );
    let m = &input.manifest;
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
    for (path, ti_deg, _) in curve_images {
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
}

/// The width fitted to the measured curve and the multi-angle readout.
fn fit_and_readout(d: &mut Document, a: &Analysis) {
    let models = a.models;
    let flake = &a.stats.pooled.flake_level;
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
}

/// The overlays, the paint section, the warnings, the files and the work done.
fn closing(
    d: &mut Document,
    a: &Analysis,
    paint_blocks: Vec<Block>,
    warnings: &[String],
    work: Work,
) {
    let names = &a.input.map_names;
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
        d.push(Block::List(warnings.to_vec()));
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
}
