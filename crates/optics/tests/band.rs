//! A flake averaged over a band of wavelengths (`flakescatter_optics::band`): the mean of
//! its members' `R_s`, `R_p`, `x = r_s r_p*`, `T_s`, `T_p`, each member computed by the
//! stack solver (checked against `tmm` in `thinfilm.rs`) or Stokes' pile (`piles`).
//!
//! * At the table's nodes the band is the weighted mean to rounding; between them,
//!   within the linear interpolation's error (below 1e-6 here); in another medium it is
//!   summed directly (to rounding).
//! * Its equivalent amplitudes carry exactly its `R_s`, `R_p` and `Re x`.
//! * A band of one member is that member.
//! * Bad bands are refused.

use flakescatter_optics::band::BAND_NODES;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::thinfilm::{FilmStack, Layer};

fn film(n1: f64, d: f64, k: f64, wl: f64) -> FlakeReflectance {
    let layers = vec![
        Layer::new(Complex::new(n1, k), d).unwrap(),
        Layer::new(Complex::new(1.6, 0.0), 2.0 * d).unwrap(),
    ];
    FlakeReflectance::stack(FilmStack::new(layers).unwrap(), wl, None).unwrap()
}

/// `(R_s, R_p, x, T_s, T_p)` of a flake from its public methods.
fn quantities(f: &FlakeReflectance, c: f64, n: f64) -> (f64, f64, Complex<f64>, f64, f64) {
    let (rs, rp) = f.amplitudes(c, n);
    let (ps, pp) = f.power(c, n);
    let (ts, tp) = f.transmitted(c, n);
    (ps, pp, rs * rp.conj(), ts, tp)
}

fn members() -> Vec<(f64, FlakeReflectance)> {
    vec![
        (1.0, film(2.4, 150.0, 0.0, 520.0)),
        (3.0, film(2.4, 150.0, 0.0, 560.0)),
        (2.0, film(2.4, 150.0, 0.02, 600.0).pile(3).unwrap()),
    ]
}

#[test]
fn the_band_is_the_weighted_mean_of_its_members() {
    let n = 1.5;
    let m = members();
    let band = FlakeReflectance::band(m.clone(), n).unwrap();
    let total: f64 = m.iter().map(|x| x.0).sum();
    let mean = |c: f64, nn: f64| {
        let mut s = (0.0, 0.0, Complex::new(0.0, 0.0), 0.0, 0.0);
        for (w, f) in &m {
            let w = w / total;
            // A pile's `x` is its sum over paths; its equivalent amplitudes carry `Re x`
            // and only the sign of `Im x`, so take the pile's own sum.
            let (ps, pp, x, ts, tp) = quantities(f, c, nn);
            s.0 += w * ps;
            s.1 += w * pp;
            s.2 += x * w;
            s.3 += w * ts;
            s.4 += w * tp;
        }
        s
    };
    // At the nodes: to rounding (Re x only: a pile's equivalent amplitudes do not carry
    // its Im x).
    for i in [1usize, 200, 1024, 1800, BAND_NODES - 1] {
        let c = i as f64 / (BAND_NODES - 1) as f64;
        let (ps, pp, x, ts, tp) = mean(c, n);
        let (bs, bp) = band.power(c, n);
        let (bts, btp) = band.transmitted(c, n);
        let (rs, rp) = band.amplitudes(c, n);
        for (a, b) in [
            (bs, ps),
            (bp, pp),
            (bts, ts),
            (btp, tp),
            ((rs * rp.conj()).re, x.re),
        ] {
            assert!((a - b).abs() < 1e-13, "node {i}: {a} vs {b}");
        }
    }
    // Between nodes: the linear interpolation.
    for c in [0.1234567, 0.5, 0.77777, 0.99991] {
        let (ps, pp, _, ts, tp) = mean(c, n);
        let (bs, bp) = band.power(c, n);
        let (bts, btp) = band.transmitted(c, n);
        for (a, b) in [(bs, ps), (bp, pp), (bts, ts), (btp, tp)] {
            assert!((a - b).abs() < 1e-6, "cos {c}: {a} vs {b}");
        }
    }
    // Another medium: summed directly.
    for c in [0.3, 0.8] {
        let (ps, pp, _, ts, tp) = mean(c, 1.4);
        let (bs, bp) = band.power(c, 1.4);
        let (bts, btp) = band.transmitted(c, 1.4);
        for (a, b) in [(bs, ps), (bp, pp), (bts, ts), (btp, tp)] {
            assert!((a - b).abs() < 1e-14, "n 1.4, cos {c}: {a} vs {b}");
        }
    }
}

#[test]
fn equivalent_amplitudes_carry_the_bands_powers() {
    let band = FlakeReflectance::band(members(), 1.5).unwrap();
    for i in 0..50 {
        let c = 0.01 + 0.98 * f64::from(i) / 49.0;
        let (rs, rp) = band.amplitudes(c, 1.5);
        let (ps, pp) = band.power(c, 1.5);
        assert!((rs.norm_sqr() - ps).abs() < 1e-13 && (rp.norm_sqr() - pp).abs() < 1e-13);
        // Cauchy–Schwarz holds for the means: |Re x|² ≤ R_s R_p.
        let x = rs * rp.conj();
        assert!(x.re * x.re <= ps * pp * (1.0 + 1e-12));
    }
}

#[test]
fn a_band_of_one_is_its_member() {
    let f = film(2.2, 120.0, 0.0, 550.0);
    let band = FlakeReflectance::band(vec![(0.3, f.clone())], 1.5).unwrap();
    for i in [0usize, 7, 512, 2047, 2048] {
        let c = i as f64 / (BAND_NODES - 1) as f64;
        let (a, b) = (band.power(c, 1.5), f.power(c, 1.5));
        assert!(
            (a.0 - b.0).abs() < 1e-14 && (a.1 - b.1).abs() < 1e-14,
            "{i}"
        );
        let (ra, pa) = band.amplitudes(c, 1.5);
        let (rb, pb) = f.amplitudes(c, 1.5);
        assert!(
            ((ra * pa.conj()).re - (rb * pb.conj()).re).abs() < 1e-14,
            "{i}"
        );
    }
}

#[test]
fn bad_bands_are_refused() {
    let f = film(2.2, 120.0, 0.0, 550.0);
    let cases: Vec<(Vec<(f64, FlakeReflectance)>, f64)> = vec![
        (vec![], 1.5),
        (vec![(-1.0, f.clone())], 1.5),
        (vec![(f64::NAN, f.clone())], 1.5),
        (vec![(0.0, f.clone())], 1.5),
        (vec![(1.0, f.clone())], 0.9),
        (
            vec![(
                1.0,
                FlakeReflectance::band(vec![(1.0, f.clone())], 1.5).unwrap(),
            )],
            1.5,
        ),
    ];
    for (m, n) in cases {
        let e = FlakeReflectance::band(m, n).unwrap_err();
        assert!(e.to_string().contains("channel band"), "{e}");
    }
    let band = FlakeReflectance::band(vec![(1.0, f)], 1.5).unwrap();
    assert!(band.pile(2).is_err());
    assert_eq!(band.pile(1).unwrap(), band);
}
