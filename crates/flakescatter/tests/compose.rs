//! The facade's composition, without the command-line tool: selection of measured
//! points, multi-angle readouts at another incidence, and the reproduced figures.

use flakescatter::chart::Style;
use flakescatter::compare::select;
use flakescatter::figures::{Content, FIXTURES, FiguresSpec, Fixture, reproduce};
use flakescatter::io::flakes::read_flakes;
use flakescatter::io::measured::{MeasuredCurve, MeasuredPoint};
use flakescatter::io::{ReadOptions, read_intensity, read_map};
use flakescatter::multiangle::{ASPECULAR_DEG, multi_angle, multi_angle_at};
use flakescatter::optics::polarization::Weighting;
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::{Coating, OrientationSource, Settings};

fn curve() -> MeasuredCurve {
    let mut points = Vec::new();
    for ti in [30.0f64, 60.0] {
        for ts in [-70.0f64, -40.0, -30.0, 0.0, 10.0] {
            points.push(MeasuredPoint {
                theta_i: ti.to_radians(),
                theta_s: ts.to_radians(),
                value: 1.0,
                uncertainty: None,
                line: points.len() as u64 + 2,
            });
        }
    }
    MeasuredCurve {
        file: "m.csv".into(),
        points,
    }
}

#[test]
fn selection_keeps_the_listed_angles_and_refuses_unmeasured_ones() {
    let c = curve();
    let r = |d: &[f64]| d.iter().map(|x| x.to_radians()).collect::<Vec<_>>();
    let only30 = select(&c, Some(&r(&[30.0])), None).unwrap();
    assert_eq!(only30.points.len(), 5);
    assert!(
        only30
            .points
            .iter()
            .all(|p| p.theta_i == 30f64.to_radians())
    );
    // A detector range wider than the file keeps what it covers: -40, -30, 0 of each.
    let range: Vec<f64> = (-40..=0).map(f64::from).collect();
    let near = select(&c, None, Some(&r(&range))).unwrap();
    assert_eq!(near.points.len(), 6);
    // Line numbers stay those of the file.
    assert_eq!(near.points[0].line, 3);
    let e = select(&c, Some(&r(&[45.0])), None).unwrap_err().to_string();
    assert!(e.contains("45") && e.contains("30, 60"), "{e}");
    let e = select(&c, None, Some(&r(&[5.0]))).unwrap_err().to_string();
    assert!(e.contains("no measured point"), "{e}");
}

#[test]
fn multi_angle_at_another_incidence_moves_every_detector() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let src = OrientationSource::Distribution(o);
    let (c, st, a) = (Coating::default(), Settings::default(), 1.5f64.to_radians());
    let m30 = multi_angle_at(&c, &st, &src, 30f64.to_radians(), a).unwrap();
    // θs = aspecular − θi (closed form of the geometry).
    for (r, asp) in m30.readouts.iter().zip(ASPECULAR_DEG) {
        assert!((r.theta_s.to_degrees() - (asp - 30.0)).abs() < 1e-9);
    }
    assert_eq!(m30.theta_i, 30f64.to_radians());
    // At 45° it is the standard readout.
    let m45 = multi_angle_at(&c, &st, &src, 45f64.to_radians(), a).unwrap();
    assert_eq!(m45, multi_angle(&c, &st, &src, a).unwrap());
    // 110° aspecular at 10° incidence is θs = 100°: below the horizon.
    assert!(multi_angle_at(&c, &st, &src, 10f64.to_radians(), a).is_err());
}

fn fixtures() -> Vec<Fixture> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures");
    let o = ReadOptions::default();
    FIXTURES
        .iter()
        .map(|(stem, _, _)| Fixture {
            stem: (*stem).into(),
            height: read_map(format!("{dir}/{stem}.height.x3p"), &o).unwrap().0,
            intensity: read_intensity(format!("{dir}/{stem}.intensity.x3p"), &o)
                .unwrap()
                .0,
            truth: read_flakes(std::path::Path::new(&format!("{dir}/{stem}.truth.csv")))
                .unwrap()
                .flakes,
        })
        .collect()
}

#[test]
fn the_figures_are_composed_without_the_cli() {
    let spec = FiguresSpec {
        quick: true,
        weighting: Weighting::Physical,
        command: "test".into(),
    };
    let fx = fixtures();
    // The fixtures must come in the documented order.
    let swapped = vec![fx[1].clone(), fx[0].clone()];
    assert!(reproduce(&swapped, &spec, &|_| {}).is_err());
    let report = reproduce(&fx, &spec, &|_| {}).unwrap();
    let charts: Vec<&str> = report
        .files
        .iter()
        .filter(|f| matches!(f.content, Content::Chart(_)))
        .map(|f| f.name.as_str())
        .collect();
    assert_eq!(
        charts,
        [
            "fig4_theta30",
            "fig4_theta60",
            "fig7",
            "fig9_theta30",
            "fig9_theta60",
            "fig10_theta30",
            "fig10_theta60",
            "fig10_ratio",
            "multiple_scattering_share",
            "multiple_scattering_brdf",
            "interference_spectra",
            "interference_travel"
        ]
    );
    for name in [
        "fig4.csv",
        "fig7.csv",
        "measured.csv",
        "fig9.csv",
        "fig10.csv",
        "multiple_scattering.csv",
        "comparison.json",
        "index.md",
    ] {
        assert!(report.text_of(name).is_some(), "{name}");
    }
    // Fig. 4: relative is 1 at the specular detector by definition (θs = −θi).
    let fig4 = report.text_of("fig4.csv").unwrap();
    let spec_rows: Vec<&str> = fig4
        .lines()
        .filter(|l| l.contains(",30,-30,") || l.contains(",60,-60,"))
        .collect();
    assert_eq!(spec_rows.len(), 4);
    for l in spec_rows {
        let rel: f64 = l.split(',').nth(5).unwrap().parse().unwrap();
        assert!((rel - 1.0).abs() < 1e-9, "{l}");
    }
    // Fig. 7: per source the area fractions sum to 1; 4 sources (2 truth, 2 segmented).
    let fig7 = report.text_of("fig7.csv").unwrap();
    let mut sums = std::collections::BTreeMap::<String, f64>::new();
    for l in fig7.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        *sums.entry(f[0].into()).or_default() += f[5].parse::<f64>().unwrap();
    }
    assert_eq!(sums.len(), 4);
    assert!(sums.values().all(|s| (s - 1.0).abs() < 1e-6), "{sums:?}");
    // The Fig. 7 chart: a truth, a segmented and a generator series per fixture.
    let c = report.chart_of("fig7").unwrap();
    assert_eq!(c.series.len(), 6);
    assert_eq!(
        c.series.iter().filter(|s| s.style == Style::Dashed).count(),
        2
    );
    // comparison.json: numbers rounded to the stated digits; the paper's finding that
    // the 6° model fits the rough sample better near specular than the 3° one.
    let j: serde_json::Value =
        serde_json::from_str(report.text_of("comparison.json").unwrap()).unwrap();
    let near = |model: &str, ti: f64| {
        j["comparisons"]["fig9"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["model"] == model && r["theta_i_deg"] == ti)
            .and_then(|r| {
                r["regions"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|x| x["region"] == "near-specular")
            })
            .and_then(|x| x["rms_log10"].as_f64())
            .unwrap()
    };
    for ti in [30.0, 60.0] {
        let (a, b) = (
            near("distribution, hwhm 6°", ti),
            near("distribution, hwhm 3°", ti),
        );
        assert!(a < b, "θi = {ti}: {a} vs {b}");
        assert_eq!((a * 1e6).round() / 1e6, a, "rounded to 1e-6");
    }
    let scale = j["comparisons"]["fig9"][0]["scale"].as_f64().unwrap();
    assert_eq!(
        format!("{scale:.5e}").parse::<f64>().unwrap(),
        scale,
        "6 significant digits"
    );
    let index = report.text_of("index.md").unwrap();
    assert!(index.contains("Generated by `test`") && index.contains("SYNTHETIC"));
    // Fig. 10: each incidence's chart has a standard-error band per sample whose bounds
    // hold the line (lower < value < upper wherever a standard error exists), and the
    // ratio chart one band per incidence.
    for stem in ["fig10_theta30", "fig10_theta60"] {
        let c = report.chart_of(stem).unwrap();
        let bands: Vec<_> = c.series.iter().filter(|s| s.style == Style::Band).collect();
        let lines: Vec<_> = c.series.iter().filter(|s| s.style == Style::Line).collect();
        assert_eq!((bands.len(), lines.len()), (2, 2), "{stem}");
        for (b, l) in bands.iter().zip(&lines) {
            let bounds = b.band_bounds();
            assert_eq!(bounds.len(), l.points.len());
            let mut with_error = 0;
            for (&(x, lo, hi), &(xl, y)) in bounds.iter().zip(&l.points) {
                assert_eq!(x, xl);
                if lo.is_finite() && y > 0.0 {
                    assert!(lo < y && y < hi, "{stem} at {x}: {lo} {y} {hi}");
                    with_error += 1;
                }
            }
            assert!(with_error > 250, "{stem}: {with_error} points with a band");
        }
    }
    let ratio = report.chart_of("fig10_ratio").unwrap();
    assert_eq!(
        ratio
            .series
            .iter()
            .filter(|s| s.style == Style::Band)
            .count(),
        2
    );
}

#[test]
fn a_tabulated_model_is_looked_up_by_angle_or_names_the_missing_one() {
    use flakescatter::compare::{ModelPoint, tabulated_points};
    let p = |b: f64| ModelPoint {
        brdf: b,
        relative: b,
        power: b,
    };
    let rows = vec![
        (30f64.to_radians(), (-30f64).to_radians(), p(1.0)),
        (30f64.to_radians(), (-20f64).to_radians(), p(2.0)),
    ];
    // Degrees read from another file agree to far better than 1e-6°.
    let ts = [(-20.0f64 + 1e-9).to_radians(), (-30f64).to_radians()];
    let got = tabulated_points(&rows, "t.csv", 30f64.to_radians(), &ts).unwrap();
    assert_eq!(got, vec![p(2.0), p(1.0)]);
    let e = tabulated_points(&rows, "t.csv", 30f64.to_radians(), &[(-25f64).to_radians()])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t.csv") && e.contains("theta_s_deg -25") && e.contains("theta_i_deg 30"),
        "{e}"
    );
}
