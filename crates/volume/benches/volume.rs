//! Ray segments per second through the paper's coating with 10⁵ flakes.
//!
//! The layer: 38 µm film, log-normal 16 µm flakes (relative sd 0.25), 1 µm thick, 5 %
//! aluminium by mass in a 1.2 g/cm³ binder (φ = 0.0229), a Gaussian of hwhm 6°, in a
//! 4960 µm tile: about 10⁵ flakes (mean flake volume π 8² (1 + 0.25²) · 1 = 213.6 µm³).
//! One iteration traces the command line's default 10⁶ rays at 45° into 281 in-plane
//! 1.5° cones on all threads (run on 2 cores for the target, ≥ 10⁷ segments/s); the
//! throughput counts straight segments (one nearest-surface query each), which is
//! deterministic for the seed. (Until the rays ran in the Z-order of their entry
//! points it traced 64 000: the figures below are for those; the same build at 10⁶
//! rays, in two back-to-back pairs, 12.2 against 12.5 and 12.9 against 10.4 M
//! segments/s: denser rays share more of the cache.)
//! `grid/cell_um` compares column widths of ½, 1 and 2 mean diameters (the tracer's
//! default is 1). The setup also places a 10⁶-flake layer and prints the memory it and
//! its grid hold, and the time placement took (2-core AMD EPYC, Zen 4: 10⁵ flakes in
//! 1.2 s, 10⁶ in 17 s; 87 bytes per flake, 87 MB for 10⁶ flakes).
//! A bounding volume hierarchy was not measured: the periodic tile would need image
//! copies of edge flakes and a wrap per tile crossing, and the profile showed the grid's
//! time going to cache misses on the first column of each ray (offsets, entries,
//! flakes), which a hierarchy shares; the tracer now runs rays in the Z-order of their
//! entry points, so that neighbours find those in the cache (module `trace`).
//!
//! What the speed work for issue 20 bought (this bench, `cell_one`, binaries
//! run back to back on a quiet 2-core AMD EPYC (Zen 4), M segments/s): 4.9–7.0 before;
//! 8.4–8.9 with the rays in the Z-order of their entry points, Xoshiro256++ per ray
//! instead of a ChaCha8 stream (whose 256-byte block was refilled for every ray) and no
//! second test of a flake met in the previous column (callgrind: 14 % fewer
//! instructions per query); 10.2–11.6 with the chunk loop under `pulp`'s dispatch
//! (AVX-512 or AVX2 encodings, three-operand forms instead of SSE2 register copies;
//! the same results bit for bit).

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter_optics::detector::Cone;
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::{Layer, LayerParams, LayerSpec, TraceOptions, Tracer};

fn paper_layer(tile_um: f64) -> Layer {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let spec = LayerSpec::new(o, tile_um, 1);
    Layer::generate(&LayerParams::new(spec).unwrap()).unwrap()
}

fn bench(c: &mut Criterion) {
    let t = Instant::now();
    let layer = paper_layer(4960.0);
    eprintln!(
        "volume bench: {} flakes placed in {:.2?} (φ = {:.4})",
        layer.stats().flakes,
        t.elapsed(),
        layer.stats().volume_fraction
    );
    let quick = std::env::args().any(|a| a == "--quick");
    if !quick {
        let t = Instant::now();
        let big = paper_layer(15_680.0);
        let tracer = Tracer::new(&big, TraceOptions::default()).unwrap();
        eprintln!(
            "volume bench: {} flakes placed in {:.2?}; flakes + grid hold {:.1} MB ({:.0} bytes per flake)",
            big.stats().flakes,
            t.elapsed(),
            tracer.memory_bytes() as f64 / 1e6,
            tracer.memory_bytes() as f64 / big.stats().flakes as f64
        );
    }
    let cones: Vec<Cone> = (0..=280)
        .map(|k| {
            Cone::in_plane(
                (-70.0 + 0.5 * f64::from(k)).to_radians(),
                1.5f64.to_radians(),
            )
            .unwrap()
        })
        .collect();
    let theta = [45f64.to_radians()];
    let options = TraceOptions {
        rays: 1_000_000,
        ..TraceOptions::default()
    };
    let mut group = c.benchmark_group("volume");
    group.sample_size(10);
    for (name, cell) in [("half", 8.0), ("one", 16.0), ("two", 32.0)] {
        let tracer = Tracer::with_cell(&layer, options.clone(), cell).unwrap();
        let segments = tracer.run(&theta, &cones).unwrap().segments;
        group.throughput(Throughput::Elements(segments));
        group.bench_function(format!("trace_1e5_flakes/cell_{name}_diameter"), |b| {
            b.iter(|| black_box(tracer.run(&theta, &cones).unwrap()));
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
