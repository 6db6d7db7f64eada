//! Thin-film stacks (physics.md §13) against an independent implementation (the `tmm`
//! package, data/thinfilm/README.md) and against closed forms derived here.

use std::f64::consts::PI;

use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::thinfilm::{FilmStack, Layer, MAX_LAYERS, ThinFilmError};

type C = Complex<f64>;

const TMM: &str = include_str!("data/thinfilm/tmm_reference.csv");

fn stack_of(spec: &str) -> FilmStack {
    let layers = spec
        .split('/')
        .map(|l| {
            let v: Vec<f64> = l.split(':').map(|x| x.parse().unwrap()).collect();
            Layer::new(C::new(v[0], v[1]), v[2]).unwrap()
        })
        .collect();
    FilmStack::new(layers).unwrap()
}

/// 1,200 rows: 24 random stacks (1–7 layers, absorbing and clear, metal cores, total
/// internal reflection), 5 angles, 10 wavelengths, s and p — amplitudes and powers to 1e-10.
#[test]
fn agrees_with_tmm_package() {
    let mut lines = TMM.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 18);
    let (mut rows, mut worst, mut tir) = (0, 0.0f64, 0);
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let v: Vec<f64> = f[1..].iter().map(|x| x.parse().unwrap()).collect();
        let (ambient, exit, theta, wl) = (v[0], C::new(v[1], v[2]), v[3], v[4]);
        let got = stack_of(f[0])
            .response(ambient, exit, theta.to_radians().cos(), wl)
            .unwrap();
        let want_amp = [
            C::new(v[5], v[6]),
            C::new(v[7], v[8]),
            C::new(v[9], v[10]),
            C::new(v[11], v[12]),
        ];
        let got_amp = [got.rs, got.rp, got.ts, got.tp];
        for (g, w) in got_amp.iter().zip(&want_amp) {
            let err = (g - w).norm();
            worst = worst.max(err);
            assert!(err < 1e-10, "{line}: amplitude {g} vs tmm {w}");
        }
        let got_pow = [got.r_s(), got.r_p(), got.t_s(), got.t_p()];
        for (g, w) in got_pow.iter().zip(&v[13..17]) {
            assert!((g - w).abs() < 1e-10, "{line}: power {g} vs tmm {w}");
        }
        if v[2] == 0.0 && ambient * theta.to_radians().sin() > v[1] {
            tir += 1;
            assert!(got.t_s() == 0.0 && got.t_p() == 0.0, "{line}");
        }
        rows += 1;
    }
    assert_eq!(rows, 1200);
    assert!(tir >= 100, "total internal reflection rows: {tir}");
    assert!(worst < 1e-10);
}

/// A single lossless layer (index n₁, thickness d) between real media n₀ and n₂ — the
/// Airy sum of the multiply reflected beams (Born & Wolf §7.6.1):
/// `R = (r₀₁² + r₁₂² + 2 r₀₁ r₁₂ cos 2β) / (1 + r₀₁² r₁₂² + 2 r₀₁ r₁₂ cos 2β)`, with the
/// real Fresnel coefficients of each interface and `β = 2π n₁ d cos θ₁ / λ`. Written
/// here with real trigonometry only.
#[test]
fn single_layer_is_the_airy_formula() {
    let (n0, n1, n2, d) = (1.5, 2.6, 1.0, 180.0);
    for theta_deg in [0.0f64, 20.0, 35.0, 40.0] {
        let t0 = theta_deg.to_radians();
        let s = n0 * t0.sin();
        let c1 = (1.0 - (s / n1).powi(2)).sqrt();
        let c2 = (1.0 - (s / n2).powi(2)).sqrt(); // below the critical angle 41.8°
        let c0 = t0.cos();
        for wl in [400.0, 473.0, 550.0, 612.0, 700.0] {
            let beta = 2.0 * PI * n1 * d * c1 / wl;
            let airy = |r01: f64, r12: f64| {
                let c = (2.0 * beta).cos();
                (r01 * r01 + r12 * r12 + 2.0 * r01 * r12 * c)
                    / (1.0 + r01 * r01 * r12 * r12 + 2.0 * r01 * r12 * c)
            };
            let rs = airy(
                (n0 * c0 - n1 * c1) / (n0 * c0 + n1 * c1),
                (n1 * c1 - n2 * c2) / (n1 * c1 + n2 * c2),
            );
            let rp = airy(
                (n1 * c0 - n0 * c1) / (n1 * c0 + n0 * c1),
                (n2 * c1 - n1 * c2) / (n2 * c1 + n1 * c2),
            );
            let got = FilmStack::new(vec![Layer::new(C::new(n1, 0.0), d).unwrap()])
                .unwrap()
                .response(n0, C::new(n2, 0.0), c0, wl)
                .unwrap();
            assert!((got.r_s() - rs).abs() < 1e-12, "{theta_deg} {wl}");
            assert!((got.r_p() - rp).abs() < 1e-12, "{theta_deg} {wl}");
            // Lossless: what is not reflected is transmitted.
            assert!((got.r_s() + got.t_s() - 1.0).abs() < 1e-12);
            assert!((got.r_p() + got.t_p() - 1.0).abs() < 1e-12);
        }
    }
}

/// A quarter-wave stack (HL)ᴺH at its design wavelength, normal incidence, between n₀ and
/// n_s: each quarter-wave layer turns the admittance Y into n²/Y, so the stack presents
/// `Y = (n_H/n_L)^{2N} n_H² / n_s` and `R = ((n₀ − Y)/(n₀ + Y))²` (Macleod, Thin-film
/// optical filters, §5.1).
#[test]
fn quarter_wave_stack_peak_is_its_closed_form() {
    let (n0, ns, nh, nl, wl) = (1.5, 1.5, 2.6, 1.46, 560.0);
    for pairs in 0..6 {
        let mut layers = Vec::new();
        for _ in 0..pairs {
            layers.push(Layer::new(C::new(nh, 0.0), wl / (4.0 * nh)).unwrap());
            layers.push(Layer::new(C::new(nl, 0.0), wl / (4.0 * nl)).unwrap());
        }
        layers.push(Layer::new(C::new(nh, 0.0), wl / (4.0 * nh)).unwrap());
        let y = (nh / nl).powi(2 * pairs) * nh * nh / ns;
        let closed = ((n0 - y) / (n0 + y)).powi(2);
        let got = FilmStack::new(layers)
            .unwrap()
            .response(n0, C::new(ns, 0.0), 1.0, wl)
            .unwrap();
        assert!((got.r_s() - closed).abs() < 1e-12, "{pairs}: {}", got.r_s());
        assert!((got.r_p() - closed).abs() < 1e-12);
        // The design wavelength is the peak: 2 % away, R is lower.
        let off = |w: f64| {
            let mut l = Vec::new();
            for _ in 0..pairs {
                l.push(Layer::new(C::new(nh, 0.0), wl / (4.0 * nh)).unwrap());
                l.push(Layer::new(C::new(nl, 0.0), wl / (4.0 * nl)).unwrap());
            }
            l.push(Layer::new(C::new(nh, 0.0), wl / (4.0 * nh)).unwrap());
            FilmStack::new(l)
                .unwrap()
                .response(n0, C::new(ns, 0.0), 1.0, w)
                .unwrap()
                .r_s()
        };
        assert!(off(wl * 0.98) < closed && off(wl * 1.02) < closed);
    }
}

/// A free film (the same medium on both sides) reflects nothing where its round-trip
/// phase is a whole number of waves, `2 n d cos θt = m λ` (the two interface
/// reflections are equal and opposite and the multiple beams cancel). The zero moves to
/// shorter wavelengths as the angle grows; found here by a golden-section search.
#[test]
fn interference_minimum_moves_with_angle_as_2nd_cos() {
    let (n0, n1, d) = (1.5, 2.6, 300.0);
    let stack = FilmStack::new(vec![Layer::new(C::new(n1, 0.0), d).unwrap()]).unwrap();
    for theta_deg in [0.0f64, 15.0, 30.0, 45.0, 60.0] {
        let s = n0 * theta_deg.to_radians().sin();
        let cos_t = (1.0 - (s / n1).powi(2)).sqrt();
        for m in [3.0, 4.0] {
            let expected = 2.0 * n1 * d * cos_t / m;
            let r = |wl: f64| {
                stack
                    .response(n0, C::new(n0, 0.0), theta_deg.to_radians().cos(), wl)
                    .unwrap()
                    .r_unpolarized()
            };
            let (mut a, mut b) = (expected * 0.93, expected * 1.07);
            let g = (5f64.sqrt() - 1.0) / 2.0;
            for _ in 0..200 {
                let (x1, x2) = (b - g * (b - a), a + g * (b - a));
                if r(x1) < r(x2) {
                    b = x2;
                } else {
                    a = x1;
                }
            }
            let found = 0.5 * (a + b);
            assert!(
                (found - expected).abs() < 1e-5 * expected,
                "θ {theta_deg}°, m {m}: {found} vs {expected}"
            );
            assert!(r(found) < 1e-14);
        }
    }
}

/// A thick aluminium layer is a bulk aluminium mirror: the stack's amplitudes equal the
/// flake's single-interface Fresnel amplitudes (flake.rs, an independent formula) to 1e-9.
#[test]
fn thick_aluminium_layer_is_the_metal_flake() {
    let (n, k, n_binder) = (0.96, 6.69, 1.5);
    let flake = FlakeReflectance::complex(n, k).unwrap();
    let thick = FilmStack::new(vec![Layer::new(C::new(n, k), 1000.0).unwrap()]).unwrap();
    let bare = FilmStack::default();
    for cos in [1.0, 0.9, 0.6, 0.3, 0.05, 0.0] {
        let (rs, rp) = flake.amplitudes(cos, n_binder);
        let a = thick
            .response(n_binder, C::new(n_binder, 0.0), cos, 550.0)
            .unwrap();
        let b = bare.response(n_binder, C::new(n, k), cos, 550.0).unwrap();
        for got in [a, b] {
            assert!((got.rs - rs).norm() < 1e-9, "{cos}: {} vs {rs}", got.rs);
            assert!((got.rp - rp).norm() < 1e-9, "{cos}: {} vs {rp}", got.rp);
        }
        assert!(a.t_s() < 1e-30 && a.t_p() < 1e-30);
    }
}

/// Lossless stacks conserve energy, R + T = 1; a lossless stack between equal media
/// transmits the same from either side (reciprocity), and reflects the same power.
#[test]
fn lossless_energy_and_reciprocity() {
    let stack = stack_of("2.6:0:120/1.56:0:400/2.6:0:120/1.3:0:77");
    for cos in [1.0, 0.8, 0.5, 0.2] {
        for wl in [400.0, 555.5, 700.0] {
            let f = stack.response(1.5, C::new(1.5, 0.0), cos, wl).unwrap();
            let b = stack
                .reversed()
                .response(1.5, C::new(1.5, 0.0), cos, wl)
                .unwrap();
            assert!((f.r_s() + f.t_s() - 1.0).abs() < 1e-12);
            assert!((f.r_p() + f.t_p() - 1.0).abs() < 1e-12);
            assert!((f.ts - b.ts).norm() < 1e-12 && (f.tp - b.tp).norm() < 1e-12);
            assert!((f.r_s() - b.r_s()).abs() < 1e-12);
        }
    }
}

#[test]
fn bad_layers_and_arguments_are_refused() {
    assert!(matches!(
        Layer::new(C::new(2.0, 0.0), 0.0),
        Err(ThinFilmError::InvalidThickness { .. })
    ));
    assert!(matches!(
        Layer::new(C::new(2.0, 0.0), -5.0),
        Err(ThinFilmError::InvalidThickness { .. })
    ));
    assert!(matches!(
        Layer::new(C::new(2.0, -0.1), 10.0),
        Err(ThinFilmError::InvalidIndex { .. })
    ));
    assert!(matches!(
        Layer::new(C::new(f64::NAN, 0.0), 10.0),
        Err(ThinFilmError::InvalidIndex { .. })
    ));
    let one = Layer::new(C::new(2.0, 0.0), 10.0).unwrap();
    assert_eq!(
        FilmStack::new(vec![one; MAX_LAYERS + 1]),
        Err(ThinFilmError::TooManyLayers(MAX_LAYERS + 1))
    );
    let s = FilmStack::new(vec![one; MAX_LAYERS]).unwrap();
    let one_c = C::new(1.5, 0.0);
    assert!(s.response(0.0, one_c, 1.0, 500.0).is_err());
    assert!(s.response(1.5, C::new(1.0, -1.0), 1.0, 500.0).is_err());
    assert!(s.response(1.5, one_c, 1.1, 500.0).is_err());
    assert!(s.response(1.5, one_c, 1.0, 0.0).is_err());
    assert!(s.response(1.5, one_c, 1.0, f64::INFINITY).is_err());
}
