//! `Settings::base_albedo` (physics.md §13, "A base under transmitting flakes") where it
//! is honoured and where it is refused: the distribution model over free thin-film flakes
//! adds the base's light (more than the black base far from specular, and `ρ = 0` the
//! black base to the bit), and so does the plain topographic model over maps in memory;
//! the isotropic and Mueller topographic models and the distribution model's Mueller
//! path refuse a non-zero albedo, as do metal flakes.

use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::nalgebra::Complex;
use flakescatter::optics::thinfilm::{FilmStack, Layer};
use flakescatter::stats::{GaussianWidth, HeightMap, Orientation};
use flakescatter::streaming::topographic_curves_streamed;
use flakescatter::topo::HeightSource;
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, PipelineError, Polarimetry, Settings,
    TopoSettings, distribution_curves, distribution_mueller, isotropic_curves, topographic_curves,
    topographic_mueller,
};

fn film() -> Coating {
    let layer = Layer::new(Complex::new(2.4, 0.0), 100.0).unwrap();
    Coating {
        n: 1.5,
        flake: FlakeReflectance::stack(FilmStack::new(vec![layer]).unwrap(), 550.0, None).unwrap(),
    }
}

fn instrument() -> Instrument {
    let dets = (0..=7)
        .map(|k| (f64::from(k * 10).to_radians(), 0.0))
        .collect();
    Instrument::new(
        vec![30f64.to_radians()],
        DetectorSet::OutOfPlane(dets),
        2f64.to_radians(),
    )
    .unwrap()
}

fn source() -> OrientationSource {
    OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(3f64.to_radians())).unwrap(),
    )
}

fn with_base(rho: f64) -> Settings {
    Settings {
        base_albedo: rho,
        ..Settings::default()
    }
}

#[test]
fn the_distribution_model_adds_the_base_and_zero_is_the_black_base() {
    let (c, i, s) = (film(), instrument(), source());
    let black = distribution_curves(&c, &i, &Settings::default(), &s).unwrap();
    let zero = distribution_curves(&c, &i, &with_base(0.0), &s).unwrap();
    let white = distribution_curves(&c, &i, &with_base(0.9), &s).unwrap();
    for ((b, z), w) in black.rows.iter().zip(&zero.rows).zip(&white.rows) {
        assert_eq!(b, z);
        assert!(w.reflectance.unwrap() > b.reflectance.unwrap());
    }
    let metal = Coating {
        flake: FlakeReflectance::aluminium_550nm(),
        ..film()
    };
    let err = distribution_curves(&metal, &i, &with_base(0.5), &s).unwrap_err();
    assert!(err.to_string().contains("transmit"), "{err}");
}

#[test]
fn the_plain_topographic_model_adds_a_base_and_the_other_paths_refuse_it() {
    let (nx, ny) = (64, 64);
    let z: Vec<f64> = (0..nx * ny)
        .map(|i| 0.3 * ((i % nx) as f64 * 0.2).sin() + 0.2 * ((i / nx) as f64 * 0.15).cos())
        .collect();
    let map = HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap();
    let (c, i, s) = (film(), instrument(), with_base(0.5));
    let topo = TopoSettings::default();
    // The plain model in memory adds the base (tests/topo_base.rs); the others refuse.
    let (black, _) =
        topographic_curves(&c, &i, &Settings::default(), &topo, &[&map], &|_, _| {}).unwrap();
    let (based, _) = topographic_curves(&c, &i, &s, &topo, &[&map], &|_, _| {}).unwrap();
    for (b, w) in black.rows.iter().zip(&based.rows) {
        assert!(w.reflectance.unwrap() > b.reflectance.unwrap());
    }
    let e = isotropic_curves(&c, &i, &s, &topo, None, &[&map], &|_, _| {}).unwrap_err();
    assert!(e.to_string().contains("black base"), "{e}");
    let metal = Coating {
        flake: FlakeReflectance::aluminium_550nm(),
        ..film()
    };
    let e = topographic_curves(&metal, &i, &s, &topo, &[&map], &|_, _| {}).unwrap_err();
    assert!(e.to_string().contains("transmit"), "{e}");
    let sources: [&dyn HeightSource; 1] = [&map];
    let e = topographic_curves_streamed(&c, &i, &s, &topo, &sources, &|_, _| {}).unwrap_err();
    assert!(e.to_string().contains("black base"), "{e}");
    let p = Polarimetry::default();
    let e = topographic_mueller(&c, &i, &s, &topo, &[&map], &p, &|_, _| {}).unwrap_err();
    assert!(matches!(e, PipelineError::Polarization(_)), "{e}");
    let e = distribution_mueller(&c, &i, &s, &source(), &p).unwrap_err();
    assert!(matches!(e, PipelineError::Polarization(_)), "{e}");
}
