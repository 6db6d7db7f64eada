//! The dilute limit: few flakes near the top reproduce the distribution model.
//!
//! Why the expectation holds. A flake of face area `A` and normal `m`, fully lit by the
//! refracted beam (power `T_in / L²` per unit tile area, `1/cos θt` of that per unit
//! area across the beam), intercepts `A γ T_in / (L² cos θt)` with `γ = −k1·m`, and
//! sends `A γ F / (L² cos θt)` out along its mirror direction, `F` the Fresnel factor
//! `½[Ts Ts' + Tp Tp']` (perfect conductor). With no shadowing, the single-bounce power in
//! a cone is the sum of that over the flakes whose exit direction lies in the cone. The
//! normals are drawn from `p2` independently of everything else, so its expectation is
//! `(Σ A / L²) ∫ p2 γ F / cos θt dΩm` over the cone's pre-image, which is
//! `(Σ A / L²) ⟨cos θn⟩` times the distribution model's cone integral (its density is
//! `D = p2/⟨cos θn⟩`): coverage × the distribution model, with the projected coverage
//! `⟨cos θn⟩ Σ A / L²`.
//!
//! Two comparisons per cone: (1) the traced single-bounce power against the exact sum
//! over this layer's flakes (only the ray-sampling error, the batch standard error);
//! (2) the traced power against coverage × the distribution model, with the ray error
//! plus the flake-sampling variance of the sum (estimated from the per-flake terms,
//! `Σ x² − (Σ x)²/N`). Both as chi-square over the cells, low-count cells pooled, as the
//! topographic model's check does; and a model 10 % off must fail.

use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions};
use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::{UnitVec3, fresnel, reflection, refraction};
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::{
    Amount, Depth, Diameter, Layer, LayerParams, LayerSpec, TraceOptions, Tracer,
};
use statrs::distribution::{ChiSquared, ContinuousCDF};

#[test]
fn dilute_single_bounce_is_coverage_times_the_distribution_model() {
    let n = 1.5;
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(8f64.to_radians())).unwrap();
    // 40 000 flakes of 4 µm, 0.1 µm thick, centres 2–2.5 µm deep: about 2 % projected
    // coverage, so shadowing is a fraction of a per cent.
    let tile = 5000.0;
    let mut spec = LayerSpec::new(orientation.clone(), tile, 3);
    spec.film_um = 10.0;
    spec.diameter = Diameter::Fixed(4.0);
    spec.thickness_um = 0.1;
    spec.amount = Amount::Count(40_000);
    spec.depth = Depth::Uniform {
        top_um: 2.0,
        bottom_um: 2.5,
    };
    let layer = Layer::generate(&LayerParams::new(spec).unwrap()).unwrap();
    let coverage = layer.stats().area_coverage * orientation.mean_cos();
    eprintln!(
        "projected coverage {coverage:.4} (realised {:.4})",
        layer.stats().projected_coverage
    );

    let alpha = 3f64.to_radians();
    let mut cones: Vec<Cone> = (-12..=12)
        .map(|k| Cone::in_plane(f64::from(k * 7).to_radians(), alpha).unwrap())
        .collect();
    for theta_r in [20.0f64, 40.0, 60.0] {
        for phi in [20.0f64, 45.0, 120.0] {
            cones.push(Cone::out_of_plane(theta_r.to_radians(), phi.to_radians(), alpha).unwrap());
        }
    }
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let tracer = Tracer::new(
        &layer,
        TraceOptions {
            n,
            rays: 4_000_000,
            seed: 5,
            ..TraceOptions::default()
        },
    )
    .unwrap();
    let res = tracer.run(&theta_i, &cones).unwrap();
    let model = DistributionModel::new(orientation, n, ModelOptions::default()).unwrap();

    let (mut chi_layer, mut chi_model, mut chi_off, mut cells) = (0.0, 0.0, 0.0, 0usize);
    // Pooled low-count cells: (traced, layer sum, model, ray var, flake var).
    let mut pooled = [0.0f64; 5];
    let nd = cones.len();
    for (ii, &ti) in theta_i.iter().enumerate() {
        let inc = model.incidence(ti).unwrap();
        let k1 = refraction::into_coating(&detector::incident_direction(ti), n);
        let entry = fresnel::air_to_coating(ti, n);
        // Per-flake terms x = A γ F / (L² cos θt) of the flakes whose ray leaves along
        // a direction, found once per incidence.
        let terms: Vec<(UnitVec3, f64)> = layer
            .flakes()
            .iter()
            .filter_map(|k| {
                let gamma = reflection::obliquity(&k1, &k.normal);
                if gamma <= 0.0 {
                    return None;
                }
                let k2 = reflection::reflect(&k1, &k.normal);
                if k2.z <= 0.0 {
                    return None;
                }
                let out = refraction::out_of_coating(&k2, n)?;
                let exit = fresnel::power_from_cosines(out.z, k2.z, n);
                let f = 0.5 * (entry.ts * exit.ts + entry.tp * exit.tp);
                Some((
                    out,
                    k.face_area_um2() * gamma * f / (tile * tile * inc.cos_t),
                ))
            })
            .collect();
        let nflakes = layer.flakes().len() as f64;
        for (j, cone) in cones.iter().enumerate() {
            let p = &res.points[ii * nd + j];
            let proj = cone.projected_solid_angle();
            let traced = p.single_brdf * proj;
            let ray_var = (p.single_std_err * proj).powi(2);
            let (mut s, mut s2) = (0.0, 0.0);
            for (out, x) in &terms {
                if cone.contains(out) {
                    s += x;
                    s2 += x * x;
                }
            }
            let flake_var = (s2 - s * s / nflakes).max(0.0);
            let expected = coverage
                * model
                    .collect(&inc, cone, ConeMethod::Exact)
                    .reflectance
                    .unwrap();
            if p.rays < 250 {
                for (a, v) in pooled
                    .iter_mut()
                    .zip([traced, s, expected, ray_var, flake_var])
                {
                    *a += v;
                }
                continue;
            }
            let z_layer = (traced - s) / ray_var.sqrt();
            let sd = (ray_var + flake_var).sqrt();
            let z_model = (traced - expected) / sd;
            let z_off = (traced - 1.1 * expected) / sd;
            eprintln!(
                "θi {:2.0} axis ({:+.3}, {:+.3}) rays {:6} traced {:.4e} layer {:.4e} model {:.4e} z_layer {:+.2} z_model {:+.2}",
                ti.to_degrees(),
                cone.axis().x,
                cone.axis().y,
                p.rays,
                traced,
                s,
                expected,
                z_layer,
                z_model
            );
            chi_layer += z_layer * z_layer;
            chi_model += z_model * z_model;
            chi_off += z_off * z_off;
            cells += 1;
        }
    }
    if pooled[3] > 0.0 {
        let [t, s, e, rv, fv] = pooled;
        eprintln!("pooled: traced {t:.4e} layer {s:.4e} model {e:.4e}");
        chi_layer += (t - s).powi(2) / rv;
        chi_model += (t - e).powi(2) / (rv + fv);
        chi_off += (t - 1.1 * e).powi(2) / (rv + fv);
        cells += 1;
    }
    let limit = ChiSquared::new(cells as f64).unwrap().inverse_cdf(0.999);
    eprintln!(
        "chi2 layer {chi_layer:.1}, model {chi_model:.1} (10 % off: {chi_off:.1}) over {cells} cells, limit {limit:.1}"
    );
    assert!(cells >= 20, "enough well-populated cells ({cells})");
    assert!(
        chi_layer < limit,
        "traced vs this layer's flakes: chi2 {chi_layer}"
    );
    assert!(
        chi_model < limit,
        "traced vs coverage × distribution model: chi2 {chi_model}"
    );
    assert!(
        chi_off > limit,
        "a 10 % error would go unnoticed ({chi_off})"
    );
}
