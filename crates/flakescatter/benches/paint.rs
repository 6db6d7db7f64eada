//! Benchmark of the joint paint fit (issue: one shared table of about 1,500 rows × 3
//! channels in under 5 s on 2 cores): the measured blue MERL paint of
//! `fixtures/real/paints`, every row and channel (4,485 values), read once; one
//! iteration is the whole fit as `fit --paint` runs it by default (the four families,
//! each started from the previous one, the lowest BIC kept), and the table family alone.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter::compare::MeasuredKind;
use flakescatter::paint::{Family, FitOptions, fit, read_measurement};

fn joint_fit(c: &mut Criterion) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/real/paints/blue-metallic-paint2.csv");
    let m = read_measurement(&path, MeasuredKind::Brdf).unwrap();
    let values = (m.rows.len() * m.channels.len()) as u64;
    let mut g = c.benchmark_group("paint");
    g.sample_size(10);
    g.throughput(Throughput::Elements(values));
    g.bench_function("joint_fit_blue_auto", |b| {
        b.iter(|| fit(black_box(&m), &FitOptions::new()).unwrap());
    });
    let table = FitOptions {
        families: vec![Family::LogLinear {
            knots: Family::default_knots(),
        }],
        ..FitOptions::new()
    };
    g.bench_function("joint_fit_blue_table", |b| {
        b.iter(|| fit(black_box(&m), &table).unwrap());
    });
    g.finish();
}

criterion_group!(benches, joint_fit);
criterion_main!(benches);
