//! The real-paints check (`fixtures/real/paints`, measured MERL and RGL paints): one paint
//! parameter set per paint, fitted to every incidence, row and channel, judged on the rows
//! the tables can be trusted on (θr ≤ 80°, values ≥ 1e-3 sr⁻¹) against the targets of
//! rms log10 residuals (near specular 0.06 and far 0.12 at θi 15–60°, 0.2 at 75°, out of
//! plane 0.1 overall; `report::worst_ratio` ≤ 1 meets them all).

use std::path::PathBuf;

use flakescatter::compare::MeasuredKind;
use flakescatter::paint::report::worst_ratio;
use flakescatter::paint::{FitOptions, Measurement, fit, read_measurement};

fn table(name: &str) -> Measurement {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/real/paints")
        .join(name);
    read_measurement(&p, MeasuredKind::Brdf).unwrap()
}

fn trusted() -> FitOptions {
    let mut o = FitOptions::new();
    o.selection.max_theta_r = 80f64.to_radians();
    o.selection.min_value = 1e-3;
    o
}

/// Blue and gold meet every target with one parameter set.
#[test]
fn blue_and_gold_meet_the_targets() {
    for name in ["blue-metallic-paint2.csv", "gold-metallic-paint2.csv"] {
        let m = table(name);
        let f = fit(&m, &trusted()).unwrap();
        let worst = worst_ratio(&f.groups);
        assert!(worst <= 1.0, "{name}: worst group / target {worst}");
        // One parameter set: every incidence is in the fit.
        let incidences =
            f.groups
                .iter()
                .filter_map(|g| g.theta_i)
                .fold(Vec::<f64>::new(), |mut v, t| {
                    if !v.contains(&t) {
                        v.push(t);
                    }
                    v
                });
        assert_eq!(incidences.len(), 5, "{name}");
        // A parameter held on its bound has no standard uncertainty, and then no
        // interval either (not one clamped to the bound). Both paints hold their base
        // amplitudes at the floor (no base light in the trusted rows).
        let held: Vec<_> = f
            .fitted
            .iter()
            .chain(&f.physical)
            .filter(|e| e.std.is_nan())
            .collect();
        assert!(!held.is_empty(), "{name}: nothing held on a bound");
        for e in held {
            assert!(e.lo95.is_nan() && e.hi95.is_nan(), "{name}: {e:?}");
        }
    }
}

/// Silver (MERL) and ILM (RGL) do not meet the targets; these are the levels reached
/// (worst group / target: 1.57 and 1.99 when this was written), held so that they do not
/// get worse unnoticed, beside the best generic model's (1.61 and 1.99, shared README).
/// docs/physics.md §12.6 says which physical term is missing.
#[test]
fn silver_and_ilm_levels() {
    for (name, level) in [
        ("silver-metallic-paint2.csv", 1.60),
        ("ilm_l3_37_metallic_rgb.csv", 2.05),
    ] {
        let f = fit(&table(name), &trusted()).unwrap();
        let worst = worst_ratio(&f.groups);
        assert!(
            worst <= level,
            "{name}: worst group / target {worst} above {level}"
        );
    }
}

/// Reciprocity of the tables themselves: a physical BRDF has
/// `f(θi, θr, φr) = f(θr, θi, φr)`; the rows where both geometries exist (θr one of the
/// incidences, both values ≥ 1e-3) give the rms log10 of the ratio, computed from the
/// files. The MERL paints are reciprocal to about 0.01–0.03; the RGL (ILM) table is not,
/// by ~0.1 (up to 0.34 at θr = 75°), which no reciprocal model can follow.
#[test]
fn reciprocity_of_the_tables() {
    let rms_of = |name: &str| {
        let m = table(name);
        let key = |ti: f64, tr: f64, pr: f64| {
            (
                (ti.to_degrees() * 1e6).round() as i64,
                (tr.to_degrees() * 1e6).round() as i64,
                (pr.to_degrees() * 1e6).round() as i64,
            )
        };
        let map: std::collections::HashMap<_, _> = m
            .rows
            .iter()
            .map(|o| (key(o.theta_i, o.theta_r, o.phi_r), o.values[1]))
            .collect();
        let mut s = Vec::new();
        for o in &m.rows {
            if o.theta_r > o.theta_i
                && let Some(&w) = map.get(&key(o.theta_r, o.theta_i, o.phi_r))
                && o.values[1] >= 1e-3
                && w >= 1e-3
            {
                s.push((o.values[1] / w).log10());
            }
        }
        assert!(s.len() > 40, "{name}: {} pairs", s.len());
        (s.iter().map(|r| r * r).sum::<f64>() / s.len() as f64).sqrt()
    };
    for name in [
        "silver-metallic-paint2.csv",
        "blue-metallic-paint2.csv",
        "gold-metallic-paint2.csv",
    ] {
        let r = rms_of(name);
        assert!(r < 0.03, "{name}: {r}");
    }
    let ilm = rms_of("ilm_l3_37_metallic_rgb.csv");
    assert!(ilm > 0.08, "ILM: {ilm}");
}

/// The colour-changing paint (MERL) with interference flakes: a free TiO2 film whose
/// thickness is fitted (physics.md §12.7) follows it better than aluminium flakes
/// (worst group / target 1.25 against 1.64 when this was written; the best generic
/// model's 2.07, shared README), at a thickness of about 386 nm (a higher interference
/// order), which the scan found from a start of 100 nm. Held so that it does not get
/// worse unnoticed; the aluminium fit is redone here for the comparison.
#[test]
fn colour_changing_paint_with_a_fitted_film() {
    use flakescatter::optics::catalogue::Catalogue;
    use flakescatter::optics::stack_spec::StackSpec;
    use flakescatter::paint::ThicknessFit;
    use flakescatter::paint_model::FlakeMetal;

    let m = table("color-changing-paint1.csv");
    let aluminium = worst_ratio(&fit(&m, &trusted()).unwrap().groups);
    let mut o = trusted();
    o.flake_metal = FlakeMetal::stack(
        StackSpec::parse("TiO2:100", &Catalogue::builtin()).unwrap(),
        None,
    );
    o.thickness = Some(ThicknessFit {
        layers: vec![1],
        range_nm: (20.0, 400.0),
    });
    let f = fit(&m, &o).unwrap();
    let worst = worst_ratio(&f.groups);
    assert!(worst <= 1.30, "film: worst group / target {worst}");
    assert!(
        worst < aluminium - 0.2,
        "film {worst} against aluminium {aluminium}"
    );
    let d = f
        .physical
        .iter()
        .find(|e| e.name == "thickness (nm)")
        .unwrap();
    assert!((d.value - 386.0).abs() < 3.0, "{d:?}");
}

/// The pearl paint (MERL) with free TiO2 films (physics.md §12.8): one film reflects too
/// little for the highlight the paint has (worst group / target 3.30 when this was
/// written), a pile of 8 follows it as well as aluminium flakes do (0.71 against 0.69).
/// Held so that it does not get worse unnoticed.
#[test]
fn pearl_paint_with_a_pile_of_films() {
    use flakescatter::optics::catalogue::Catalogue;
    use flakescatter::optics::stack_spec::StackSpec;
    use flakescatter::paint::ThicknessFit;
    use flakescatter::paint_model::FlakeMetal;

    let m = table("pearl-paint.csv");
    let film = FlakeMetal::stack(
        StackSpec::parse("TiO2:100", &Catalogue::builtin()).unwrap(),
        None,
    );
    let worst_with = |layers: u32| {
        let mut o = trusted();
        o.flake_metal = film.with_layers(layers).unwrap();
        o.thickness = Some(ThicknessFit {
            layers: vec![1],
            range_nm: (20.0, 600.0),
        });
        worst_ratio(&fit(&m, &o).unwrap().groups)
    };
    let one = worst_with(1);
    let eight = worst_with(8);
    assert!(one > 3.0, "one film: worst group / target {one}");
    assert!(eight <= 0.75, "a pile of 8: worst group / target {eight}");
}

/// The colour-changing paint (MERL) with aluminium flakes under a tinted binder
/// (physics.md §12.9): the tint lets the flake light's colour change with angle (light
/// reaching the flakes obliquely crosses more binder), which the plain fit's
/// angle-independent flake scales cannot. Worst group / target 1.37 against 1.64
/// without when this was written, with a strong tint in red (1.68) and none in green.
/// Held so that it does not get worse unnoticed; the plain fit is redone here.
#[test]
fn colour_changing_paint_under_a_tinted_binder() {
    use flakescatter::paint::{FitExtras, fit_with};

    let m = table("color-changing-paint1.csv");
    let plain = worst_ratio(&fit(&m, &trusted()).unwrap().groups);
    let f = fit_with(&m, &trusted(), FitExtras { tint: true }).unwrap();
    let worst = worst_ratio(&f.groups);
    assert!(worst <= 1.42, "tinted: worst group / target {worst}");
    assert!(worst < plain - 0.2, "tinted {worst} against plain {plain}");
    let red = f.physical.iter().find(|e| e.name == "tint r").unwrap();
    assert!(red.value > 1.0 && red.lo95 > 1.0, "{red:?}");
}
