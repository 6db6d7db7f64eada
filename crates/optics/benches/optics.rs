//! Per-call cost of the optics primitives every model evaluates in its inner loop:
//! Fresnel power coefficients, Snell refraction in and out of the clear coat, mirror
//! reflection by a flake and the internal half vector. Each bench evaluates the
//! primitive on 1000 seeded inputs (angles in `[0°, 80°)`, flake normals within about
//! 25° of `+z`, clear-coat index 1.5), so throughput is in evaluations per second.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::thinfilm::{FilmStack, Layer};
use flakescatter_optics::{UnitVec3, Vec3, detector, fresnel, reflection, refraction};

/// Inputs per bench iteration.
const N: usize = 1000;
/// Clear-coat refractive index.
const INDEX: f64 = 1.5;

/// A small seeded generator (64-bit LCG, top 53 bits) so the bench needs no RNG crate.
struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn bench(c: &mut Criterion) {
    let mut rng = Lcg(0x00f1_a4e5_ca77_e12d);
    let angles: Vec<f64> = (0..N).map(|_| rng.uniform() * 80f64.to_radians()).collect();
    let k_in: Vec<UnitVec3> = angles
        .iter()
        .map(|&t| detector::incident_direction(t))
        .collect();
    let k1: Vec<UnitVec3> = k_in
        .iter()
        .map(|k| refraction::into_coating(k, INDEX))
        .collect();
    let normals: Vec<UnitVec3> = (0..N)
        .map(|_| {
            let (a, b) = (rng.uniform() - 0.5, rng.uniform() - 0.5);
            UnitVec3::new_normalize(Vec3::new(0.9 * a, 0.9 * b, 1.0))
        })
        .collect();
    let k2: Vec<UnitVec3> = k1
        .iter()
        .zip(&normals)
        .map(|(k, m)| reflection::reflect(k, m))
        .collect();

    let mut g = c.benchmark_group("optics");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("fresnel_air_to_coating_x1000", |b| {
        b.iter(|| {
            black_box(&angles)
                .iter()
                .map(|&t| fresnel::air_to_coating(t, INDEX).t_av())
                .sum::<f64>()
        });
    });
    g.bench_function("snell_into_coating_x1000", |b| {
        b.iter(|| {
            black_box(&k_in)
                .iter()
                .map(|k| refraction::into_coating(k, INDEX).z)
                .sum::<f64>()
        });
    });
    g.bench_function("snell_out_of_coating_x1000", |b| {
        b.iter(|| {
            black_box(&k2)
                .iter()
                .filter_map(|k| refraction::out_of_coating(k, INDEX))
                .map(|k| k.z)
                .sum::<f64>()
        });
    });
    g.bench_function("reflect_x1000", |b| {
        b.iter(|| {
            black_box(&k1)
                .iter()
                .zip(&normals)
                .map(|(k, m)| reflection::reflect(k, m).z)
                .sum::<f64>()
        });
    });
    g.bench_function("half_vector_x1000", |b| {
        b.iter(|| {
            black_box(&k1)
                .iter()
                .zip(&k2)
                .filter_map(|(a, b)| reflection::half_vector(a, b))
                .map(|m| m.z)
                .sum::<f64>()
        });
    });
    // The flake's own optics at one local incidence: a metal (one Fresnel interface)
    // against a three-layer interference stack (TiO2/mica/TiO2-like, Rouard's recursion)
    // in the same binder. Their ratio bounds what a stack flake adds per point.
    let metal = FlakeReflectance::complex(0.96, 6.69).expect("valid index");
    let cosines: Vec<f64> = angles.iter().map(|t| t.cos()).collect();
    g.bench_function("flake_metal_amplitudes_x1000", |b| {
        b.iter(|| {
            black_box(&cosines)
                .iter()
                .map(|&c| {
                    let (rs, rp) = metal.amplitudes(c, INDEX);
                    rs.norm_sqr() + rp.norm_sqr()
                })
                .sum::<f64>()
        });
    });
    let layer = |n: f64, d: f64| Layer::new(Complex::new(n, 0.0), d).expect("valid layer");
    let stack = FilmStack::new(vec![
        layer(2.6, 120.0),
        layer(1.6, 400.0),
        layer(2.6, 120.0),
    ])
    .expect("valid stack");
    let binder = Complex::new(INDEX, 0.0);
    g.bench_function("flake_stack3_response_x1000", |b| {
        b.iter(|| {
            black_box(&cosines)
                .iter()
                .map(|&c| {
                    let r = stack
                        .response(INDEX, binder, c, 550.0)
                        .expect("valid inputs");
                    r.r_s() + r.r_p()
                })
                .sum::<f64>()
        });
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
