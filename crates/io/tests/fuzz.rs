//! Fuzz-style robustness: mutated bytes of the real files (bit flips, truncations,
//! insertions, byte overwrites) never make a reader panic; they load or give an error.
//!
//! The X3P seeds are re-packed with stored (uncompressed) members as well as read as
//! shipped, so that mutations reach `main.xml` and `data.bin` themselves and not only the
//! deflate stream (whose CRC would otherwise catch almost every change).

use std::io::{Read, Write};
use std::sync::atomic::{AtomicUsize, Ordering};

use flakescatter_io::{ReadOptions, ZUnit, read_map_bytes};
use proptest::prelude::*;

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/real");

fn load(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DIR}/{name}")).unwrap()
}

/// Re-packs an archive with every member stored, so mutations hit the content.
fn stored(bytes: &[u8]) -> Vec<u8> {
    let mut src = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for i in 0..src.len() {
        let mut f = src.by_index(i).unwrap();
        if f.is_dir() {
            continue;
        }
        let name = f.name().unwrap().into_owned();
        let mut buf = Vec::new();
        f.read_to_end(&mut buf).unwrap();
        out.start_file(name, opts).unwrap();
        out.write_all(&buf).unwrap();
    }
    out.finish().unwrap().into_inner()
}

fn seeds() -> Vec<Vec<u8>> {
    let mut v = vec![
        load("pyramid.x3p"),
        stored(&load("pyramid.x3p")),
        load("testing.x3p"),
        stored(&load("testing.x3p")),
        load("surfacetopography-sdf-1.sdf"),
        load("surfacetopography-gwyddion-export-english.txt"),
        load("surfacetopography-gwyddion-export-german.txt"),
        load("surfacetopography-txt_example.txt"),
        load("surfacetopography-csv-1.csv"),
    ];
    // A binary SDF header (written from ISO 25178-71) with 2 x 2 float64 values.
    let mut sdf = b"bISO-1.0MAKER".to_vec();
    sdf.extend_from_slice(&[0; 5]);
    sdf.extend_from_slice(b"010120240000010120240000");
    sdf.extend_from_slice(&2u16.to_le_bytes());
    sdf.extend_from_slice(&2u16.to_le_bytes());
    for s in [1e-6f64, 1e-6, 1e-6, 1e-9] {
        sdf.extend_from_slice(&s.to_le_bytes());
    }
    sdf.extend_from_slice(&[0, 7, 0]);
    for z in [1.0f64, 2.0, 3.0, 4.0] {
        sdf.extend_from_slice(&z.to_le_bytes());
    }
    v.push(sdf);
    v
}

#[derive(Debug, Clone)]
enum Mutation {
    FlipBit(usize, u8),
    Truncate(usize),
    Insert(usize, Vec<u8>),
    Overwrite(usize, u8),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<usize>(), 0u8..8).prop_map(|(i, b)| Mutation::FlipBit(i, b)),
        1 => any::<usize>().prop_map(Mutation::Truncate),
        2 => (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
        3 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Overwrite(i, b)),
    ]
}

fn apply(mut bytes: Vec<u8>, muts: &[Mutation]) -> Vec<u8> {
    for m in muts {
        if bytes.is_empty() {
            break;
        }
        let n = bytes.len();
        match m {
            Mutation::FlipBit(i, b) => bytes[i % n] ^= 1 << b,
            Mutation::Truncate(i) => bytes.truncate(i % n),
            Mutation::Insert(i, b) => {
                let at = i % (n + 1);
                bytes.splice(at..at, b.iter().copied());
            }
            Mutation::Overwrite(i, b) => bytes[i % n] = *b,
        }
    }
    bytes
}

static TRIED: AtomicUsize = AtomicUsize::new(0);
static LOADED: AtomicUsize = AtomicUsize::new(0);

proptest! {
    // Fixed seed; about 20 000 inputs take a few seconds. A panic found here once (a profile
    // header over one-column rows) is kept as a regression test in `bad_input.rs`.
    #![proptest_config(ProptestConfig {
        cases: 20_000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_f1a4e),
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_real_files_never_panic(
        seed in any::<prop::sample::Index>(),
        muts in proptest::collection::vec(mutation(), 1..4),
        accept in any::<bool>(),
    ) {
        let all = seeds();
        let bytes = apply(all[seed.index(all.len())].clone(), &muts);
        let options = ReadOptions {
            pixel_um: None,
            z_unit: Some(ZUnit::Um),
            accept_md5_mismatch: accept,
            ..ReadOptions::default()
        };
        // Either outcome is fine; a panic fails the test.
        if read_map_bytes(&bytes, &options).is_ok() {
            LOADED.fetch_add(1, Ordering::Relaxed);
        }
        let n = TRIED.fetch_add(1, Ordering::Relaxed) + 1;
        if n.is_multiple_of(5000) {
            eprintln!("fuzz: {n} mutated inputs tried, {} loaded", LOADED.load(Ordering::Relaxed));
        }
    }
}
