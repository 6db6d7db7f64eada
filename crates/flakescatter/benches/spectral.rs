//! Benchmark of the spectral distribution model (issue 19): ASTM E2194's six geometries
//! at 41 wavelengths (380–780 nm every 10 nm), Rakić aluminium under a Cauchy clear coat,
//! exact cones of 1.5° half-angle, with the colorimetry (D65 / 10°): 246 detector
//! readings per iteration.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter::colour::{GeometrySet, Illuminant, Observer};
use flakescatter::optics::dispersion::{Cauchy, CoatIndex};
use flakescatter::optics::material::ComplexIndexTable;
use flakescatter::spectral::{
    FlakeSpectrum, MultiAngleSource, SpectralCoating, multi_angle_colour,
};
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::{OrientationSource, Settings};

fn multi_angle(c: &mut Criterion) {
    let coating = SpectralCoating {
        coat: CoatIndex::Cauchy(Cauchy::new(1.49, 0.0045, 0.0).unwrap()),
        flake: FlakeSpectrum::Table(ComplexIndexTable::aluminium().clone()),
        binder: None,
    };
    let source = OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap(),
    );
    let wavelengths: Vec<f64> = (0..=40).map(|k| 380.0 + 10.0 * f64::from(k)).collect();
    let set = GeometrySet::astm_e2194();
    let mut g = c.benchmark_group("spectral");
    g.throughput(Throughput::Elements((wavelengths.len() * 6) as u64));
    g.bench_function("multi_angle_41wl_e2194", |b| {
        b.iter(|| {
            multi_angle_colour(
                black_box(&coating),
                &Settings::default(),
                MultiAngleSource::Distribution(&source),
                &set,
                1.5f64.to_radians(),
                &wavelengths,
                Illuminant::D65,
                Observer::Cie1964TenDegree,
                &|_, _| {},
            )
            .unwrap()
        });
    });
    g.finish();
}

criterion_group!(benches, multi_angle);
criterion_main!(benches);
