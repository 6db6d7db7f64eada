//! Piles of transmitting flakes (physics.md §12.8): Stokes' pile of plates, `s` and `p`
//! separately, with the `s`–`p` cross products.
//!
//! Checked against things that are not the recursion of `flakescatter_optics::pile`:
//! * a lossless plate: `R_N = N R / (1 + (N − 1) R)` (Stokes 1862);
//! * an absorbing plate: the closed form of the `N`-th power of the plate's 2×2 flux
//!   transfer matrix (derived below; Stokes' result in another form), and its limit, the
//!   root of the fixed-point quadratic;
//! * an asymmetric plate (complex cross products too): the flux balance of every gap
//!   between the plates, a linear system solved by LU;
//! * real thin-film flakes: the coherent response of flakes separated by binder gaps
//!   (one thin-film stack, Rouard's recursion), averaged over the gaps' phases: the
//!   incoherent pile is that average, for the powers and for `Re r_s r_p*`;
//! * the paint model: at normal incidence and exit the flake term of a pile of TiO2-like
//!   films over a mirror's is the lossless pile of Airy's reflectance (`N = 1`: Airy's);
//! * a table made by the model with 4 layers is fitted back to 4 layers.

use flakescatter_optics::Vec3;
use flakescatter_optics::catalogue::Catalogue;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::{Complex, DMatrix, DVector};
use flakescatter_optics::pile::Plate;
use flakescatter_optics::stack_spec::StackSpec;
use flakescatter_optics::thinfilm::{FilmStack, Layer};
use flakescatter_paint::fit::{Family, FitOptions, Measurement, Observation, fit_flake_layers};
use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams};
use flakescatter_stats::Orientation;

type C = Complex<f64>;

#[test]
fn lossless_plates_pile_as_stokes_says() {
    for r in [0.01, 0.04, 0.2, 0.45, 0.9] {
        let plate = Plate::powers(r, 1.0 - r, r, 1.0 - r);
        for n in [1u32, 2, 3, 4, 7, 8, 16, 100, 1000] {
            let p = plate.pile(n);
            let nf = f64::from(n);
            let want = nf * r / (1.0 + (nf - 1.0) * r);
            assert!(
                (p.r.re - want).abs() < 1e-12,
                "R {r} N {n}: {} vs {want}",
                p.r.re
            );
            // Lossless: nothing absorbed, whatever N.
            assert!((p.r.re + p.t.re - 1.0).abs() < 1e-12);
            assert_eq!(p.r.im, 0.0);
        }
    }
}

/// An absorbing plate, the same from both sides (`R`, `T`, `R + T < 1`). The fluxes
/// going down (`D`) and up (`U`) on either side of a plate obey `D₂ = T D₁ + R U₂`,
/// `U₁ = R D₁ + T U₂`; as a transfer from side 2 to side 1, `(D₁, U₁) = M (D₂, U₂)` with
/// `M = [[1, −R], [R, T² − R²]]/T`, `det M = 1`, `tr M = (1 + T² − R²)/T = 2 cosh ξ`.
/// Cayley–Hamilton gives `Mᴺ = (sinh(Nξ) M − sinh((N − 1)ξ) I)/sinh ξ`, and a pile lit
/// from above with nothing from below (`U_N = 0`, `D₀ = 1`) has `T_N = 1/(Mᴺ)₀₀`,
/// `R_N = (Mᴺ)₁₀/(Mᴺ)₀₀`:
/// `R_N = R sinh(Nξ)/(sinh(Nξ) − T sinh((N − 1)ξ))`,
/// `T_N = T sinh ξ /(sinh(Nξ) − T sinh((N − 1)ξ))`.
fn stokes(r: f64, t: f64, n: u32) -> (f64, f64) {
    let xi = ((1.0 + t * t - r * r) / (2.0 * t)).acosh();
    let nf = f64::from(n);
    let den = (nf * xi).sinh() - t * ((nf - 1.0) * xi).sinh();
    (r * (nf * xi).sinh() / den, t * xi.sinh() / den)
}

#[test]
fn absorbing_plates_follow_the_closed_form_and_its_limit() {
    for (r, t) in [(0.3, 0.6), (0.08, 0.9), (0.5, 0.2)] {
        let plate = Plate::powers(r, t, r, t);
        let mut last = 0.0;
        for n in 1u32..=60 {
            let p = plate.pile(n);
            let (rn, tn) = stokes(r, t, n);
            assert!(
                (p.r.re - rn).abs() < 1e-12,
                "R {r} T {t} N {n}: {} vs {rn}",
                p.r.re
            );
            assert!(
                (p.t.re - tn).abs() < 1e-12,
                "R {r} T {t} N {n}: {} vs {tn}",
                p.t.re
            );
            assert!(p.r.re + p.t.re <= 1.0 + 1e-15, "energy at N {n}");
            assert!(p.r.re >= last - 1e-15, "more plates reflect more");
            last = p.r.re;
        }
        // The limit: R∞ = R + T² R∞/(1 − R R∞), i.e. R R∞² − (1 + R² − T²) R∞ + R = 0,
        // the smaller root.
        let b = 1.0 + r * r - t * t;
        let r_inf = (b - (b * b - 4.0 * r * r).sqrt()) / (2.0 * r);
        let far = plate.pile(1000);
        assert!((far.r.re - r_inf).abs() < 1e-12, "{} vs {r_inf}", far.r.re);
        assert!(far.t.re < 1e-12);
    }
}

/// The flux balance of `n` plates: in the gaps `0..=n` (0 above the first plate, `n`
/// below the last) the flux going down is `D_j`, up `U_j`; plate `j` (between gaps
/// `j − 1` and `j`) gives `D_j = T D_{j−1} + R' U_j` and `U_{j−1} = R D_{j−1} + T' U_j`;
/// `D_0 = 1`, `U_n = 0`. Returns `(U_0, D_n)` = the pile's `(R, T)`.
fn flux_balance(p: &Plate, n: usize) -> (C, C) {
    let m = 2 * (n + 1);
    let (d, u) = (|j: usize| 2 * j, |j: usize| 2 * j + 1);
    let mut a = DMatrix::<C>::zeros(m, m);
    let mut b = DVector::<C>::zeros(m);
    let one = C::new(1.0, 0.0);
    let mut row = 0;
    a[(row, d(0))] = one;
    b[row] = one;
    row += 1;
    a[(row, u(n))] = one;
    row += 1;
    for j in 1..=n {
        a[(row, d(j))] = one;
        a[(row, d(j - 1))] = -p.t;
        a[(row, u(j))] = -p.r_back;
        row += 1;
        a[(row, u(j - 1))] = one;
        a[(row, d(j - 1))] = -p.r;
        a[(row, u(j))] = -p.t_back;
        row += 1;
    }
    let x = a
        .lu()
        .solve(&b)
        .expect("a pile's flux balance has one solution");
    (x[u(0)], x[d(n)])
}

#[test]
fn asymmetric_plates_and_cross_products_match_the_flux_balance() {
    let powers = Plate::powers(0.35, 0.5, 0.15, 0.5);
    let cross = Plate {
        r: C::new(-0.2, 0.25),
        t: C::new(0.45, -0.1),
        r_back: C::new(0.1, -0.05),
        t_back: C::new(0.45, -0.1),
    };
    for plate in [powers, cross] {
        for n in 1..=9u32 {
            let p = plate.pile(n);
            let (r, t) = flux_balance(&plate, n as usize);
            assert!((p.r - r).norm() < 1e-13, "N {n}: {} vs {r}", p.r);
            assert!((p.t - t).norm() < 1e-13, "N {n}: {} vs {t}", p.t);
        }
    }
}

/// `layers` of `film` with `gaps[i]` nm of binder (index `n0`) between flakes `i` and
/// `i + 1`: one coherent thin-film stack.
fn coherent(film: &FilmStack, gaps: &[f64], n0: f64) -> FilmStack {
    let mut layers: Vec<Layer> = film.layers().to_vec();
    for &g in gaps {
        layers.push(Layer::new(C::new(n0, 0.0), g).unwrap());
        layers.extend(film.layers().iter().cloned());
    }
    FilmStack::new(layers).unwrap()
}

#[test]
fn a_pile_of_real_flakes_is_the_phase_average_of_coherent_flakes() {
    let cat = Catalogue::builtin();
    let (n0, wl) = (1.5, 547.0);
    // A free TiO2 film and an asymmetric, absorbing pigment (Fe2O3 on one side only).
    for spec in ["TiO2:150", "TiO2:100/mica:300/Fe2O3:40"] {
        let film = StackSpec::parse(spec, &cat).unwrap().at(wl).unwrap();
        let flake = FlakeReflectance::stack(film.clone(), wl, None).unwrap();
        for gamma in [1.0, 0.8, 0.5, 0.3] {
            // One fringe of a gap's phase: e^{2iδ}, δ = 2π n0 γ d/λ, repeats every
            // λ/(2 n0 γ); the trapezoid rule over a period of a smooth periodic
            // function is exact to rounding with enough points.
            let period = wl / (2.0 * n0 * gamma);
            // Two flakes, one gap: every path crosses the gap a different number of
            // times, so the phase average keeps exactly the paths' powers (with three
            // or more flakes, distinct paths that cross each gap as often keep their
            // interference in the average, which Stokes' sum leaves out: physics.md
            // §12.8).
            let (layers, k) = (2u32, 128usize);
            {
                let mut sum = [0.0; 3];
                for j in 0..k {
                    let gap = 2000.0 + period * j as f64 / k as f64;
                    let r = coherent(&film, &[gap], n0)
                        .response(n0, C::new(n0, 0.0), gamma, wl)
                        .unwrap();
                    sum[0] += r.r_s();
                    sum[1] += r.r_p();
                    sum[2] += (r.rs * r.rp.conj()).re;
                }
                let want = sum.map(|s| s / k as f64);
                let pile = flake.pile(layers).unwrap();
                let (rs, rp) = pile.amplitudes(gamma, n0);
                let got = [rs.norm_sqr(), rp.norm_sqr(), (rs * rp.conj()).re];
                for (g, w) in got.iter().zip(want) {
                    assert!(
                        (g - w).abs() < 1e-9,
                        "{spec} γ {gamma} N {layers}: {got:?} vs {want:?}"
                    );
                }
                let (ps, pp) = pile.power(gamma, n0);
                assert!((ps - want[0]).abs() < 1e-9 && (pp - want[1]).abs() < 1e-9);
                let (ts, tp) = pile.transmitted(gamma, n0);
                assert!(ps + ts <= 1.0 + 1e-12 && pp + tp <= 1.0 + 1e-12);
            }
        }
    }
}

#[test]
fn a_pile_polarises_so_averaging_first_is_wrong() {
    // At oblique incidence s and p reflect differently; piling their average differs
    // from averaging their piles.
    let film = StackSpec::parse("TiO2:150", &Catalogue::builtin())
        .unwrap()
        .at(547.0)
        .unwrap();
    let flake = FlakeReflectance::stack(film, 547.0, None).unwrap();
    let gamma = 0.35;
    let (rs, rp) = flake.power(gamma, 1.5);
    let (ts, tp) = flake.transmitted(gamma, 1.5);
    let avg = Plate::powers(
        0.5 * (rs + rp),
        0.5 * (ts + tp),
        0.5 * (rs + rp),
        0.5 * (ts + tp),
    );
    let (ps, pp) = flake.pile(8).unwrap().power(gamma, 1.5);
    assert!((0.5 * (ps + pp) - avg.pile(8).r.re).abs() > 0.01);
}

fn paint(metal: FlakeMetal) -> PaintParams {
    PaintParams {
        coat: CoatParams::flat(1.5),
        orientation: Orientation::trowbridge_reitz(0.1).unwrap(),
        coverage: 0.6,
        flake_metal: metal,
        channels: ["r", "g", "b"]
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

/// Airy: `|r|²` of a film of index `n1`, `d` nm, in `n0` on both sides, at normal
/// incidence, `r = (r01 + r10 e^{2iδ}) / (1 + r01 r10 e^{2iδ})`, `r10 = −r01`,
/// `δ = 2π n1 d/λ`.
fn airy(n0: f64, n1: f64, d: f64, wl: f64) -> f64 {
    let r01 = (n0 - n1) / (n0 + n1);
    let e = C::from_polar(1.0, 4.0 * std::f64::consts::PI * n1 * d / wl);
    let r = (C::new(r01, 0.0) - r01 * e) / (C::new(1.0, 0.0) - r01 * r01 * e);
    r.norm_sqr()
}

#[test]
fn the_normal_flake_term_of_a_pile_is_the_piled_airy_reflectance() {
    let film = FlakeMetal::stack(
        StackSpec::parse("2.6:120", &Catalogue::builtin()).unwrap(),
        None,
    );
    let mirror = PaintModel::new(paint(FlakeMetal::PerfectConductor)).unwrap();
    let mi = mirror.incidence(0.0).unwrap();
    let up = Vec3::new(0.0, 0.0, 1.0);
    for n in [1u32, 2, 4, 8, 50] {
        let pile = PaintModel::new(paint(film.with_layers(n).unwrap())).unwrap();
        let pi = pile.incidence(0.0).unwrap();
        for (k, wl) in [612.0, 547.0, 464.0].into_iter().enumerate() {
            let ratio = pile.terms(&pi, &up, k).flakes / mirror.terms(&mi, &up, k).flakes;
            let r = airy(1.5, 2.6, 120.0, wl);
            let nf = f64::from(n);
            let want = nf * r / (1.0 + (nf - 1.0) * r);
            assert!(
                (ratio - want).abs() < 1e-12,
                "N {n} λ {wl}: {ratio} vs {want}"
            );
        }
    }
}

#[test]
fn piles_of_opaque_flakes_and_bad_counts_are_refused() {
    let cat = Catalogue::builtin();
    let film = FlakeMetal::stack(StackSpec::parse("TiO2:100", &cat).unwrap(), None);
    for bad in [0u32, 1001] {
        let e = film.with_layers(bad).unwrap_err().to_string();
        assert!(e.contains("flake layers") && e.contains("1 to 1000"), "{e}");
    }
    let cored = FlakeMetal::stack(
        StackSpec::parse("TiO2:100", &cat).unwrap(),
        Some(cat.parse("aluminium").unwrap()),
    );
    for metal in [FlakeMetal::Aluminium, FlakeMetal::PerfectConductor, cored] {
        assert_eq!(metal.with_layers(1).unwrap(), metal);
        let e = metal.with_layers(2).unwrap_err().to_string();
        assert!(e.contains("transmit nothing"), "{e}");
    }
    // The optics refuse the same.
    assert!(FlakeReflectance::aluminium_550nm().pile(2).is_err());
    // A pile keeps its layers when a thickness is set.
    let four = film
        .with_layers(4)
        .unwrap()
        .with_thickness(&[1], 200.0)
        .unwrap();
    assert_eq!(four.layers(), 4);
}

/// Incidences 20°, 45°, 65°; in-plane detectors every 4° on both sides up to 80°, and
/// out of the plane at 30°, 60° azimuth every 10°: the table `params` make.
fn table(params: &PaintParams) -> Measurement {
    let model = PaintModel::new(params.clone()).unwrap();
    let mut rows = Vec::new();
    for ti in [20.0f64, 45.0, 65.0] {
        let inc = model.incidence(ti.to_radians()).unwrap();
        let mut geometry: Vec<(f64, f64)> = (1..=20)
            .flat_map(|k| [(4.0 * f64::from(k), 0.0), (4.0 * f64::from(k), 180.0)])
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
                uncertainties: vec![None; 3],
                line: rows.len() as u64 + 2,
            };
            let r = o.direction();
            let values = (0..3).map(|k| model.brdf(&inc, &r, k)).collect();
            rows.push(Observation { values, ..o });
        }
    }
    Measurement {
        file: "synthetic pile".into(),
        channels: params.channels.iter().map(|c| c.channel.clone()).collect(),
        rows,
    }
}

#[test]
fn a_table_of_four_layers_is_fitted_back_to_four() {
    let film = FlakeMetal::stack(
        StackSpec::parse("TiO2:150", &Catalogue::builtin()).unwrap(),
        None,
    );
    let mut truth = paint(film.with_layers(4).unwrap());
    truth.coat.roughness = 0.03;
    truth.coverage = 0.5;
    for (c, (s, rho)) in truth
        .channels
        .iter_mut()
        .zip([(0.9, 0.05), (0.7, 0.1), (0.8, 0.2)])
    {
        c.flake_scale = s;
        c.base_albedo = rho;
    }
    let opts = FitOptions {
        families: vec![Family::TrowbridgeReitz],
        haze: false,
        flake_metal: film.clone(),
        ..FitOptions::new()
    };
    let lf = fit_flake_layers(&table(&truth), &opts, 8).unwrap();
    assert_eq!(lf.layers, 4, "{:?}", lf.scan);
    assert_eq!(lf.fit.params.flake_metal.layers(), 4);
    assert_eq!(lf.scan.len(), 8);
    let chi2 = |n: u32| lf.scan[n as usize - 1].1.unwrap();
    // Exact data: the truth fits to rounding, its neighbours do not.
    assert!(chi2(4) < 1e-12, "{:?}", lf.scan);
    assert!(chi2(3) > 1e3 * chi2(4).max(1e-15) && chi2(5) > 1e3 * chi2(4).max(1e-15));
    assert!(lf.fit.groups.iter().all(|g| g.rms_log10 < 1e-6));
    // Flakes that transmit nothing have no pile to fit.
    let e = fit_flake_layers(
        &table(&truth),
        &FitOptions {
            flake_metal: FlakeMetal::Aluminium,
            ..opts
        },
        8,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("free interference flakes"), "{e}");
}

#[test]
fn a_pile_at_grazing_incidence_reflects_everything_and_never_more() {
    let film = StackSpec::parse("TiO2:100/mica:300/Fe2O3:40", &Catalogue::builtin())
        .unwrap()
        .at(612.0)
        .unwrap();
    let pile = FlakeReflectance::stack(film, 612.0, None)
        .unwrap()
        .pile(16)
        .unwrap();
    // §13: at grazing incidence a stack reflects everything and passes nothing.
    let (rs, rp) = pile.power(0.0, 1.5);
    assert!(
        (rs - 1.0).abs() < 1e-12 && (rp - 1.0).abs() < 1e-12,
        "{rs} {rp}"
    );
    assert_eq!(pile.transmitted(0.0, 1.5), (0.0, 0.0));
    for k in 1..=100 {
        let gamma = f64::from(k) / 100.0;
        let (rs, rp) = pile.power(gamma, 1.5);
        let (ts, tp) = pile.transmitted(gamma, 1.5);
        assert!(rs.is_finite() && rp.is_finite(), "γ {gamma}");
        assert!(
            rs + ts <= 1.0 + 1e-12 && rp + tp <= 1.0 + 1e-12,
            "γ {gamma}"
        );
        assert!(
            rs >= 0.0 && rp >= 0.0 && ts >= 0.0 && tp >= 0.0,
            "γ {gamma}"
        );
    }
}
