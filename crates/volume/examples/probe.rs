//! Timing probe.
use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::*;
fn main() {
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(25f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(orientation, 400.0, 17);
    spec.film_um = 8.0;
    spec.diameter = Diameter::Fixed(3.0);
    spec.thickness_um = 0.15;
    spec.amount = Amount::VolumeFraction(0.03);
    let t = std::time::Instant::now();
    let layer = Layer::generate(&LayerParams::new(spec).unwrap()).unwrap();
    println!("{:?} {:?}", layer.stats(), t.elapsed());
    let cones = vec![Cone::in_plane(25f64.to_radians(), 4f64.to_radians()).unwrap()];
    for (sub, rims) in [(Substrate::Black, RimRule::Absorb), (Substrate::Lambertian(0.2), RimRule::Absorb), (Substrate::Black, RimRule::Diffuse), (Substrate::Lambertian(0.2), RimRule::Diffuse)] {
        for cell in [1.5, 3.0, 6.0] {
        let tracer = Tracer::with_cell(&layer, TraceOptions { rays: 64000, substrate: sub, rims, flake: FlakeReflectance::aluminium_550nm(), ..TraceOptions::default() }, cell);
        let t = std::time::Instant::now();
        let res = tracer.run(&[10f64.to_radians()], &cones).unwrap();
        println!("{sub:?} {rims:?} cell {cell}: per ray {:.2}, {:?}, cut {:.2e}", res.segments as f64 / 64000.0, t.elapsed(), res.energy[0].cut_off);
        }
    }
}
