//! Benchmarks of the distribution model (issue targets: the default set of 5 incidences ×
//! 281 in-plane detectors with exact cone integration at α = 1.5° in under 20 ms on one
//! thread; the point BRDF at more than 10⁷ evaluations per second; the point Mueller
//! BRDF at most 3× the cost of the unpolarised point BRDF on the same 1000 directions,
//! issue 18; the batch point BRDF at 120 M evaluations per second or more on one
//! thread, issue 22).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions, curve};
use flakescatter_optics::Vec3;
use flakescatter_optics::detector::{Cone, in_plane_direction};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::mueller::Mueller;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::thinfilm::{FilmStack, Layer};
use flakescatter_stats::{GaussianWidth, Orientation};

fn model() -> DistributionModel {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap()
}

fn default_set(c: &mut Criterion) {
    let m = model();
    let alpha = 1.5f64.to_radians();
    let cones: Vec<Cone> = (0..=280)
        .map(|k| Cone::in_plane((-70.0 + 0.5 * f64::from(k)).to_radians(), alpha).unwrap())
        .collect();
    let ti: Vec<f64> = [0.0, 30.0, 45.0, 60.0, 75.0].map(f64::to_radians).to_vec();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut g = c.benchmark_group("gaussian");
    g.throughput(Throughput::Elements((ti.len() * cones.len()) as u64));
    g.bench_function("default_set_5x281_exact_1thread", |b| {
        b.iter(|| pool.install(|| curve(black_box(&m), &ti, &cones, ConeMethod::Exact).unwrap()));
    });
    g.finish();
}

fn point_brdf(c: &mut Criterion) {
    let m = model();
    let inc = m.incidence(45f64.to_radians()).unwrap();
    let dirs: Vec<Vec3> = (0..1000)
        .map(|k| in_plane_direction((-70.0 + 0.14 * f64::from(k)).to_radians()).into_inner())
        .collect();
    let mut g = c.benchmark_group("gaussian");
    g.throughput(Throughput::Elements(dirs.len() as u64));
    g.bench_function("point_brdf_x1000", |b| {
        b.iter(|| dirs.iter().map(|r| m.brdf(&inc, black_box(r))).sum::<f64>());
    });
    g.bench_function("point_brdf_batch_x1000", |b| {
        let mut out = Vec::with_capacity(dirs.len());
        // The values are handed to `black_box` rather than summed: a sum of 1000 values
        // is a chain of 1000 dependent additions (about 7 % of the batch's time on
        // this machine), which measures the adder's latency, not the kernel.
        b.iter(|| {
            m.brdf_batch(&inc, black_box(&dirs), &mut out);
            black_box(&out);
        });
    });
    g.bench_function("point_mueller_x1000", |b| {
        b.iter(|| {
            dirs.iter()
                .map(|r| m.brdf_mueller(&inc, black_box(r)))
                .fold(Mueller::ZERO, |a, x| a + x)
        });
    });
    g.finish();
}

/// A metal flake against an interference flake of three layers (issue 47: a stack flake
/// costs at most 3× a metal flake per point BRDF evaluation).
fn stack_flake(c: &mut Criterion) {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let layer = |n: f64, d: f64| Layer::new(Complex::new(n, 0.0), d).unwrap();
    let stack = FilmStack::new(vec![
        layer(2.6, 120.0),
        layer(1.6, 400.0),
        layer(2.6, 120.0),
    ])
    .unwrap();
    let models = [
        (
            "point_brdf_metal_x1000",
            FlakeReflectance::complex(0.96, 6.69).unwrap(),
        ),
        (
            "point_brdf_stack3_x1000",
            FlakeReflectance::stack(stack, 550.0, None).unwrap(),
        ),
    ];
    let dirs: Vec<Vec3> = (0..1000)
        .map(|k| in_plane_direction((-70.0 + 0.14 * f64::from(k)).to_radians()).into_inner())
        .collect();
    let mut g = c.benchmark_group("gaussian");
    g.throughput(Throughput::Elements(dirs.len() as u64));
    for (id, flake) in models {
        let options = ModelOptions {
            flake,
            ..ModelOptions::default()
        };
        let m = DistributionModel::new(o.clone(), 1.5, options).unwrap();
        let inc = m.incidence(45f64.to_radians()).unwrap();
        g.bench_function(id, |b| {
            b.iter(|| dirs.iter().map(|r| m.brdf(&inc, black_box(r))).sum::<f64>());
        });
    }
    g.finish();
}

criterion_group!(benches, default_set, point_brdf, stack_flake);
criterion_main!(benches);
