//! Interference (thin-film) flakes are refused by the volume model until it traces the
//! light a flake transmits (physics.md §13): a clear error, never reflectance-only
//! numbers that would count the transmitted light as absorbed.

use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::thinfilm::{FilmStack, Layer as FilmLayer};
use flakescatter_stats::Orientation;
use flakescatter_volume::{
    Amount, Diameter, Layer, LayerParams, LayerSpec, TraceOptions, Tracer, VolumeError,
};

#[test]
fn stack_flakes_are_refused_with_a_reason() {
    let mut s = LayerSpec::new(Orientation::flat(), 100.0, 1);
    s.diameter = Diameter::Fixed(10.0);
    s.film_um = 20.0;
    s.thickness_um = 1.0;
    s.amount = Amount::VolumeFraction(0.01);
    let layer = Layer::generate(&LayerParams::new(s).unwrap()).unwrap();
    let stack =
        FilmStack::new(vec![FilmLayer::new(Complex::new(2.6, 0.0), 120.0).unwrap()]).unwrap();
    let options = TraceOptions {
        flake: FlakeReflectance::stack(stack, 550.0, None).unwrap(),
        ..TraceOptions::default()
    };
    let err = Tracer::new(&layer, options).unwrap_err();
    assert!(matches!(err, VolumeError::StackFlake), "{err:?}");
    assert!(err.to_string().contains("transmits"));
}
