//! The identity of physics.md §5.2: the isotropic topographic model equals the
//! usable-pixel coverage times the distribution model driven by the pixel-level
//! distribution of normals, up to the histogram's bin width.
//!
//! Why (derivation in physics.md §5.2): pixel `p` with polar angle `θp` and area factor
//! `ap = 1/m.z` gives `ρ_iso = (1/N) Σ_p ap h(θp)` with `h(θ) = (1/2π) ∫ F γ / cos θt
//! 1[cone] dφ`. The distribution model with an area-weighted density `p2` collects
//! `ρ = ∫ D F γ / cos θt 1[cone] dΩm`, `D = p2/⟨cos θn⟩` (physics.md §4, conservation),
//! i.e. `ρ = ∫ p(θ) h(θ) dθ / ⟨cos θn⟩`. For the pixels' own distribution,
//! `p = Σ ap δ(θ − θp)/Σ ap` and `⟨cos θn⟩ = Σ ap m.z/Σ ap = N_usable/Σ ap`, so
//! `coverage · ρ = (N_usable/N) Σ ap h(θp)/N_usable = ρ_iso` exactly. A histogram spreads
//! each bin's area uniformly in solid angle over the bin, which changes both `∫ p h` and
//! `⟨cos θn⟩` by amounts that vanish with the bin width.
//!
//! The distribution model here is an independent implementation: the `gaussian` crate
//! integrates its point BRDF over each detector cone in detector space.

use flakescatter::stats::distribution::{GaussianWidth, Orientation};
use flakescatter::synth::{LayerParams, LayerSpec, generate};
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, Settings, TopoSettings,
    distribution_curves, isotropic_curves, pixel_orientation,
};

/// A rough synthetic layer: flakes with a Gaussian hwhm of 6°, roughness rms 0.05 µm
/// with a 1.5 µm correlation length, 0.18 µm pixels, exact heights.
fn rough_layer(size: usize, seed: u64) -> flakescatter::stats::HeightMap {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(size, size, o, seed);
    spec.roughness.rms_um = 0.05;
    spec.roughness.correlation_um = 1.5;
    spec.confocal.z_step_um = 0.0;
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    let mut map = layer.height;
    map.apply_intensity_cutoff(&layer.intensity, 0.49).unwrap();
    map
}

#[test]
fn isotropic_model_is_coverage_times_the_distribution_model_of_the_pixel_normals() {
    let map = rough_layer(1024, 17);
    let ts: Vec<f64> = (-140..=140)
        .map(|d| (f64::from(d) * 0.5).to_radians())
        .collect();
    let instrument = Instrument::new(
        vec![30f64.to_radians(), 60f64.to_radians()],
        DetectorSet::InPlane(ts.clone()),
        1.5f64.to_radians(),
    )
    .unwrap();
    let (coating, settings, topo) = (
        Coating::default(),
        Settings::default(),
        TopoSettings::default(),
    );
    // Nodes 4× finer than the default, so that the table's interpolation error (its
    // estimate is checked below) stays well under the bins' effect being measured.
    let spacing = 1.5f64.to_radians() / flakescatter::topo::DEFAULT_NODES_PER_APERTURE / 4.0;
    let (iso, result) = isotropic_curves(
        &coating,
        &instrument,
        &settings,
        &topo,
        Some(spacing),
        &[&map],
        &|_, _| {},
    )
    .unwrap();
    let coverage = result.usable_fraction();
    let mut deviations = Vec::new();
    for bin_deg in [1.0f64, 0.5, 0.25] {
        let pix = pixel_orientation(&[&map], &topo, bin_deg.to_radians()).unwrap();
        assert_eq!(pix.tilts.usable_pixels, result.usable_pixels);
        let dist = distribution_curves(
            &coating,
            &instrument,
            &settings,
            &OrientationSource::Distribution(pix.orientation),
        )
        .unwrap();
        let (mut worst, mut sq, mut n) = (0.0f64, 0.0, 0);
        let mut est = 0.0f64;
        for (k, (a, b)) in iso.rows.iter().zip(&dist.rows).enumerate() {
            let aspecular = (ts[a.detector] + a.theta_i).abs().to_degrees();
            if !(5.0 - 1e-9..=40.0 + 1e-9).contains(&aspecular) {
                continue;
            }
            let (ri, rd) = (a.reflectance.unwrap(), coverage * b.reflectance.unwrap());
            let rel = (rd - ri) / ri;
            est = est.max(result.interpolation_error[k] / ri);
            assert!(
                result.interpolation_error[k] < 2e-3 * ri,
                "{} of {ri}",
                result.interpolation_error[k]
            );
            worst = worst.max(rel.abs());
            sq += rel * rel;
            n += 1;
        }
        let rms = (sq / f64::from(n)).sqrt();
        eprintln!(
            "bins {bin_deg}°: {n} detectors, worst {worst:.2e}, rms {rms:.2e}, interpolation estimate up to {est:.2e}"
        );
        deviations.push((worst, rms));
    }
    let (w025, _) = deviations[2];
    assert!(w025 < 0.01, "0.25° bins: worst deviation {w025}");
    for pair in deviations.windows(2) {
        assert!(
            pair[1].0 < pair[0].0 && pair[1].1 < pair[0].1,
            "{deviations:?}"
        );
    }
}
