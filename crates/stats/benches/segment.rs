//! Segmentation speed on a 2048 × 2048 synthetic confocal map (issue 8 asks for < 1 s
//! on 2 cores): 0.18 µm pitch, 16 µm flakes, 0.3 µm z step, 30 nm height noise.
//!
//! `segment/floor_2048x2048` is the floor `cargo xtask bench` compares segmentation
//! with: one streaming, single-threaded pass that reads every height of the same map once
//! (a sum).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flakescatter_benchfloor::streaming_sum;
use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_stats::segment::{SegmentParams, segment};
use flakescatter_synth::{LayerParams, LayerSpec, generate};

fn bench(c: &mut Criterion) {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(2048, 2048, o, 7);
    spec.confocal.noise_sd_um = 0.03;
    spec.confocal.psf_sd_um = 0.066;
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    let mut map = layer.height.clone();
    map.apply_intensity_cutoff(&layer.intensity, 0.49).unwrap();
    let params = SegmentParams::default();
    let mut g = c.benchmark_group("segment");
    g.sample_size(10);
    g.bench_function("floor_2048x2048", |b| {
        b.iter(|| streaming_sum(black_box(map.heights())));
    });
    g.bench_function("2048x2048", |b| b.iter(|| segment(&map, &params).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
