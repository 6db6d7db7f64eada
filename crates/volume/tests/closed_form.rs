//! Closed forms: a horizontal mirror layer under the film's top interface.
//!
//! Derivation. A ray enters at `θi` with polarisation channel weights `½ T_s`, `½ T_p`
//! (`T = T(θi)`, Fresnel power transmittance air → film). A horizontal mirror of
//! reflectance `R_m` (per channel) sends it back up at the inside angle `θt`; at the top
//! interface the channel escapes with `T(θi)` again (the same power transmittance both
//! ways for the Snell pair) into the specular direction, and `R_in = 1 − T` of it is
//! reflected back down, to meet the mirror again at the same angle. So each channel
//! leaves as the geometric series
//!
//! `E = ½ T² R_m Σ_{k≥0} (R_in R_m)^k = ½ T² R_m / (1 − R_in R_m)`,
//!
//! of which the `k = 0` term is the single bounce and the rest the multiple bounces, and
//! the mirror absorbs `A = ½ T (1 − R_m) / (1 − R_in R_m)`. The clear coat reflects
//! `½ (R_s + R_p)` exactly.
//!
//! * With no flakes and a specular substrate of reflectance `R`, every ray follows this
//!   series: the result is deterministic.
//! * With one flat flake in the tile at a depth where one round trip
//!   (flake → top → flake) shifts the ray by exactly one tile width,
//!   `2 h tan θt = L`, a ray that meets the flake's top face meets it again at the same
//!   place after each internal reflection (the tile is periodic). The fraction of rays
//!   that meet it is binomial with `p = π r² / L²` (a horizontal disc's shadow along any
//!   direction on a horizontal plane is the disc itself); every such ray carries the
//!   series exactly, so the ratio multiple/single is exact.

use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel;
use flakescatter_optics::{UnitVec3, Vec3, refraction};
use flakescatter_volume::{Flake, Layer, RimRule, Substrate, TraceOptions, Tracer};

/// Per channel `(T, R_m)` → `(single, multiple, absorbed by the mirror)` of the series.
fn series(t: f64, r_m: f64) -> (f64, f64, f64) {
    let r_in = 1.0 - t;
    let q = r_in * r_m;
    let single = 0.5 * t * t * r_m;
    let all = 0.5 * t * t * r_m / (1.0 - q);
    (single, all - single, 0.5 * t * (1.0 - r_m) / (1.0 - q))
}

#[test]
fn specular_substrate_gives_the_geometric_series_exactly() {
    let layer = Layer::from_flakes(20.0, 50.0, Vec::new()).unwrap();
    let n = 1.5;
    let r = 0.85;
    let options = TraceOptions {
        n,
        substrate: Substrate::Specular(r),
        rays: 640,
        min_weight: 1e-16,
        max_events: 5000,
        ..TraceOptions::default()
    };
    let tracer = Tracer::new(&layer, options).unwrap();
    let angles = [0.0f64, 30.0, 60.0, 75.0].map(f64::to_radians);
    let alpha = 1f64.to_radians();
    let cones: Vec<Cone> = angles
        .iter()
        .map(|&t| Cone::in_plane(-t, alpha).unwrap())
        .collect();
    let res = tracer.run(&angles, &cones).unwrap();
    for (i, &ti) in angles.iter().enumerate() {
        let f = fresnel::air_to_coating(ti, n);
        let (ss, ms, as_) = series(f.ts, r);
        let (sp, mp, ap) = series(f.tp, r);
        // No flake: all that escapes met the substrate (multiple, via substrate).
        let escaped = ss + ms + sp + mp;
        // The substrate absorbs (1 − R) of what reaches it: `A` with R_m = R.
        let absorbed = as_ + ap;
        let e = &res.energy[i];
        eprintln!(
            "θi {:.0}: escaped {:.15} expected {escaped:.15}",
            ti.to_degrees(),
            e.escaped_multiple
        );
        assert!((e.coat_reflected - f.r_av()).abs() < 1e-15);
        assert_eq!(e.escaped_single, 0.0);
        assert!((e.escaped_multiple - escaped).abs() < 1e-12);
        assert!((e.escaped_via_substrate - escaped).abs() < 1e-12);
        assert!((e.absorbed_substrate - absorbed).abs() < 1e-12);
        assert!(e.cut_off < 1e-16, "cut off {}", e.cut_off);
        // Everything goes into the specular cone of incidence i (and nowhere else).
        let p = &res.points[i * cones.len() + i];
        let proj = p.cone.projected_solid_angle();
        assert!((p.reflectance - (f.r_av() + escaped)).abs() < 1e-12);
        assert!((p.multiple_brdf * proj - escaped).abs() < 1e-12);
        assert_eq!(
            p.multiple_std_err, 0.0,
            "deterministic rays have no scatter"
        );
        for (j, q) in res.points[i * cones.len()..(i + 1) * cones.len()]
            .iter()
            .enumerate()
        {
            if j != i {
                assert_eq!(q.reflectance, 0.0);
            }
        }
    }
}

/// One flat flake whose round trip shifts the ray by one tile width at `theta_i`,
/// centred at `(x, y)`.
fn returning_flake(
    theta_i: f64,
    n: f64,
    tile: f64,
    radius: f64,
    thickness: f64,
    x: f64,
    y: f64,
) -> Flake {
    let k1 = refraction::into_coating(&detector::incident_direction(theta_i), n);
    let tan_t = k1.x / -k1.z;
    let h_top = if tan_t > 0.0 {
        tile / (2.0 * tan_t)
    } else {
        5.0
    };
    Flake {
        centre: Vec3::new(x, y, -(h_top + 0.5 * thickness)),
        normal: UnitVec3::new_normalize(Vec3::z()),
        radius_um: radius,
        thickness_um: thickness,
    }
}

fn check_returning_flake(theta_i: f64, flake_r: FlakeReflectance, rims: RimRule, x: f64, y: f64) {
    let n = 1.5;
    let (tile, radius, thickness) = (20.0, 8.0, 0.5);
    let flake = returning_flake(theta_i, n, tile, radius, thickness, x, y);
    let layer = Layer::from_flakes(40.0, tile, vec![flake]).unwrap();
    let rays = 64 * 4000;
    let options = TraceOptions {
        n,
        flake: flake_r.clone(),
        rims,
        rays,
        seed: 11,
        // Paths end below 1e-16 of a ray's power: negligible against the 1e-12 checks.
        min_weight: 1e-16,
        max_events: 5000,
        ..TraceOptions::default()
    };
    let tracer = Tracer::new(&layer, options).unwrap();
    let cone = Cone::in_plane(-theta_i, 1f64.to_radians()).unwrap();
    let res = tracer.run(&[theta_i], &[cone]).unwrap();
    let f = fresnel::air_to_coating(theta_i, n);
    // The flake is met at the inside angle θt: local incidence cosine cos θt.
    let cos_t = refraction::snell_inside(theta_i, n).cos();
    let (rms, rmp) = flake_r.power(cos_t, n);
    let (ss, ms, as_) = series(f.ts, rms);
    let (sp, mp, ap) = series(f.tp, rmp);
    let e = &res.energy[0];
    // Exact per ray that meets the flake: the ratios do not depend on how many did.
    let ratio = e.escaped_multiple / e.escaped_single;
    let expected_ratio = (ms + mp) / (ss + sp);
    eprintln!(
        "θi {:.0}°: multiple/single {ratio:.15} expected {expected_ratio:.15}",
        theta_i.to_degrees()
    );
    assert!((ratio / expected_ratio - 1.0).abs() < 1e-12);
    let absorbed_ratio = e.absorbed_flakes / e.escaped_single;
    let expected_absorbed = (as_ + ap) / (ss + sp);
    assert!((absorbed_ratio - expected_absorbed).abs() < 1e-12 * expected_absorbed.max(1.0));
    // The fraction of rays that met the flake is binomial with p = π r² / L².
    let p = std::f64::consts::PI * radius * radius / (tile * tile);
    let hit = e.escaped_single / (ss + sp);
    let sd = (p * (1.0 - p) / res.rays_per_incidence as f64).sqrt();
    eprintln!("hit fraction {hit:.5} expected {p:.5} ± {sd:.5}");
    assert!(
        (hit - p).abs() < 4.0 * sd,
        "hit fraction {hit} vs {p} ± {sd}"
    );
    // The batch standard error of the single-bounce part estimates that binomial error.
    let point = &res.points[0];
    let proj = cone.projected_solid_angle();
    let se_expected = sd * (ss + sp);
    let se = point.single_std_err * proj;
    assert!(
        (se / se_expected - 1.0).abs() < 0.3,
        "batch se {se:.3e} vs binomial {se_expected:.3e}"
    );
    // All escapes go into the specular cone.
    assert!((point.single_brdf * proj - e.escaped_single).abs() < 1e-15);
    assert!((point.multiple_brdf * proj - e.escaped_multiple).abs() < 1e-15);
    assert!((point.coat_brdf * proj - f.r_av()).abs() < 1e-15);
    assert!((e.total() - 1.0).abs() < 1e-12);
}

#[test]
fn one_flat_flake_gives_the_series_at_normal_incidence() {
    check_returning_flake(
        0.0,
        FlakeReflectance::PerfectConductor,
        RimRule::Absorb,
        10.0,
        10.0,
    );
}

#[test]
fn one_flat_flake_across_the_tile_corner_gives_the_same_series() {
    // The tile is periodic: a flake centred near a corner, cut by two sides, is the same
    // layer shifted. (The column grid here is one column wide, so each column holds
    // several images of the flake.)
    check_returning_flake(
        45f64.to_radians(),
        FlakeReflectance::aluminium_550nm(),
        RimRule::Absorb,
        1.0,
        19.5,
    );
    check_returning_flake(
        0.0,
        FlakeReflectance::PerfectConductor,
        RimRule::Diffuse,
        19.0,
        0.5,
    );
}

#[test]
fn one_flat_flake_gives_the_series_at_oblique_incidence_per_polarisation() {
    // Aluminium: R_s ≠ R_p at 28° inside, and T_s ≠ T_p at 45°, so s and p must be
    // carried apart for the ratio to hold.
    check_returning_flake(
        45f64.to_radians(),
        FlakeReflectance::aluminium_550nm(),
        RimRule::Absorb,
        10.0,
        10.0,
    );
    check_returning_flake(
        60f64.to_radians(),
        FlakeReflectance::PerfectConductor,
        RimRule::Ignore,
        10.0,
        10.0,
    );
}
