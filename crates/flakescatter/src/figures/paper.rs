//! Figs. 4 and 7: the distribution model for two widths, and the flake statistics of
//! the fixtures (truth tables against segmentation of their maps).

use std::fmt::Write as _;

use flakescatter_stats::Flake;
use flakescatter_stats::fit::fit_gaussian_ml;
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::histogram::AreaHistogram;
use flakescatter_stats::segment::{SegmentParams, segment};
use serde_json::{Value, json};

use super::{
    APERTURE_DEG, CUTOFF, Ctx, FIXTURES, FiguresError, Fixture, INCIDENCES, Index, deg, gaussian,
    sig,
};
use crate::chart::{Chart, Series, Style, THETA_S_LABEL};
use crate::pipeline::{
    Coating, CurveRow, Curves, OrientationSource, distribution_curves, p_tilde_about_specular,
};

/// Rows of `curves` at incidence `ti_deg`.
pub(super) fn rows_at(curves: &Curves, ti_deg: f64) -> Vec<CurveRow> {
    curves
        .rows
        .iter()
        .filter(|r| (r.theta_i.to_degrees() - ti_deg).abs() < 1e-9)
        .copied()
        .collect()
}

/// Fig. 4: relative curves for w = 4°, 10° at 30°, 60°, p̃ about specular.
pub(super) fn fig4(
    ctx: &Ctx,
    report: &mut super::Report,
    index: &mut Index,
) -> Result<(), FiguresError> {
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
    report.text("fig4.csv", csv);
    let mut files = vec!["fig4.csv".to_string()];
    for (k, series) in per_incidence.into_iter().enumerate() {
        let ti = INCIDENCES[k];
        let stem = format!("fig4_theta{ti}");
        report.chart(
            &stem,
            Chart {
                title: format!(
                    "Fig. 4 analogue: distribution model, θi = {ti}°\nsolid: collected power relative to specular; dashed: Gaussian p~ drawn about specular; {} weighting, α = {APERTURE_DEG}°",
                    ctx.weighting_name()
                ),
                x_label: THETA_S_LABEL.into(),
                y_label: "relative reflectance (1 at specular)".into(),
                log_y: true,
                series,
            },
        );
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

/// Fig. 7: histograms of p̃ from the truth tables and from segmentation of the maps
/// (`masked`: the fixtures' height maps with the intensity cutoff applied). Returns the
/// fitted widths by source, degrees.
pub(super) fn fig7(
    fixtures: &[Fixture],
    masked: &[HeightMap],
    report: &mut super::Report,
    index: &mut Index,
) -> Result<Value, FiguresError> {
    let bin = 1f64.to_radians();
    let mut csv = String::from(
        "source,flakes,hwhm_fit_deg,theta_lo_deg,theta_hi_deg,area_fraction,p_tilde\n",
    );
    let mut series = Vec::new();
    let mut fits = serde_json::Map::new();
    let mut notes = Vec::new();
    let fail = |message: String| FiguresError::Figure {
        figure: "Fig. 7",
        message,
    };
    for (c, ((stem, hwhm, _), (fixture, map))) in
        FIXTURES.iter().zip(fixtures.iter().zip(masked)).enumerate()
    {
        let truth = &fixture.truth;
        let seg = segment(map, &SegmentParams::for_instrument(0.3, 0.0))
            .map_err(|e| fail(format!("segmenting {stem}.height.x3p: {e}")))?;
        let found: Vec<Flake> = seg.flakes.iter().map(|f| f.to_flake()).collect();
        for (source, flakes, style) in [
            (format!("{stem}.truth.csv"), truth, Style::Line),
            (format!("segment {stem}.height.x3p"), &found, Style::Dashed),
        ] {
            let hist = AreaHistogram::from_flakes(flakes, bin)
                .map_err(|e| fail(format!("histogram of {source}: {e}")))?;
            let samples: Vec<(f64, f64)> = flakes
                .iter()
                .map(|f| (f.normal.z.clamp(-1.0, 1.0).acos(), f.area_um2))
                .collect();
            let fit =
                fit_gaussian_ml(&samples).map_err(|e| fail(format!("width of {source}: {e}")))?;
            let w = fit.hwhm().to_degrees();
            fits.insert(source.clone(), json!(sig(w)));
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
                    // k/10 is the double nearest the decimal: 0.3, not 0.30000000000000004.
                    let t = f64::from(k) / 10.0;
                    (t, o.p_tilde(t.to_radians()))
                })
                .collect(),
            style: Style::Line,
            colour: c + 4,
        });
    }
    report.text("fig7.csv", csv);
    report.chart(
        "fig7",
        Chart {
            title: "Fig. 7 analogue: area-weighted p~ histograms (1° bins) of the fixture maps\nsolid steps: truth tables; dashed steps: automatic segmentation of the height maps; smooth: generator's p~".into(),
            x_label: "θn, flake tilt from the coating normal (degrees)".into(),
            y_label: "p~(θn) = area fraction / (cos θlo − cos θhi)".into(),
            log_y: false,
            series,
        },
    );
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
