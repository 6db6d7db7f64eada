//! `model --flake-stack SPEC --base-albedo RHO` (docs/cli.md, physics.md §13 "A base
//! under transmitting flakes"): far from specular, where nearly flat flakes send no light,
//! the BRDF rises over the black base's by the base term derived here for a free lossless
//! film whose facets are all but flat (hwhm 0.3°: the flakes' mean transmittance is the
//! film's own, Airy's formula, at the ray's angle, to ~1e-5); bad values and flakes that
//! transmit nothing exit 2 naming the flag.

mod common;

use std::f64::consts::PI;

use common::{run, run_text, stderr};

const N: f64 = 1.5;
const N_FILM: f64 = 2.4;
const D_NM: f64 = 100.0;
const WL: f64 = 550.0;

/// Unpolarised `(R, T)` of the free lossless film in the binder at the binder cosine
/// `c` (Airy: `R = F sin²δ / (1 + F sin²δ)`, `F = 4r²/(1 − r²)²` per polarisation, `r`
/// the binder-to-film amplitude, `δ = 2π n₁ d cos θ₁/λ`).
fn film(c: f64) -> (f64, f64) {
    let s2 = (1.0 - c * c) * (N / N_FILM).powi(2);
    let c1 = (1.0 - s2).sqrt();
    let rs = (N * c - N_FILM * c1) / (N * c + N_FILM * c1);
    let rp = (N_FILM * c - N * c1) / (N_FILM * c + N * c1);
    let delta = 2.0 * PI * N_FILM * D_NM * c1 / WL;
    let airy = |r: f64| {
        let f = 4.0 * r * r / (1.0 - r * r).powi(2);
        let x = f * delta.sin().powi(2);
        x / (1.0 + x)
    };
    let r = 0.5 * (airy(rs) + airy(rp));
    (r, 1.0 - r)
}

/// Unpolarised transmittance of the coat's surface for the air cosine `co` and the
/// binder cosine `ci`.
fn surface(co: f64, ci: f64) -> f64 {
    let rs = (co - N * ci) / (co + N * ci);
    let rp = (N * co - ci) / (N * co + ci);
    1.0 - 0.5 * (rs * rs + rp * rp)
}

/// The same from inside at the binder cosine `ci` (0 beyond the critical angle).
fn inside(ci: f64) -> f64 {
    let co2 = 1.0 - N * N * (1.0 - ci * ci);
    if co2 <= 0.0 {
        0.0
    } else {
        surface(co2.sqrt(), ci)
    }
}

/// Light going up at binder cosine `c` above the flakes: the shares that leave and that
/// reach the base after the bounces between the surface and the flakes' tops.
fn cavity(c: f64) -> (f64, f64) {
    let (r, t) = film(c);
    let top = inside(c);
    let den = 1.0 - (1.0 - top) * r;
    (top / den, (1.0 - top) * t / den)
}

/// `r̄ = ∫ [R + T B] 2μ dμ` by Simpson in `μ` on both sides of the critical cosine
/// (`μ = μc + (1 − μc) s²` above it).
fn return_fraction() -> f64 {
    let g = |mu: f64| {
        let (r, t) = film(mu);
        (r + t * cavity(mu).1) * 2.0 * mu
    };
    let simpson = |f: &dyn Fn(f64) -> f64, a: f64, b: f64| {
        let k = 4000;
        let h = (b - a) / f64::from(k);
        (0..=k)
            .map(|i| {
                let w = if i == 0 || i == k {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * f(a + h * f64::from(i))
            })
            .sum::<f64>()
            * h
            / 3.0
    };
    let mu_c = (1.0 - 1.0 / (N * N)).sqrt();
    let above = |s: f64| g(mu_c + (1.0 - mu_c) * s * s) * 2.0 * (1.0 - mu_c) * s;
    // Below μ = 1e-4 every ray comes back (R + T B = 1 there: no surface transmission,
    // a lossless film): ∫ 2μ dμ = 1e-8.
    1e-8 + simpson(&g, 1e-4, mu_c) + simpson(&above, 0.0, 1.0)
}

fn brdf(extra: &[&str]) -> Vec<f64> {
    let mut a = vec![
        "model",
        "--flake-stack",
        "2.4+0i:100",
        "--n",
        "1.5",
        "--wavelengths",
        "550",
        "--hwhm",
        "0.3",
        "--theta-i",
        "30",
        "--theta-s",
        "0,20,45,70",
        "--aperture",
        "0",
    ];
    a.extend(extra);
    let o = run(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(5).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn far_from_specular_the_brdf_rises_by_the_base_term() {
    let rho = 0.8;
    let black = brdf(&[]);
    let white = brdf(&["--base-albedo", "0.8"]);
    let r_bar = return_fraction();
    let ti = 30f64.to_radians();
    let ct = (1.0 - (ti.sin() / N).powi(2)).sqrt();
    let reaching = surface(ti.cos(), ct) * film(ct).1;
    for ((ts, b), w) in [0.0f64, 20.0, 45.0, 70.0].iter().zip(&black).zip(&white) {
        let o = ts.to_radians();
        let c2 = (1.0 - (o.sin() / N).powi(2)).sqrt();
        let want = rho * reaching * film(c2).1 * cavity(c2).0 / (PI * N * N * (1.0 - rho * r_bar));
        eprintln!("θs {ts}: rise {:.6e}, derived {want:.6e}", w - b);
        assert!(b.abs() < 1e-12, "{b}");
        assert!(
            ((w - b) - want).abs() < 1e-4 * want,
            "θs {ts}: {} vs {want}",
            w - b
        );
    }
}

#[test]
fn bad_base_albedos_are_refused_naming_the_flag() {
    let stack = ["model", "--flake-stack", "TiO2:100", "--wavelengths", "550"];
    for v in ["-0.1", "1.5", "NaN", "inf", "0.2,0.3", "white"] {
        let mut a = stack.to_vec();
        a.extend(["--base-albedo", v]);
        let (code, _, err) = run_text(&a);
        assert_eq!(code, 2, "{v}: {err}");
        assert!(
            err.contains("--base-albedo") && err.contains("[0, 1]"),
            "{err}"
        );
    }
    for a in [
        vec![
            "model",
            "--flake-index",
            "0.96,6.69",
            "--base-albedo",
            "0.5",
        ],
        vec!["model", "--base-albedo", "0.5"],
        vec![
            "model",
            "--flake-stack",
            "TiO2:100",
            "--flake-core",
            "aluminium",
            "--base-albedo",
            "0.5",
        ],
        vec![
            "model",
            "--flake-stack",
            "TiO2:100",
            "--wavelengths",
            "550",
            "--polarization",
            "mueller",
            "--base-albedo",
            "0.5",
        ],
        vec![
            "compare",
            "--measured",
            "absent.csv",
            "--base-albedo",
            "0.5",
        ],
        vec![
            "export",
            "--format",
            "merl",
            "--base-albedo",
            "0.5",
            "--out",
            "absent/x.binary",
        ],
    ] {
        let (code, _, err) = run_text(&a);
        assert_eq!(code, 2, "{a:?}: {err}");
        assert!(err.contains("--base-albedo"), "{a:?}: {err}");
    }
}
