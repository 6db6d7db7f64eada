//! Cost of spectrum → CIELAB: building the tristimulus weights for a sampling (once per
//! sampling) and applying them to one spectrum (once per spectrum), at the three
//! samplings users bring: 1 nm 360–830 (summation), 10 nm 400–700 (Lagrange weights, the
//! multi-angle instruments' output) and an irregular 3–7 nm grid 380–780 (Lagrange).
//! The spectrum is a smooth seeded curve; D65 / 10°.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flakescatter_colour::{Illuminant, Observer, TristimulusWeights};

fn grid(start: f64, end: f64, step: f64) -> Vec<f64> {
    let n = ((end - start) / step).round() as usize;
    (0..=n).map(|i| start + step * i as f64).collect()
}

fn irregular() -> Vec<f64> {
    // Steps cycle through 3, 5, 7, 4, 6 nm (seeded by construction, no RNG needed).
    let steps = [3.0f64, 5.0, 7.0, 4.0, 6.0];
    let mut wl = vec![380.0f64];
    let mut i = 0;
    while *wl.last().unwrap() < 780.0 {
        let next = (wl.last().unwrap() + steps[i % steps.len()]).min(780.0);
        wl.push(next);
        i += 1;
    }
    wl
}

fn spectrum(wl: &[f64]) -> Vec<f64> {
    wl.iter()
        .map(|w| 0.1 + 0.6 / (1.0 + (-(w - 590.0) / 20.0).exp()))
        .collect()
}

fn bench(c: &mut Criterion) {
    let cases = [
        ("1nm_360_830", grid(360.0, 830.0, 1.0)),
        ("10nm_400_700", grid(400.0, 700.0, 10.0)),
        ("irregular_380_780", irregular()),
    ];
    let mut group = c.benchmark_group("spectrum_to_lab");
    for (name, wl) in &cases {
        let r = spectrum(wl);
        let weights =
            TristimulusWeights::new(wl, Illuminant::D65, Observer::Cie1964TenDegree).unwrap();
        group.bench_function(format!("apply/{name}"), |b| {
            b.iter(|| weights.lab(black_box(&r)).unwrap())
        });
        group.bench_function(format!("build_and_apply/{name}"), |b| {
            b.iter(|| {
                TristimulusWeights::new(black_box(wl), Illuminant::D65, Observer::Cie1964TenDegree)
                    .unwrap()
                    .lab(black_box(&r))
                    .unwrap()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
