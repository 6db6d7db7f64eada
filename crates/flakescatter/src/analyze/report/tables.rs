//! The report's tables: `maps.csv`, `flakes.csv`, `histogram.csv`, `curves.csv` and
//! `comparison.csv` (docs/formats.md), numbers by [`num`].

use std::fmt::Write as _;

use super::Analysis;
use crate::analyze::format::{deg, num, opt};
use crate::analyze::settings::in_plane_angles;
use crate::analyze::{Content, OutFile};

/// The tables, in the report's order; `comparison.csv` only with comparisons.
pub(super) fn tables(a: &Analysis) -> Vec<OutFile> {
    let text = |path: &str, t: String| OutFile {
        path: path.to_owned(),
        content: Content::Text(t),
    };
    let mut files = vec![
        text("maps.csv", maps_csv(a)),
        text("flakes.csv", flakes_csv(a)),
        text("histogram.csv", histogram_csv(a)),
        text("curves.csv", curves_csv(a)),
    ];
    if !a.comparisons.is_empty() {
        files.push(text("comparison.csv", comparison_csv(a)));
    }
    files
}

/// Per map its flakes, width, interval, z and flag.
fn maps_csv(a: &Analysis) -> String {
    let (input, stats) = (a.input, a.stats);
    let p = &stats.pooled;
    let names = &input.map_names;
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
    t
}

/// Every flake of every map, as `segment --out` writes them (io's one writer).
fn flakes_csv(a: &Analysis) -> String {
    let maps: Vec<(&str, &[flakescatter_stats::SegmentedFlake])> = a
        .input
        .map_names
        .iter()
        .zip(&a.stats.segmentations)
        .map(|(n, s)| (n.as_str(), s.flakes.as_slice()))
        .collect();
    let mut bytes = Vec::new();
    // Writing to memory cannot fail.
    let _ = flakescatter_io::flakes::write_segmented_flakes(&mut bytes, "flakes.csv", &maps);
    String::from_utf8(bytes).unwrap_or_default()
}

/// The pooled area-weighted histogram, as `stats --out` writes it.
fn histogram_csv(a: &Analysis) -> String {
    // io's one writer, as `stats --out` writes the histogram.
    let mut bytes = Vec::new();
    // Writing to memory cannot fail.
    let _ =
        flakescatter_io::flakes::write_histogram(&mut bytes, "histogram.csv", &a.stats.histogram);
    String::from_utf8(bytes).unwrap_or_default()
}

/// Every model curve.
fn curves_csv(a: &Analysis) -> String {
    let (instrument, models) = (a.instrument, a.models);
    let ts_list = in_plane_angles(instrument);
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
    t
}

/// Per model, incidence and region the fitted scale and log10 residuals.
fn comparison_csv(a: &Analysis) -> String {
    let comparisons = a.comparisons;
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
    t
}
