//! Time to generate a layer with the default parameters (hwhm 6°, coverage 1.5,
//! 0.18 µm pixels, 0.3 µm z step), seed 1. Target: 2048 × 2048 in under 2 s.
//!
//! `generate/floor_<n>` is the floor `cargo xtask bench` compares each size with: a
//! generator has no input map, so the floor is one streaming pass over its output, a
//! sum of every height of the generated `n × n` map. With the environment variable
//! `FLAKESCATTER_BENCH_QUICK` set, the rough 2048² case is skipped.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flakescatter_benchfloor::streaming_sum;
use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{LayerParams, LayerSpec, generate};

fn params(n: usize, rough: bool) -> LayerParams {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).expect("width");
    let mut spec = LayerSpec::new(n, n, o, 1);
    if rough {
        spec.roughness.rms_um = 0.1;
        spec.roughness.correlation_um = 1.5;
        spec.confocal.psf_sd_um = 0.066;
        spec.confocal.noise_sd_um = 0.05;
    }
    LayerParams::new(spec).expect("valid parameters")
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("generate");
    g.sample_size(10);
    let quick = std::env::var_os("FLAKESCATTER_BENCH_QUICK").is_some();
    for (name, n, rough) in [
        ("512_default", 512, false),
        ("2048_default", 2048, false),
        ("2048_rough_psf_noise", 2048, true),
    ] {
        if quick && rough {
            continue;
        }
        let p = params(n, rough);
        if !rough {
            let layer = generate(&p).expect("generate");
            g.bench_function(format!("floor_{n}"), |b| {
                b.iter(|| streaming_sum(black_box(layer.height.heights())));
            });
        }
        g.bench_function(name, |b| b.iter(|| generate(&p).expect("generate")));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
