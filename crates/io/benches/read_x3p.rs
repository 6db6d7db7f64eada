//! Reading a large X3P: 4096 x 4096 float64 heights (128 MiB of data), target < 1 s.
//!
//! The file is written once to the system temp directory by this crate's writer
//! (deflate level 1, with `valid.bin` because some points are NaN), then read repeatedly.
//!
//! `read_x3p/floor_4096x4096_f64` is the floor `cargo xtask bench` compares the read
//! with: reading the same file's bytes into memory and summing them once (no inflate,
//! no parsing, no checksum).
//!
//! `read_x3p/inflate_4096x4096_f64` is the read's compute limit: the same file's
//! `bindata/data.bin` inflated by the zip crate's streaming inflater (zlib-rs, the one the
//! read streams a poorly compressed member with: this one does not compress, its
//! level-1 deflate stream is 6 % larger than its bytes), through the same 1 MiB file
//! buffer, into one reused 1 MiB buffer: no parsing, no checksum but the zip crate's
//! CRC-32, no decoding, no heights vector. The read runs the MD5 and the decoding on a
//! second thread while this inflates; it cannot be faster than this alone.

use criterion::{Criterion, criterion_group, criterion_main};
use flakescatter_io::{MapFormat, ReadOptions, read_map, write_map};
use flakescatter_stats::heightmap::HeightMap;

const N: usize = 4096;

fn bench_read(c: &mut Criterion) {
    // A seeded, smooth-plus-noise surface (a small LCG, no RNG crate needed), µm.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let z: Vec<f64> = (0..N * N)
        .map(|i| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let noise = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            let (row, col) = ((i / N) as f64, (i % N) as f64);
            if i % 997 == 0 {
                f64::NAN
            } else {
                (row * 0.01).sin() + (col * 0.013).cos() + 0.05 * noise
            }
        })
        .collect();
    let map = HeightMap::new(N, N, 0.25, 0.25, z).expect("valid map");
    let path = std::env::temp_dir().join(format!("flakescatter-bench-{}.x3p", std::process::id()));
    write_map(&map, &path, MapFormat::X3p).expect("write bench file");

    let mut group = c.benchmark_group("read_x3p");
    group.sample_size(10);
    group.bench_function("floor_4096x4096_f64", |b| {
        b.iter(|| {
            let bytes = std::fs::read(&path).expect("read bench file bytes");
            bytes.iter().map(|&v| u64::from(v)).sum::<u64>()
        })
    });
    group.bench_function("inflate_4096x4096_f64", |b| {
        let mut out = vec![0u8; 1 << 20];
        b.iter(|| {
            let file = std::fs::File::open(&path).expect("open bench file");
            let mut archive =
                zip::ZipArchive::new(std::io::BufReader::with_capacity(1 << 20, file))
                    .expect("bench file is a zip archive");
            let mut member = archive.by_name("bindata/data.bin").expect("data.bin");
            let mut total = 0usize;
            loop {
                let k = std::io::Read::read(&mut member, &mut out).expect("inflate data.bin");
                if k == 0 {
                    break;
                }
                total += k;
            }
            assert_eq!(total, N * N * 8);
            total
        })
    });
    group.bench_function("4096x4096_f64", |b| {
        b.iter(|| {
            let (m, _) = read_map(&path, &ReadOptions::default()).expect("read bench file");
            assert_eq!(m.len(), N * N);
            m
        })
    });
    group.finish();
    let _ = std::fs::remove_file(&path);
}

criterion_group!(benches, bench_read);
criterion_main!(benches);
