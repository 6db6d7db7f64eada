//! Speed of the topographic model: a seeded smooth random map (sum of random plane waves,
//! 0.5 µm pitch, rms slope about 5°) × 5 incidences × 281 in-plane detectors
//! (θs = −70°:70°:0.5°, α = 1.5°). Throughput is reported in rays (usable pixels ×
//! incidences) per second. Target: 4096² in under 1.5 s on 2 cores.
//!
//! `topo/isotropic_5inc_281det/<size>` is the isotropic average (rings, rays' worth per
//! second) on the same map and detectors; its target (issue 17) is within 3× of
//! `topo/run_5inc_281det/2048`, the plain model on the same 2048² map.
//!
//! On the same maps: `topo/normals/<size>` times the windowed normals alone (pixels per
//! second), and `topo/floor_<size>` is the floor `cargo xtask bench` compares both with:
//! one streaming single-threaded pass that reads every height once (a sum). With the
//! environment variable `FLAKESCATTER_BENCH_QUICK` set, only the 1024² map is used.
//! The isotropic rows use the 1024² and 2048² maps.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flakescatter_benchfloor::streaming_sum;
use flakescatter_optics::detector::Cone;
use flakescatter_stats::HeightMap;
use flakescatter_topo::{TopoModel, TopoOptions};
use rand::{RngExt, SeedableRng};

/// A smooth random surface: 12 plane waves with wavelengths 8–60 µm.
fn surface(size: usize, seed: u64) -> HeightMap {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let pitch = 0.5;
    let waves: Vec<(f64, f64, f64, f64)> = (0..12)
        .map(|_| {
            let lambda: f64 = rng.random_range(8.0..60.0);
            let dir: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let k = std::f64::consts::TAU / lambda;
            // Slope amplitude about 0.03 per wave (rms slope ~ 0.03 · sqrt(12/2) ≈ 0.07).
            let amp = 0.03 / k;
            (
                k * dir.cos(),
                k * dir.sin(),
                amp,
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    let mut z = vec![0.0; size * size];
    for (row, zr) in z.chunks_mut(size).enumerate() {
        let y = row as f64 * pitch;
        for (col, v) in zr.iter_mut().enumerate() {
            let x = col as f64 * pitch;
            *v = waves
                .iter()
                .map(|&(kx, ky, a, p)| a * (kx * x + ky * y + p).sin())
                .sum();
        }
    }
    HeightMap::new(size, size, pitch, pitch, z).expect("valid map")
}

fn bench(c: &mut Criterion) {
    let alpha = 1.5f64.to_radians();
    let cones: Vec<Cone> = (-140..=140)
        .map(|d| Cone::in_plane((f64::from(d) * 0.5).to_radians(), alpha).expect("cone"))
        .collect();
    let theta_i: Vec<f64> = [0.0f64, 30.0, 45.0, 60.0, 75.0]
        .iter()
        .map(|d| d.to_radians())
        .collect();
    let model = TopoModel::new(TopoOptions::default()).expect("model");
    let mut group = c.benchmark_group("topo");
    group.sample_size(10);
    let quick = std::env::var_os("FLAKESCATTER_BENCH_QUICK").is_some();
    let sizes: &[usize] = if quick { &[1024] } else { &[1024, 2048, 4096] };
    for &size in sizes {
        let map = surface(size, 42);
        group.throughput(Throughput::Elements((size * size) as u64));
        group.bench_function(format!("floor_{size}"), |b| {
            b.iter(|| streaming_sum(black_box(map.heights())));
        });
        group.bench_with_input(BenchmarkId::new("normals", size), &map, |b, map| {
            b.iter(|| model.normals(black_box(map)).expect("normals"));
        });
        let usable = ((size - 4) * (size - 4)) as u64;
        group.throughput(Throughput::Elements(usable * theta_i.len() as u64));
        group.bench_with_input(BenchmarkId::new("run_5inc_281det", size), &map, |b, map| {
            b.iter(|| model.run(&[black_box(map)], &theta_i, &cones).expect("run"));
        });
        if size <= 2048 {
            group.bench_with_input(
                BenchmarkId::new("isotropic_5inc_281det", size),
                &map,
                |b, map| {
                    b.iter(|| {
                        model
                            .run_isotropic(&[black_box(map)], &theta_i, &cones)
                            .expect("isotropic")
                    });
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
