//! Reading a large X3P: 4096 x 4096 float64 heights (128 MiB of data), target < 1 s.
//!
//! The heights are smooth plus noise in every mantissa bit, as a measured map's are, and
//! some are NaN (so there is a `valid.bin`). Two files are written once to the system
//! temp directory and read repeatedly:
//! * **deflated** (`read_x3p/4096x4096_f64`): every member deflated at level 1 by the
//!   zip crate (zlib-rs), as this crate's writer did for every `data.bin` before it
//!   learnt to store one that does not compress. Such a `data.bin` is fixed-Huffman
//!   literals, 6 % larger than its bytes, like the deflated members other software
//!   writes of noisy float64 heights (a measured file here deflates to 96 % at the
//!   default level, and inflates no faster).
//! * **stored** (`read_x3p/stored_4096x4096_f64`): the file this crate's writer writes
//!   of the same map, whose `data.bin` it stores (zip method 0) because a sample of it
//!   does not deflate.
//!
//! Floors (`floor_…`, `floor_stored_…`): reading the same file's bytes into memory and
//! summing them once (no inflate, no parsing, no checksum).
//!
//! Compute limits, the step that bounds each read, alone on the same input:
//! * `read_x3p/inflate_4096x4096_f64`: the deflated file's `bindata/data.bin` inflated
//!   by the zip crate's streaming inflater (zlib-rs, the one the read streams a poorly
//!   compressed member with), through the same 1 MiB file buffer, into one reused
//!   1 MiB buffer: no parsing, no checksum but the zip crate's CRC-32, no decoding, no
//!   heights vector. The read runs the MD5 and the decoding on a second thread while
//!   this inflates; it cannot be faster than this alone.
//! * `read_x3p/md5_4096x4096_f64`: the MD5 of `data.bin`'s bytes, in memory. The read
//!   of the stored file computes it on a second thread while the member is copied out
//!   of the archive; it cannot be faster than this alone.

use criterion::{Criterion, criterion_group, criterion_main};
use flakescatter_io::{MapFormat, ReadOptions, read_map, write_map};
use flakescatter_stats::heightmap::HeightMap;
use md5::Digest;
use std::io::Read;

#[path = "../tests/support/repack.rs"]
mod repack;
use repack::deflate_members;

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
    let dir = std::env::temp_dir();
    let stored = dir.join(format!(
        "flakescatter-bench-{}-stored.x3p",
        std::process::id()
    ));
    write_map(&map, &stored, MapFormat::X3p).expect("write bench file");
    let path = dir.join(format!("flakescatter-bench-{}.x3p", std::process::id()));
    let stored_bytes = std::fs::read(&stored).expect("read bench file");
    std::fs::write(&path, deflate_members(&stored_bytes)).expect("write deflated bench file");
    let mut data = Vec::new();
    zip::ZipArchive::new(std::io::Cursor::new(&stored_bytes))
        .expect("bench file is a zip archive")
        .by_name("bindata/data.bin")
        .expect("data.bin")
        .read_to_end(&mut data)
        .expect("data.bin bytes");
    assert_eq!(data.len(), N * N * 8, "bindata/data.bin");

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
    group.bench_function("floor_stored_4096x4096_f64", |b| {
        b.iter(|| {
            let bytes = std::fs::read(&stored).expect("read bench file bytes");
            bytes.iter().map(|&v| u64::from(v)).sum::<u64>()
        })
    });
    group.bench_function("md5_4096x4096_f64", |b| b.iter(|| md5::Md5::digest(&data)));
    group.bench_function("stored_4096x4096_f64", |b| {
        b.iter(|| {
            let (m, _) = read_map(&stored, &ReadOptions::default()).expect("read bench file");
            assert_eq!(m.len(), N * N);
            m
        })
    });
    group.finish();
    let _ = std::fs::remove_file(&path);
    let _ = std::fs::remove_file(&stored);
}

criterion_group!(benches, bench_read);
criterion_main!(benches);
