//! The base under a map's flakes (physics.md §13, "The base under a map's flakes"),
//! against the term derived here.
//!
//! The map is one tilted plane `z = x tan β`: every usable pixel's normal is at the tilt
//! `β`, so a ray meets facets at `β` at every azimuth, weighted by the area each shows
//! it (`γ⁺`). For a free lossless film (Airy's formula, written here) in the binder:
//!
//! * `τ(θ) = ∫ T(γ) γ⁺ dφ / ∫ γ⁺ dφ`, `γ = cos θ cos β + sin θ sin β cos φ`, and
//!   `ρ̄ = 1 − τ` (lossless, the same from both sides);
//! * the cavity: light going up at `θ` leaves with `E = T_top/(1 − (1 − T_top) ρ̄)` and
//!   reaches the base with `B = (1 − T_top) τ/(1 − (1 − T_top) ρ̄)`;
//! * the loop: `r̄ = ∫ [ρ̄ + τ B] sin 2θ dθ`;
//! * `f_base = ρ T_top(θi) τ(θt) τ(θ2) E(θ2) / (π n² (1 − ρ r̄))`, integrated over each
//!   detector cone (`∫ f cos θr dΩ`, Gauss–Legendre in the cone's polar offset and
//!   azimuth);
//! * times the usable-pixel coverage, counted here from the mask (a pixel is usable when
//!   its whole 5 × 5 window is inside the map and valid).
//!
//! What the base adds to each row's reflectance must be that (to 2e-5 relative: the
//! pixel distribution is binned at 1°, β sits mid-bin, and the bin's spread changes `τ`
//! at second order), the flakes' own light unchanged; the standard error grows by the
//! term times `sqrt(T/(T − 1) Σ (u_t − ū)²)/N_pixels` over the tiles' usable counts
//! `u_t`, counted here too.

use std::f64::consts::PI;

use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::nalgebra::Complex;
use flakescatter::optics::thinfilm::{FilmStack, Layer};
use flakescatter::stats::HeightMap;
use flakescatter::{Coating, DetectorSet, Instrument, Settings, TopoSettings, topographic_curves};

const N: f64 = 1.5;
const N_FILM: f64 = 2.2;
const D_NM: f64 = 130.0;
const WL: f64 = 600.0;
const RHO: f64 = 0.7;
/// Tilt of the plane, degrees (mid-bin of the 1° bins).
const BETA_DEG: f64 = 10.5;
const NX: usize = 96;
const NY: usize = 96;
const PITCH: f64 = 0.5;
const TILE_UM: f64 = 8.0;

/// Gauss–Legendre nodes and weights on `[a, b]` (Newton on the Legendre polynomial).
fn gauss_legendre(n: usize, a: f64, b: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            (0.5 * (a + b) + 0.5 * (b - a) * x, 0.5 * (b - a) * w)
        })
        .collect()
}

/// Unpolarised transmittance of the free lossless film in the binder at the local
/// cosine `c` (Airy: `R = F sin²δ / (1 + F sin²δ)`, `F = 4r²/(1 − r²)²` per
/// polarisation, `δ = 2π n₁ d cos θ₁/λ`).
fn film_t(c: f64) -> f64 {
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
    1.0 - 0.5 * (airy(rs) + airy(rp))
}

/// Unpolarised transmittance of the coat's surface between the air cosine `co` and the
/// binder cosine `ci`.
fn surface(co: f64, ci: f64) -> f64 {
    let rs = (co - N * ci) / (co + N * ci);
    let rp = (N * co - ci) / (N * co + ci);
    1.0 - 0.5 * (rs * rs + rp * rp)
}

/// The surface seen from inside at the binder cosine `ci` (0 beyond the critical angle).
fn inside(ci: f64) -> f64 {
    let co2 = 1.0 - N * N * (1.0 - ci * ci);
    if co2 <= 0.0 {
        0.0
    } else {
        surface(co2.sqrt(), ci)
    }
}

/// `τ(θ)` for facets at the tilt β, from the binder cosine `c` of the ray.
fn tau(c: f64) -> f64 {
    let beta = BETA_DEG.to_radians();
    let s = (1.0 - c * c).max(0.0).sqrt();
    let (a, b) = (c * beta.cos(), s * beta.sin());
    // γ ≥ 0 on φ ∈ [0, φ_end] (symmetric about 0).
    let end = if b <= a { PI } else { (-a / b).acos() };
    let (mut num, mut den) = (0.0, 0.0);
    for (phi, w) in gauss_legendre(96, 0.0, end) {
        let g = (a + b * phi.cos()).max(0.0);
        num += w * g * film_t(g.max(1e-12));
        den += w * g;
    }
    num / den
}

/// `(E, B)` for light going up at binder cosine `c` (module docs).
fn cavity(c: f64) -> (f64, f64) {
    let t = tau(c);
    let top = inside(c);
    let den = 1.0 - (1.0 - top) * (1.0 - t);
    (top / den, (1.0 - top) * t / den)
}

/// `r̄ = ∫ [ρ̄ + τ B] 2μ dμ`, Gauss–Legendre in `μ` on both sides of the critical cosine
/// and of the cosine where the facets' backs come into view (`θ = 90° − β`).
fn return_fraction() -> f64 {
    let mu_c = (1.0 - 1.0 / (N * N)).sqrt();
    let mu_b = (90f64 - BETA_DEG).to_radians().cos();
    let mut sum = 0.0;
    for (a, b) in [(0.0, mu_b), (mu_b, mu_c), (mu_c, 1.0)] {
        for (mu, w) in gauss_legendre(64, a, b) {
            let t = tau(mu);
            sum += w * 2.0 * mu * ((1.0 - t) + t * cavity(mu).1);
        }
    }
    sum
}

/// `∫_cone f_base cos θr dΩ` for the cone of half-angle `alpha` about the polar angle
/// `theta_r`, at incidence `theta_i` (module docs).
fn base_cone(theta_i: f64, theta_r: f64, alpha: f64, gain: f64) -> f64 {
    let ct = (1.0 - (theta_i.sin() / N).powi(2)).sqrt();
    let reaching = surface(theta_i.cos(), ct) * tau(ct);
    let f = |rz: f64| {
        let c2 = (N * N - 1.0 + rz * rz).sqrt() / N;
        gain * reaching * tau(c2) * cavity(c2).0
    };
    let (st, ctr) = theta_r.sin_cos();
    let mut sum = 0.0;
    for (u, wu) in gauss_legendre(12, 0.0, alpha) {
        for (psi, wp) in gauss_legendre(24, 0.0, 2.0 * PI) {
            // The polar cosine of the direction at offset u, azimuth ψ about the axis.
            let rz = ctr * u.cos() - st * u.sin() * psi.cos();
            sum += wu * wp * u.sin() * f(rz) * rz;
        }
    }
    sum
}

/// The plane `z = x tan β` with a block of missing points.
fn map() -> HeightMap {
    let slope = BETA_DEG.to_radians().tan();
    let z = (0..NX * NY)
        .map(|i| {
            let (col, row) = (i % NX, i / NX);
            if (20..50).contains(&row) && (10..40).contains(&col) {
                f64::NAN
            } else {
                col as f64 * PITCH * slope
            }
        })
        .collect();
    HeightMap::new(NX, NY, PITCH, PITCH, z).unwrap()
}

/// Usable pixels per statistics tile (tiles of `TILE_UM / PITCH` pixels, row-major),
/// counted from the mask.
fn usable_per_tile(m: &HeightMap) -> Vec<u64> {
    let side = (TILE_UM / PITCH).round() as usize;
    let (tx, ty) = (NX.div_ceil(side), NY.div_ceil(side));
    let mut counts = vec![0u64; tx * ty];
    let z = m.heights();
    for row in 2..NY - 2 {
        for col in 2..NX - 2 {
            let whole =
                (row - 2..=row + 2).all(|r| (col - 2..=col + 2).all(|c| z[r * NX + c].is_finite()));
            if whole {
                counts[(row / side) * tx + col / side] += 1;
            }
        }
    }
    counts
}

fn film() -> Coating {
    let layer = Layer::new(Complex::new(N_FILM, 0.0), D_NM).unwrap();
    Coating {
        n: N,
        flake: FlakeReflectance::stack(FilmStack::new(vec![layer]).unwrap(), WL, None).unwrap(),
    }
}

#[test]
fn a_tilted_plane_adds_the_derived_base_term_times_its_coverage() {
    let m = map();
    let alpha = 2f64.to_radians();
    let dets: Vec<(f64, f64)> = [
        (0.0, 0.0),
        (20.0, 0.0),
        (40.0, 90.0),
        (60.0, 180.0),
        (75.0, 45.0),
    ]
    .iter()
    .map(|&(t, p): &(f64, f64)| (t.to_radians(), p.to_radians()))
    .collect();
    let inst = Instrument::new(
        vec![30f64.to_radians(), 60f64.to_radians()],
        DetectorSet::OutOfPlane(dets.clone()),
        alpha,
    )
    .unwrap();
    let topo = TopoSettings {
        window: 5,
        tile_um: TILE_UM,
    };
    let black = Settings::default();
    let based = Settings {
        base_albedo: RHO,
        ..Settings::default()
    };
    let (bk, rb) = topographic_curves(&film(), &inst, &black, &topo, &[&m], &|_, _| {}).unwrap();
    let (wh, rw) = topographic_curves(&film(), &inst, &based, &topo, &[&m], &|_, _| {}).unwrap();

    let tiles = usable_per_tile(&m);
    let usable: u64 = tiles.iter().sum();
    let pixels = (NX * NY) as u64;
    assert_eq!(rw.usable_pixels, usable);
    assert_eq!(rw.tiles, tiles.len() as u64);
    let coverage = usable as f64 / pixels as f64;
    let t = tiles.len() as f64;
    let mean = usable as f64 / t;
    let spread = (t / (t - 1.0)
        * tiles
            .iter()
            .map(|&u| (u as f64 - mean).powi(2))
            .sum::<f64>())
    .sqrt()
        / pixels as f64;
    let gain = RHO / (PI * N * N * (1.0 - RHO * return_fraction()));

    let mut worst = 0f64;
    for ((b, w), (pb, pw)) in bk
        .rows
        .iter()
        .zip(&wh.rows)
        .zip(rb.points.iter().zip(&rw.points))
    {
        let (theta_r, _) = dets[b.detector];
        let expected = coverage * base_cone(b.theta_i, theta_r, alpha, gain);
        let added = w.reflectance.unwrap() - b.reflectance.unwrap();
        let rel = (added - expected).abs() / expected;
        worst = worst.max(rel);
        assert!(
            rel < 2e-5,
            "θi {:.0}°, θr {:.0}°: added {added:e}, derived {expected:e} (rel {rel:e})",
            b.theta_i.to_degrees(),
            theta_r.to_degrees()
        );
        // The flakes' rays are those of the black base's run.
        assert_eq!(w.rays, b.rays);
        // The standard error grows by the term's share of the usable pixels' spread.
        let se_added = pw.reflectance_std_err.unwrap() - pb.reflectance_std_err.unwrap_or(0.0);
        let se_expected = expected / coverage * spread;
        assert!(
            (se_added - se_expected).abs() <= 2e-5 * se_expected,
            "std err added {se_added:e}, derived {se_expected:e}"
        );
        assert!(
            (w.brdf - pw.reflectance / pw.cone.projected_solid_angle()).abs() <= 1e-15 * w.brdf
        );
    }
    eprintln!("worst relative difference {worst:e}");
    assert!(wh.source.contains("albedo 0.7"), "{}", wh.source);
}

#[test]
fn zero_albedo_is_the_black_base_to_the_bit() {
    let m = map();
    let inst = Instrument::new(
        vec![45f64.to_radians()],
        DetectorSet::OutOfPlane(vec![(0.3, 0.0), (0.8, 1.0)]),
        2f64.to_radians(),
    )
    .unwrap();
    let topo = TopoSettings::default();
    let zero = Settings {
        base_albedo: 0.0,
        ..Settings::default()
    };
    let (a, _) = topographic_curves(
        &film(),
        &inst,
        &Settings::default(),
        &topo,
        &[&m],
        &|_, _| {},
    )
    .unwrap();
    let (b, _) = topographic_curves(&film(), &inst, &zero, &topo, &[&m], &|_, _| {}).unwrap();
    // Debug text: `relative` is NaN where the specular cone gets nothing.
    assert_eq!(format!("{:?}", a.rows), format!("{:?}", b.rows));
    assert_eq!(a.source, b.source);
}
