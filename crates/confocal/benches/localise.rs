//! Localisation throughput: a 1024 x 1024 x 100 stack of seeded Gaussian axial responses
//! (FWHM 0.6 µm, 0.3 µm steps, surface heights spread over the stack) pushed slice by
//! slice through the streaming localiser with each estimator. Throughput in voxels per
//! second (criterion's elements).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter_confocal::{Localiser, PeakMethod, PeakOptions, SliceOrder, StackGeometry};

const N: usize = 1024;
const NZ: usize = 100;

fn bench_localise(c: &mut Criterion) {
    // Surface heights from a small LCG, between slices 5 and 95.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let heights: Vec<f64> = (0..N * N)
        .map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (5.0 + 90.0 * ((state >> 11) as f64 / (1u64 << 53) as f64)) * 0.3
        })
        .collect();
    let slices: Vec<Vec<f32>> = (0..NZ)
        .map(|k| {
            let z = k as f64 * 0.3;
            heights
                .iter()
                .map(|h| (-4.0 * 2f64.ln() * ((z - h) / 0.6).powi(2)).exp() as f32)
                .collect()
        })
        .collect();
    let geometry = StackGeometry {
        nx: N,
        ny: N,
        nz: NZ,
        dx_um: 0.18,
        dy_um: 0.18,
        dz_um: 0.3,
        order: SliceOrder::BottomFirst,
    };
    let mut g = c.benchmark_group("localise");
    g.sample_size(10);
    g.throughput(Throughput::Elements((N * N * NZ) as u64));
    for method in [
        PeakMethod::Argmax,
        PeakMethod::Gaussian,
        PeakMethod::Parabolic,
        PeakMethod::Centroid,
    ] {
        g.bench_function(format!("{method}_1024x1024x100"), |b| {
            b.iter(|| {
                let options = PeakOptions {
                    method,
                    ..PeakOptions::default()
                };
                let mut loc = Localiser::new(geometry, options).unwrap();
                for s in &slices {
                    loc.push_slice(s).unwrap();
                }
                loc.finish().unwrap().report.valid
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench_localise);
criterion_main!(benches);
