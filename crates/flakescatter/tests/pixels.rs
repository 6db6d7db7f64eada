//! Where the orientation width comes from (physics.md §5.2): on synthetic layers whose
//! flake tilts and surface roughness are known, the flake-level width (segmented
//! flakes) recovers the flakes' width, and the pixel-level width of the pixels inside
//! flakes exceeds it by the roughness's slope spread as the 5 × 5 fit sees it.
//!
//! Expected roughness term, derived here from the generator's documented field (not from
//! the code under test): the roughness is a Gaussian field with covariance
//! `C(Δ) = σr² exp(−|Δ|²/ℓ²)` (`flakescatter_synth`, module `field`). The window fit's
//! x slope is linear in the heights, `a = Σ_(i,j) i z_ij / (k dx S)` (physics.md §5,
//! `S = Σ i² = 10` for `k = 5`), so its variance is
//! `Var a = Σ_(i,j) Σ_(i',j') i i' C((i − i') dx, (j − j') dy) / (k dx S)²`, and the same
//! for `b`. For small angles the pixel tilt vector is the flake's plus the roughness
//! slope, independent, so mean square tilts add: `2 s_inside² ≈ 2 s_flake² + 2 Var a`,
//! i.e. the within-flake spread `sqrt(s_inside² − s_flake²)` is `sqrt(Var a)` (flakes
//! weighted like the pixels). Segmentation is told the roughness as its height noise,
//! so that it does not cut rough flakes into pieces.

use flakescatter::stats::distribution::{GaussianWidth, Orientation};
use flakescatter::stats::segment::SegmentParams;
use flakescatter::synth::{LayerParams, LayerSpec, generate};
use flakescatter::{TopoSettings, pixel_orientation, width_sources};

const DX: f64 = 0.18;

fn layer(hwhm_deg: f64, rms_um: f64, ell_um: f64, seed: u64) -> flakescatter::stats::HeightMap {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
    let mut spec = LayerSpec::new(512, 512, o, seed);
    spec.roughness.rms_um = rms_um;
    spec.roughness.correlation_um = ell_um;
    spec.confocal.z_step_um = 0.0;
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    let mut map = layer.height;
    map.apply_intensity_cutoff(&layer.intensity, 0.49).unwrap();
    map
}

/// `Var a` of the 5 × 5 fit for the Gaussian covariance (module docs).
fn window_slope_variance(rms_um: f64, ell_um: f64) -> f64 {
    let (h, k, s) = (2i32, 5.0, 10.0);
    let mut v = 0.0;
    for i in -h..=h {
        for j in -h..=h {
            for i2 in -h..=h {
                for j2 in -h..=h {
                    let (dx, dy) = (f64::from(i - i2) * DX, f64::from(j - j2) * DX);
                    let c = rms_um * rms_um * (-(dx * dx + dy * dy) / (ell_um * ell_um)).exp();
                    v += f64::from(i * i2) * c;
                }
            }
        }
    }
    v / (k * DX * s).powi(2)
}

#[test]
fn pixel_width_exceeds_flake_width_by_the_roughness() {
    let (hwhm, rms, ell) = (5.0, 0.04, 1.5);
    let maps: Vec<_> = (0..4).map(|k| layer(hwhm, rms, ell, 300 + k)).collect();
    let refs: Vec<_> = maps.iter().collect();
    let w = width_sources(
        &refs,
        &SegmentParams::for_instrument(0.0, rms),
        &TopoSettings::default(),
    )
    .unwrap();
    let truth = GaussianWidth::Hwhm(hwhm.to_radians()).sigma();
    let rough = window_slope_variance(rms, ell).sqrt();
    eprintln!(
        "flakes {}: s_flake {:.3}° [{:.3}, {:.3}] (truth {:.3}°); inside pixels {}: s {:.3}° [{:.3}, {:.3}]; all pixels {:?}",
        w.flakes,
        w.flake.sigma.to_degrees(),
        w.flake.sigma_ci95.0.to_degrees(),
        w.flake.sigma_ci95.1.to_degrees(),
        truth.to_degrees(),
        w.inside.pixels,
        w.inside.sigma.to_degrees(),
        w.inside.sigma_ci95.0.to_degrees(),
        w.inside.sigma_ci95.1.to_degrees(),
        w.pixel.map(|p| p.sigma.to_degrees()),
    );
    eprintln!(
        "within-flake spread {:?}°, expected sqrt(Var a) = {:.3}°",
        w.within_flake_sigma.map(f64::to_degrees),
        rough.to_degrees()
    );
    assert!(w.flakes > 200, "{}", w.flakes);
    // The flakes recover the generator's width.
    assert!(w.flake.sigma_ci95.0 < truth && truth < w.flake.sigma_ci95.1);
    // The pixels inside flakes are wider by the roughness, to 10 %.
    let within = w.within_flake_sigma.unwrap();
    assert!((within - rough).abs() < 0.1 * rough, "{within} vs {rough}");
    // A smooth control: the same flakes without roughness show (almost) no excess; what
    // remains comes from segments that join pieces of two flakes.
    let smooth: Vec<_> = (0..4).map(|k| layer(hwhm, 0.0, ell, 300 + k)).collect();
    let srefs: Vec<_> = smooth.iter().collect();
    let s = width_sources(
        &srefs,
        &SegmentParams::for_instrument(0.0, 0.0),
        &TopoSettings::default(),
    )
    .unwrap();
    let excess = s.within_flake_sigma.unwrap_or(0.0);
    eprintln!(
        "smooth control: within-flake spread {:.4}°",
        excess.to_degrees()
    );
    assert!(excess < 0.1 * rough, "{excess}");
}

/// The pixel-level histogram: its area fractions sum to 1, it is the tabulated
/// distribution it returns, and its least-squares width is near the inside-pixel one.
#[test]
fn pixel_orientation_histogram_is_the_tabulated_distribution() {
    let map = layer(5.0, 0.04, 1.5, 7);
    let p = pixel_orientation(&[&map], &TopoSettings::default(), 0.5f64.to_radians()).unwrap();
    let f = p.tilts.area_fractions();
    assert!((f.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    for (i, w) in p.tilts.edges.windows(2).enumerate().take(40) {
        assert!((p.orientation.mass_between(w[0], w[1]) - f[i]).abs() < 1e-12);
    }
    let s = p.histogram_fit.as_ref().unwrap().sigma.to_degrees();
    eprintln!(
        "histogram fit s = {s:.3}°, ML over all pixels {:?}",
        p.width.map(|w| w.sigma.to_degrees())
    );
    assert!(s > 3.0 && s < 6.0, "{s}");
    assert!(p.tilts.coverage() > 0.5 && p.tilts.coverage() < 1.0);
}
