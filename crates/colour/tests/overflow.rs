//! Colour steps at the edges of the doubles (issue 52, item 11): a spectrum near 1e308
//! gave empty cells and ΔE2000 = 0, one at 1e300 ΔE*ab 1.16e102 beside ΔE2000 0.00.
//! Now XYZ that exist as doubles are computed (the sums scaled when they would overflow
//! on the way), XYZ that do not are an error naming the largest reflectance factor, and
//! every colour difference of two finite colours is a number (never NaN, never 0 for
//! different colours).
//!
//! Expected values: XYZ is linear in the spectrum (`X = Σ Wx R`), so `XYZ(k R) =
//! k XYZ(R)`; ΔE*ab is homogeneous of degree 1; the limits of CIEDE2000 and of CIE94/k
//! for pairs scaled by `k → ∞` are colour-science 0.4.7's values at `k = 1e40`
//! (`tests/data/README.md`, `colour_science_extreme_delta_e.csv`).

use flakescatter_colour::{
    Cie94, ColourError, Illuminant, Lab, Observer, TristimulusWeights, delta_e_94, delta_e_2000,
    delta_e_ab,
};

fn weights() -> (Vec<f64>, TristimulusWeights) {
    let wl: Vec<f64> = (0..=40).map(|i| 380.0 + 10.0 * f64::from(i)).collect();
    let w = TristimulusWeights::new(&wl, Illuminant::D65, Observer::Cie1964TenDegree).unwrap();
    (wl, w)
}

/// A smooth non-flat spectrum (a reddish metallic), values of order 1.
fn shape(l: f64) -> f64 {
    0.3 + 0.8 / (1.0 + (-(l - 600.0) / 20.0).exp())
}

#[test]
fn xyz_is_linear_up_to_the_largest_double_and_an_error_beyond() {
    let (wl, w) = weights();
    let base: Vec<f64> = wl.iter().map(|&l| shape(l)).collect();
    let xyz1 = w.xyz(&base).unwrap();
    // Y of the base is between 40 and 110, so Y = 1e306 × that stays a double, and the
    // weighted sums on the way are scaled where they would not (1.7e306 × 41 samples).
    for k in [1e250, 1e300, 1e305, 1.7e306] {
        let scaled: Vec<f64> = base.iter().map(|r| r * k).collect();
        let got = w.xyz(&scaled).unwrap_or_else(|e| panic!("k = {k:e}: {e}"));
        for (g, b) in [(got.x, xyz1.x), (got.y, xyz1.y), (got.z, xyz1.z)] {
            assert!(g.is_finite(), "k = {k:e}: {got:?}");
            assert!(
                (g / (k * b) - 1.0).abs() < 1e-13,
                "k = {k:e}: {g:e} vs {:e}",
                k * b
            );
        }
        let lab = w.lab(&scaled).unwrap();
        assert!(lab.l.is_finite() && lab.a.is_finite() && lab.b.is_finite());
        // L* = 116 (Y/Yn)^(1/3) − 16 with Y/Yn = k Y1/100.
        let want = 116.0 * (k * xyz1.y / 100.0).cbrt() - 16.0;
        assert!((lab.l / want - 1.0).abs() < 1e-13, "{} vs {want}", lab.l);
    }
    // Y = 100 × 1e307-ish does not exist in doubles: an error naming the largest factor
    // and its wavelength, not infinities or empty cells.
    let mut big = base.clone();
    big[22] = 1e308; // 600 nm
    let e = w.xyz(&big).unwrap_err();
    assert_eq!(
        e,
        ColourError::TristimulusOverflow {
            wavelength_nm: 600.0,
            value: 1e308
        }
    );
    let text = e.to_string();
    assert!(
        text.contains("1e308 at 600 nm") && text.contains("largest double"),
        "{text}"
    );
    assert!(matches!(
        w.lab(&vec![1e308; wl.len()]),
        Err(ColourError::TristimulusOverflow { .. })
    ));
}

/// `(name, lab1, lab2, ΔE00 limit, ΔE94/k limit, ΔE*ab)`: one row of the table.
type Pair = (String, [f64; 3], [f64; 3], f64, f64, f64);

/// The pairs of the colour-science table.
fn pairs() -> Vec<Pair> {
    let text = include_str!("data/colour_science_extreme_delta_e.csv");
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let n = |i: usize| f[i].parse::<f64>().unwrap();
            (
                f[0].to_owned(),
                [n(1), n(2), n(3)],
                [n(4), n(5), n(6)],
                n(7),
                n(8),
                n(9),
            )
        })
        .collect()
}

fn lab(v: [f64; 3], k: f64) -> Lab {
    Lab::new(v[0] * k, v[1] * k, v[2] * k).unwrap()
}

#[test]
fn colour_differences_of_huge_colours_are_their_limits_never_nan_or_zero() {
    let rows = pairs();
    assert_eq!(rows.len(), 5);
    for (name, p, q, e00, e94, eab) in rows {
        // k = 1e40 takes the published formulas as written; from 1e60 on C⁷ overflows,
        // from 1e160 the squares of L and of the differences too.
        for k in [1e40, 1e60, 1e100, 1e160, 1e200, 1e300] {
            let (a, b) = (lab(p, k), lab(q, k));
            let d00 = delta_e_2000(&a, &b);
            assert!(
                (d00 - e00).abs() <= 1e-9 * e00,
                "{name}, k = {k:e}: ΔE00 {d00} vs the limit {e00}"
            );
            let d94 = delta_e_94(&a, &b, Cie94::GRAPHIC_ARTS);
            assert!(
                d94.is_finite() && d94 > 0.0,
                "{name}, k = {k:e}: ΔE94 {d94}"
            );
            assert!(
                (d94 / k - e94).abs() <= 1e-9 * e94.max(1.0),
                "{name}, k = {k:e}: ΔE94/k {} vs {e94}",
                d94 / k
            );
            let dab = delta_e_ab(&a, &b);
            assert!(
                (dab / (k * eab) - 1.0).abs() < 1e-14,
                "{name}, k = {k:e}: ΔE*ab {dab:e} vs {:e}",
                k * eab
            );
        }
    }
}

#[test]
fn no_colour_difference_of_finite_colours_is_nan() {
    // Extreme but finite colours against ordinary ones and each other: every difference
    // is a number > 0 (or +inf where the difference itself exceeds the doubles).
    let values = [
        -1.7e308, -1e200, -1e40, -1.0, 0.0, 1e-300, 1.0, 50.0, 1e40, 1e154, 1e200, 1.7e308,
    ];
    let mut n = 0;
    for &l in &values {
        for &a in &values {
            for &b in &[0.0, -1e200, 1e100] {
                let x = Lab::new(l, a, b).unwrap();
                let y = Lab::new(50.0, 10.0, -10.0).unwrap();
                for d in [
                    delta_e_ab(&x, &y),
                    delta_e_94(&x, &y, Cie94::GRAPHIC_ARTS),
                    delta_e_94(&y, &x, Cie94::GRAPHIC_ARTS),
                    delta_e_2000(&x, &y),
                ] {
                    assert!(!d.is_nan() && d > 0.0, "{x:?} vs {y:?}: {d}");
                    n += 1;
                }
            }
        }
    }
    assert_eq!(n, 12 * 12 * 3 * 4);
}

#[test]
fn a_huge_lightness_difference_alone_is_still_a_difference() {
    // ΔL* = 2e200, whose square overflows, and nothing else: ΔE*ab = ΔE94 = |ΔL*|
    // (weight 1), CIEDE2000 = |ΔL*|/S_L with L̄ = 0: S_L = 1 + 0.015·2500/√2520.
    let x = Lab::new(1e200, 0.0, 0.0).unwrap();
    let y = Lab::new(-1e200, 0.0, 0.0).unwrap();
    assert_eq!(delta_e_ab(&x, &y), 2e200);
    assert_eq!(delta_e_94(&x, &y, Cie94::GRAPHIC_ARTS), 2e200);
    let s_l = 1.0 + 0.015 * 2500.0 / 2520f64.sqrt();
    let d = delta_e_2000(&x, &y);
    assert!((d / (2e200 / s_l) - 1.0).abs() < 1e-14, "{d}");
}

#[test]
fn a_hue_difference_at_a_huge_chroma_is_not_lost() {
    // C*ab = 1e160, so (kH·SH)² = (1 + 0.015·1e160)² overflows; b* differs by 1e150 and
    // nothing else does to double precision (C*ab of the sample is 1e160·√(1 + 1e-20),
    // 1e160 in doubles), so ΔE94 = ΔH*/(kH·SH) = 1e150 / (1 + 0.015e160) (kH = 1).
    // Dividing ΔH*² by the overflowed square once gave 0.
    let x = Lab::new(50.0, 1e160, 0.0).unwrap();
    let y = Lab::new(50.0, 1e160, 1e150).unwrap();
    let want = 1e150 / (1.0 + 0.015 * 1e160);
    let d = delta_e_94(&x, &y, Cie94::GRAPHIC_ARTS);
    assert!((d / want - 1.0).abs() < 1e-12, "{d} against {want}");
}
