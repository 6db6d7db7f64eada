//! Maps of flat flakes reproduce the distribution model (physics.md §5 step 4).
//!
//! Why the expectation holds: a flat flake of true area `A` and normal `m` covers
//! `A m.z` of map area, so the usable pixels' normals have density `D(m) m.z` per unit
//! solid angle (flake area density `D` of physics.md §3, projected). Each pixel carries
//! `F R γ / (m.z cos θt) / N_pixels`, so a detector collects, in expectation,
//! `coverage · ∫_{m → cone} D(m) F R γ / cos θt dΩm`, with coverage = usable / all
//! pixels; and that normal-space integral is the distribution model's cone integral
//! (conservation of probability under the change of variables, tested in the gaussian
//! crate). The scatter about the expectation comes from the finite number of flakes; the
//! tile standard errors must account for it, which the chi-square checks.
//!
//! The maps come from the synthetic generator with no roughness, no z quantisation, no
//! noise and no blur; flake edges (pixels next to another flake or the background) are
//! masked so that no window straddles two flakes.

use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions};
use flakescatter_optics::detector::Cone;
use flakescatter_stats::HeightMap;
use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{DiameterDistribution, FlakeAmount, LayerParams, LayerSpec, generate};
use flakescatter_topo::{TopoModel, TopoOptions};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// A 2048² map at 0.5 µm pitch of 8 µm flat flakes (about 10⁴ flakes), edges masked.
fn flat_flake_map(orientation: &Orientation, seed: u64) -> HeightMap {
    let mut spec = LayerSpec::new(2048, 2048, orientation.clone(), seed);
    spec.dx_um = 0.5;
    spec.dy_um = 0.5;
    spec.diameter = DiameterDistribution::Fixed(8.0);
    spec.amount = FlakeAmount::Coverage(0.5);
    spec.confocal.z_step_um = 0.0;
    spec.confocal.psf_sd_um = 0.0;
    spec.confocal.noise_sd_um = 0.0;
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    let (nx, ny) = (layer.height.nx(), layer.height.ny());
    let l = &layer.labels;
    let mask: Vec<bool> = (0..nx * ny)
        .map(|i| {
            let (c, r) = (i % nx, i / nx);
            let same = |j: usize| l[j] == l[i];
            l[i] != 0
                && (c == 0 || same(i - 1))
                && (c + 1 == nx || same(i + 1))
                && (r == 0 || same(i - nx))
                && (r + 1 == ny || same(i + nx))
        })
        .collect();
    HeightMap::with_mask(nx, ny, 0.5, 0.5, layer.height.heights().to_vec(), mask).unwrap()
}

#[test]
fn flat_flakes_reproduce_the_distribution_model_times_coverage() {
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    // Eight maps, about 8 × 10⁴ flakes: a 3° cone near the peak sees several thousand.
    let maps: Vec<HeightMap> = (21..29).map(|s| flat_flake_map(&orientation, s)).collect();
    let refs: Vec<&HeightMap> = maps.iter().collect();
    // Detectors 7° apart with α = 3° (cells independent), in plane and out of plane.
    let alpha = 3f64.to_radians();
    let mut cones: Vec<Cone> = (-12..=12)
        .map(|k| Cone::in_plane(f64::from(k * 7).to_radians(), alpha).unwrap())
        .collect();
    for theta_r in [20.0f64, 40.0, 60.0] {
        for phi in [30.0f64, 60.0, 100.0, 150.0] {
            cones.push(Cone::out_of_plane(theta_r.to_radians(), phi.to_radians(), alpha).unwrap());
        }
    }
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let topo = TopoModel::new(TopoOptions::default())
        .unwrap()
        .run(&refs, &theta_i, &cones)
        .unwrap();
    let coverage = topo.usable_fraction();
    assert!(coverage > 0.05, "coverage {coverage}");
    let model = DistributionModel::new(orientation, 1.5, ModelOptions::default()).unwrap();

    let (mut chi2, mut cells) = (0.0, 0usize);
    let (mut chi2_off, mut total_expected) = (0.0, 0.0);
    let mut pooled = (0.0, 0.0, 0.0); // (observed, expected, variance)
    for p in &topo.points {
        let inc = model.incidence(p.theta_i).unwrap();
        let expected = coverage
            * model
                .collect(&inc, &p.cone, ConeMethod::Exact)
                .reflectance
                .unwrap();
        total_expected += expected;
        // Cells resting on fewer than ~25 flakes' worth of rays (a flake shows about 40
        // usable pixels here: 10 % of the map over ~10⁴ flakes per map) get pooled: their
        // tile variance is poorly estimated.
        if (p.rays as f64) < 25.0 * 40.0 {
            pooled.0 += p.reflectance;
            pooled.1 += expected;
            // A cell without rays has no spread of its own (None) and adds none.
            pooled.2 += p.reflectance_std_err.unwrap_or(0.0).powi(2);
            continue;
        }
        let se = p.reflectance_std_err.unwrap();
        let z = (p.reflectance - expected) / se;
        // The same with the model 10 % too high: the test must be able to see that.
        let z_off = (p.reflectance - 1.1 * expected) / se;
        eprintln!(
            "θi {:5.1} axis ({:+.3}, {:+.3}) rays {:8} topo {:.4e} ± {:.1e} model {:.4e} z {:+.2}",
            p.theta_i.to_degrees(),
            p.cone.axis().x,
            p.cone.axis().y,
            p.rays,
            p.reflectance,
            se,
            expected,
            z
        );
        chi2 += z * z;
        chi2_off += z_off * z_off;
        cells += 1;
    }
    if pooled.2 > 0.0 {
        let z = (pooled.0 - pooled.1) / pooled.2.sqrt();
        eprintln!(
            "pooled: topo {:.4e} model {:.4e} z {z:+.2}",
            pooled.0, pooled.1
        );
        chi2 += z * z;
        cells += 1;
    }
    let limit = ChiSquared::new(cells as f64).unwrap().inverse_cdf(0.999);
    eprintln!("chi2 {chi2:.1} (10 % off: {chi2_off:.1}) over {cells} cells, limit {limit:.1}");
    assert!(cells >= 25, "enough well-populated cells ({cells})");
    assert!(
        total_expected > 0.2 * coverage,
        "the detectors see a real share of the light ({total_expected})"
    );
    assert!(
        chi2 < limit,
        "chi2 {chi2} over {cells} cells exceeds {limit}"
    );
    assert!(
        chi2_off > limit,
        "a 10 % error would go unnoticed ({chi2_off})"
    );
}
