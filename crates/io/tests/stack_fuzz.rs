//! Bounded mutation fuzzing of the stack reader: mutated bytes of the stack fixtures
//! (bit flips, truncations, insertions, overwrites, and overwrites of whole TIFF
//! directory entries) never make the reader panic or allocate without bound; each input
//! opens and streams its slices, or gives an error.
//!
//! Seeds: the three fixtures of `tests/data/stack` (tifffile ImageJ and OME-TIFF, a
//! byte-built LSM file with thumbnails) and one LZW-compressed stack written here.

use std::io::Cursor;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use flakescatter_io::stack::{StackOptions, StackReader};
use proptest::prelude::*;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stack");

fn seeds() -> Vec<Vec<u8>> {
    let mut v: Vec<Vec<u8>> = ["imagej-u16.tif", "ome-u16-topfirst.ome.tif", "zeiss-u8.lsm"]
        .iter()
        .map(|n| std::fs::read(format!("{DATA}/{n}")).unwrap())
        .collect();
    // LZW pages with the horizontal predictor, so mutations reach a decompressor.
    let mut buf = Cursor::new(Vec::new());
    {
        let mut enc = tiff::encoder::TiffEncoder::new(&mut buf)
            .unwrap()
            .with_compression(tiff::encoder::Compression::Lzw)
            .with_predictor(tiff::tags::Predictor::Horizontal);
        for k in 0..4u16 {
            let data: Vec<u16> = (0..64u16).map(|i| i * 300 + k * 7).collect();
            enc.write_image::<tiff::encoder::colortype::Gray16>(8, 8, &data)
                .unwrap();
        }
    }
    v.push(buf.into_inner());
    v
}

#[derive(Debug, Clone)]
enum Mutation {
    FlipBit(usize, u8),
    Truncate(usize),
    Insert(usize, Vec<u8>),
    Overwrite(usize, u8),
    /// Overwrites four aligned bytes: hits counts, offsets and tag values whole.
    Word(usize, u32),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        3 => (any::<usize>(), 0u8..8).prop_map(|(i, b)| Mutation::FlipBit(i, b)),
        1 => any::<usize>().prop_map(Mutation::Truncate),
        1 => (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
        2 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Overwrite(i, b)),
        3 => (any::<usize>(), prop_oneof![Just(0u32), Just(1), Just(3), Just(u32::MAX),
                                          Just(1 << 16), Just(1 << 28), any::<u32>()])
            .prop_map(|(i, w)| Mutation::Word(i, w)),
    ]
}

fn apply(mut bytes: Vec<u8>, muts: &[Mutation]) -> Vec<u8> {
    for m in muts {
        if bytes.len() < 4 {
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
            Mutation::Word(i, w) => {
                let at = (i % (n - 3)) & !1;
                bytes[at..at + 4].copy_from_slice(&w.to_le_bytes());
            }
        }
    }
    bytes
}

static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
static TRIED: AtomicUsize = AtomicUsize::new(0);
static STREAMED: AtomicUsize = AtomicUsize::new(0);

proptest! {
    // Fixed seed; 20 000 inputs take about two seconds.
    #![proptest_config(ProptestConfig {
        cases: 20_000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x57ac_f022),
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_stacks_never_panic(
        seed in any::<prop::sample::Index>(),
        muts in proptest::collection::vec(mutation(), 1..4),
    ) {
        let all = SEEDS.get_or_init(seeds);
        let bytes = apply(all[seed.index(all.len())].clone(), &muts);
        let options = StackOptions {
            pixel_um: Some((0.2, 0.2)),
            z_step_um: Some(0.3),
            first_page: None,
        };
        if let Ok(mut r) = StackReader::new(Cursor::new(&bytes[..]), &options) {
            let n = r.info().nx * r.info().ny;
            let mut complete = true;
            loop {
                match r.next_slice() {
                    Ok(Some(s)) => prop_assert_eq!(s.len(), n),
                    Ok(None) => break,
                    Err(_) => {
                        complete = false;
                        break;
                    }
                }
            }
            if complete {
                STREAMED.fetch_add(1, Ordering::Relaxed);
            }
        }
        let n = TRIED.fetch_add(1, Ordering::Relaxed) + 1;
        if n.is_multiple_of(5000) {
            eprintln!("stack fuzz: {n} inputs, {} streamed completely", STREAMED.load(Ordering::Relaxed));
        }
    }
}
