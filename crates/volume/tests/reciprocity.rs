//! Reciprocity of the total BRDF (Helmholtz): `f(a → b) = f(b → a)`.
//!
//! For a fixed layer lit uniformly over its periodic tile, the power a cone about
//! direction `o` collects from a beam along `i`, per unit projected solid angle, is
//! symmetric under swapping `i` and `o` reversed: every interaction's weight is
//! symmetric (Fresnel power transmittance and reflectance are the same both ways at a
//! Snell pair, mirror reflection and the cosine-law events are reciprocal, the s/p
//! channel bookkeeping multiplies the same factors in reverse order), and geometric
//! optics conserves étendue. In the plane of incidence with the source on the `−x` side,
//! the reverse of the exit direction at `θs = b > 0` (on the source side) is the
//! incidence `θi = b`, and the reverse of incidence `a` is the detector `θs = a`. So the
//! detector `θs = b` at incidence `a` and the detector `θs = a` at incidence `b` must
//! agree within the Monte Carlo error (the cone averages differ at second order in the
//! aperture; with a 25° orientation width and 4° cones that is below the error).
//! Many small flakes keep the curve smooth: a mirror flake sends light into a cone only
//! when its normal lies in the cone's small pre-image, so a few thousand flakes would
//! leave a spiky curve whose cones rest on a handful of flakes.
//!
//! A dense layer (multiple scattering a large share of the light) with every rule that
//! changes a path on: complex-index flakes, diffuse rims, a Lambertian substrate.

use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::{
    Amount, Diameter, Layer, LayerParams, LayerSpec, RimRule, Substrate, TraceOptions, Tracer,
};

#[test]
fn total_brdf_is_reciprocal() {
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(25f64.to_radians())).unwrap();
    // About 36 000 flakes of 3 µm, 0.15 µm thick, in an 8 µm film: face-area coverage 1.6.
    let mut spec = LayerSpec::new(orientation, 400.0, 17);
    spec.film_um = 8.0;
    spec.diameter = Diameter::Fixed(3.0);
    spec.thickness_um = 0.15;
    spec.amount = Amount::VolumeFraction(0.03);
    let layer = Layer::generate(&LayerParams::new(spec).unwrap()).unwrap();
    let tracer = Tracer::new(
        &layer,
        TraceOptions {
            flake: FlakeReflectance::aluminium_550nm(),
            rims: RimRule::Diffuse,
            substrate: Substrate::Lambertian(0.2),
            rays: 512_000,
            seed: 23,
            // Paths end below 1e-4 of a ray's power (tallied as cut_off): the tail
            // of long diffuse histories costs time and moves no cone by a visible amount.
            min_weight: 1e-4,
            ..TraceOptions::default()
        },
    )
    .unwrap();
    let angles = [10.0f64, 25.0, 45.0].map(f64::to_radians);
    let alpha = 4f64.to_radians();
    let cones: Vec<Cone> = angles
        .iter()
        .map(|&a| Cone::in_plane(a, alpha).unwrap())
        .collect();
    let res = tracer.run(&angles, &cones).unwrap();
    let nd = cones.len();
    let mut worst: f64 = 0.0;
    for a in 0..angles.len() {
        for b in a + 1..angles.len() {
            let ab = &res.points[a * nd + b];
            let ba = &res.points[b * nd + a];
            let se = ab.brdf_std_err.hypot(ba.brdf_std_err);
            let z = (ab.brdf - ba.brdf) / se;
            // The share of multiple scattering in these off-specular geometries.
            let share = ab.multiple_brdf / ab.brdf;
            eprintln!(
                "{:.0}° → {:.0}°: {:.5} ± {:.5}; reverse {:.5} ± {:.5}; z {z:+.2}; multiple share {share:.2}",
                angles[a].to_degrees(),
                angles[b].to_degrees(),
                ab.brdf,
                ab.brdf_std_err,
                ba.brdf,
                ba.brdf_std_err
            );
            assert!(
                share > 0.15,
                "multiple scattering must be part of the check ({share})"
            );
            assert!(
                ab.brdf_std_err < 0.06 * ab.brdf,
                "precise enough to mean something"
            );
            worst = worst.max(z.abs());
        }
    }
    // BRDF × cos θ (the collected power per sr) is not reciprocal: a weighting error of
    // that kind (cos 45°/cos 10° = 0.72) would show up far outside the error.
    let ab = &res.points[2];
    let ba = &res.points[2 * nd];
    let ratio = angles[2].cos() / angles[0].cos();
    let se = ab.brdf_std_err.hypot(ba.brdf_std_err);
    assert!(((ab.brdf * ratio - ba.brdf) / se).abs() > 5.0);
    {
        {}
    }
    assert!(worst < 4.0, "largest |z| {worst}");
}
