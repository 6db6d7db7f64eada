//! Interference (thin-film) flakes in the paint model and a fitted layer thickness
//! (physics.md §12.7, §13).
//!
//! * At normal incidence and normal exit the flakes that reflect are the level ones, met
//!   at normal incidence, where s and p are one: the flake term of a stack paint over
//!   that of a perfect-conductor paint is the film's reflectance at the channel's
//!   wavelength, written here in closed form (Airy's single-layer formula).
//! * A 1 µm aluminium layer is bulk aluminium: a stack paint of it equals the
//!   aluminium paint.
//! * A table made by the model with a known TiO2/mica/TiO2 thickness gives the thickness
//!   back from a start in another interference order (the scan), within 1e-3 nm for
//!   exact data and within its 95 % interval for 3 % noise.

use flakescatter_optics::Vec3;
use flakescatter_optics::catalogue::Catalogue;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::stack_spec::StackSpec;
use flakescatter_paint::fit::{
    Family, FitOptions, Measurement, Observation, ThicknessFit, fit_paint,
};
use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams};
use flakescatter_stats::Orientation;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn stack(text: &str) -> FlakeMetal {
    FlakeMetal::stack(StackSpec::parse(text, &Catalogue::builtin()).unwrap(), None)
}

fn paint(metal: FlakeMetal, channels: &[&str]) -> PaintParams {
    PaintParams {
        coat: CoatParams::flat(1.5),
        orientation: Orientation::trowbridge_reitz(0.1).unwrap(),
        coverage: 0.6,
        flake_metal: metal,
        channels: channels
            .iter()
            .map(|c| ChannelParams {
                channel: Channel::parse(c).unwrap(),
                flake_scale: 1.0,
                base_albedo: 0.0,
                tint: 0.0,
            })
            .collect(),
    }
}

/// Airy: a film of index `n1`, `d` nm thick, in a medium of index `n0` on both sides, at
/// normal incidence and vacuum wavelength `wl` nm: `|r|²` with
/// `r = (r01 + r10 e^{2iδ}) / (1 + r01 r10 e^{2iδ})`, `r01 = (n0 − n1)/(n0 + n1) = −r10`,
/// `δ = 2π n1 d / λ`.
fn airy(n0: f64, n1: f64, d: f64, wl: f64) -> f64 {
    let r01 = (n0 - n1) / (n0 + n1);
    let r10 = -r01;
    let e = Complex::from_polar(1.0, 4.0 * std::f64::consts::PI * n1 * d / wl);
    let r = (Complex::new(r01, 0.0) + r10 * e) / (Complex::new(1.0, 0.0) + r01 * r10 * e);
    r.norm_sqr()
}

#[test]
fn normal_flake_term_is_the_films_reflectance_at_each_channel() {
    let channels = ["r", "g", "b", "500nm"];
    let film = PaintModel::new(paint(stack("2.6:120"), &channels)).unwrap();
    let mirror = PaintModel::new(paint(FlakeMetal::PerfectConductor, &channels)).unwrap();
    let (fi, mi) = (film.incidence(0.0).unwrap(), mirror.incidence(0.0).unwrap());
    let up = Vec3::new(0.0, 0.0, 1.0);
    for (k, (name, wl)) in [("r", 612.0), ("g", 547.0), ("b", 464.0), ("500nm", 500.0)]
        .into_iter()
        .enumerate()
    {
        let ratio = film.terms(&fi, &up, k).flakes / mirror.terms(&mi, &up, k).flakes;
        let want = airy(1.5, 2.6, 120.0, wl);
        assert!(
            (ratio - want).abs() < 1e-12,
            "channel {name}: {ratio} vs Airy {want}"
        );
    }
    // The three channels differ: the film is coloured (a check that the wavelengths
    // reach the optics).
    assert!((airy(1.5, 2.6, 120.0, 612.0) - airy(1.5, 2.6, 120.0, 464.0)).abs() > 0.05);
}

#[test]
fn a_micrometre_of_aluminium_is_the_aluminium_paint() {
    let channels = ["r", "g", "b"];
    let al = PaintModel::new(paint(FlakeMetal::Aluminium, &channels)).unwrap();
    let st = PaintModel::new(paint(stack("aluminium:1000"), &channels)).unwrap();
    for ti in [10f64, 45.0, 70.0] {
        let (a, s) = (
            al.incidence(ti.to_radians()).unwrap(),
            st.incidence(ti.to_radians()).unwrap(),
        );
        for tr in [-60f64, -20.0, 0.0, 15.0, 40.0, 75.0] {
            for phi in [0f64, 40.0] {
                let (t, p) = (tr.to_radians(), phi.to_radians());
                let r = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos().abs());
                for k in 0..3 {
                    let (x, y) = (al.terms(&a, &r, k).flakes, st.terms(&s, &r, k).flakes);
                    assert!(
                        (x - y).abs() <= 1e-9 * x.abs().max(1e-300),
                        "θi {ti} θr {tr} φ {phi} channel {k}: {x} vs {y}"
                    );
                }
            }
        }
    }
}

/// The paint of the thickness fits: TiO2 (rutile) 100 nm on both sides of 300 nm of
/// mica, Trowbridge–Reitz flakes, a slightly rough coat, three channels.
fn pearl(d: f64) -> PaintParams {
    let mut p = paint(
        stack(&format!("TiO2:{d}/mica:300/TiO2:{d}")),
        &["r", "g", "b"],
    );
    p.coat.roughness = 0.03;
    p.coverage = 0.5;
    for (c, (s, rho)) in p
        .channels
        .iter_mut()
        .zip([(0.9, 0.05), (0.7, 0.1), (0.8, 0.2)])
    {
        c.flake_scale = s;
        c.base_albedo = rho;
    }
    p
}

/// Incidences 20°, 45°, 65°; in-plane detectors every 4° on both sides up to 80°, and
/// out of the plane at 30°, 60° azimuth every 10°.
fn table(params: &PaintParams, mut noise: impl FnMut() -> f64) -> Measurement {
    let model = PaintModel::new(params.clone()).unwrap();
    let mut rows = Vec::new();
    for ti in [20.0f64, 45.0, 65.0] {
        let inc = model.incidence(ti.to_radians()).unwrap();
        let mut geometry: Vec<(f64, f64)> = (0..=20)
            .flat_map(|k| {
                let tr = 4.0 * f64::from(k);
                [(tr, 0.0), (tr, 180.0)]
            })
            .filter(|&(tr, phi)| tr > 0.0 || phi == 0.0)
            .collect();
        for phi in [30.0, 60.0] {
            geometry.extend((1..=8).map(|k| (10.0 * f64::from(k), phi)));
        }
        for (tr, phi) in geometry {
            let o = Observation {
                theta_i: ti.to_radians(),
                theta_r: f64::to_radians(tr),
                phi_r: f64::to_radians(phi),
                values: vec![],
                uncertainties: vec![],
                line: rows.len() as u64 + 2,
            };
            let r = o.direction();
            let values: Vec<f64> = (0..3).map(|k| model.brdf(&inc, &r, k) * noise()).collect();
            rows.push(Observation {
                uncertainties: vec![None; 3],
                values,
                ..o
            });
        }
    }
    Measurement {
        file: "synthetic pearl".into(),
        channels: params.channels.iter().map(|c| c.channel.clone()).collect(),
        rows,
    }
}

/// Fit options: Trowbridge–Reitz, no haze, the two TiO2 layers' thickness over
/// 40–300 nm, starting from a spec of 230 nm (another interference order).
fn options() -> FitOptions {
    FitOptions {
        families: vec![Family::TrowbridgeReitz],
        haze: false,
        flake_metal: stack("TiO2:230/mica:300/TiO2:230"),
        thickness: Some(ThicknessFit {
            layers: vec![1, 3],
            range_nm: (40.0, 300.0),
        }),
        ..FitOptions::new()
    }
}

fn fitted_thickness(fit: &flakescatter_paint::fit::PaintFit) -> &flakescatter_paint::fit::Estimate {
    fit.physical
        .iter()
        .find(|e| e.name == "thickness (nm)")
        .expect("a thickness estimate")
}

#[test]
fn exact_data_give_the_thickness_back_from_another_order() {
    let truth = pearl(100.0);
    let fit = fit_paint(&table(&truth, || 1.0), &options()).unwrap();
    let d = fitted_thickness(&fit);
    assert!((d.value - 100.0).abs() < 1e-3, "{d:?}");
    // The scan's best point is within a grid step (5 nm) of the truth: the scan, not the
    // start of 230 nm, put the fit in the right order.
    let scan = fit.thickness_scan.as_ref().unwrap();
    assert_eq!(scan.len(), 53);
    let best = scan.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert!((best.0 - 100.0).abs() <= 5.0, "{best:?}");
    // The paint fitted carries the thickness in its stack.
    assert!((fit.params.flake_metal.thickness(1).unwrap() - 100.0).abs() < 1e-3);
    assert_eq!(
        fit.params.flake_metal.thickness(2),
        Some(300.0),
        "the mica is not fitted"
    );
    assert!(
        fit.groups.iter().all(|g| g.rms_log10 < 1e-6),
        "{:?}",
        fit.groups
    );
}

#[test]
fn noisy_data_cover_the_thickness() {
    let truth = pearl(100.0);
    let mut rng = ChaCha8Rng::seed_from_u64(47);
    let normal = Normal::new(0.0, 0.03).unwrap();
    let m = table(&truth, || f64::exp(normal.sample(&mut rng)));
    let fit = fit_paint(&m, &options()).unwrap();
    let d = fitted_thickness(&fit);
    assert!(d.lo95 <= 100.0 && 100.0 <= d.hi95, "{d:?}");
    assert!(
        d.hi95 - d.lo95 < 5.0,
        "interval too wide to mean anything: {d:?}"
    );
}

#[test]
fn a_thickness_fit_needs_a_stack_and_its_layers() {
    let truth = pearl(100.0);
    let m = table(&truth, || 1.0);
    let with = |metal: FlakeMetal, layers: Vec<usize>, range: (f64, f64)| {
        fit_paint(
            &m,
            &FitOptions {
                flake_metal: metal,
                thickness: Some(ThicknessFit {
                    layers,
                    range_nm: range,
                }),
                ..options()
            },
        )
        .unwrap_err()
        .to_string()
    };
    let e = with(FlakeMetal::Aluminium, vec![1], (40.0, 300.0));
    assert!(e.contains("interference flakes"), "{e}");
    let e = with(stack("TiO2:100/mica:300"), vec![3], (40.0, 300.0));
    assert!(e.contains("layer 3") && e.contains("2 layer"), "{e}");
    let e = with(stack("TiO2:100/mica:300"), vec![], (40.0, 300.0));
    assert!(e.contains("at least one layer"), "{e}");
    for range in [(0.0, 300.0), (300.0, 40.0), (40.0, f64::INFINITY)] {
        let e = with(stack("TiO2:100/mica:300"), vec![1], range);
        assert!(e.contains("thickness range"), "{range:?}: {e}");
    }
}
