//! Benchmark of `export --format merl` (issue 48: a full table, 1.46 M bins × 3
//! channels, in under 3 s on 2 cores): one iteration fills every bin of a MERL table at
//! its centre, for the flakes of a hwhm 6° Gaussian under a coat of 1.5 (grey), and for
//! the paint fitted to the measured blue MERL paint of `fixtures/real/paints` (table
//! family; the fit is done once, outside the timing).

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter::compare::MeasuredKind;
use flakescatter::export::{BrdfSource, merl_table, paint_rgb};
use flakescatter::gaussian::{DistributionModel, ModelOptions};
use flakescatter::paint::{Family, FitOptions, fit, read_measurement};
use flakescatter::paint_model::PaintModel;
use flakescatter::stats::{GaussianWidth, Orientation};

fn export(c: &mut Criterion) {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let flakes = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/real/paints/blue-metallic-paint2.csv");
    let m = read_measurement(&path, MeasuredKind::Brdf).unwrap();
    let opts = FitOptions {
        families: vec![Family::LogLinear {
            knots: Family::default_knots(),
        }],
        ..FitOptions::new()
    };
    let paint = PaintModel::new(fit(&m, &opts).unwrap().params).unwrap();
    let rgb = paint_rgb(&paint).unwrap();
    let mut g = c.benchmark_group("export");
    g.sample_size(10);
    g.throughput(Throughput::Elements(3 * 90 * 90 * 180));
    g.bench_function("merl_flakes_full_table", |b| {
        b.iter(|| merl_table(black_box(&BrdfSource::Distribution(&flakes)), &|_, _| {}).unwrap());
    });
    g.bench_function("merl_paint_full_table", |b| {
        let source = BrdfSource::Paint { model: &paint, rgb };
        b.iter(|| merl_table(black_box(&source), &|_, _| {}).unwrap());
    });
    g.finish();
}

criterion_group!(benches, export);
criterion_main!(benches);
