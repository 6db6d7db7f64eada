//! Bounded mutation test of every reader, part of `cargo test` (a few seconds, fixed
//! seed): mutated bytes of real files and of small hand-made inputs (bit flips,
//! truncations, insertions, byte overwrites) never make a reader panic; they load or
//! give an error, and every table error names the file. The coverage-guided fuzz targets
//! in `fuzz/` explore further (docs/reliability.md); what they find is kept as a
//! regression test in this directory, its input in `tests/data/fuzz/` (so far one: the
//! `plu` target's overflowing layer size, `instruments.rs`).
//!
//! The X3P seeds are re-packed with stored (uncompressed) members as well as read as
//! shipped, so that mutations reach `main.xml` and `data.bin` themselves and not only the
//! deflate stream (whose CRC would otherwise catch almost every change).

use std::io::{Read, Write};
use std::sync::LazyLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use flakescatter_io::{
    DecimalMark, ReadOptions, ValueKind, ZUnit, curves, detectors, flakes, list_channels_bytes,
    measured, read_bytes, spectral,
};
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

static MAP_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(|| {
    let mut v = vec![
        load("pyramid.x3p"),
        stored(&load("pyramid.x3p")),
        load("testing.x3p"),
        stored(&load("testing.x3p")),
        load("surfacetopography-sdf-1.sdf"),
        load("sdfio-mm11_iso1_ascii_int32.sdf"),
        load("surfacetopography-gwyddion-export-english.txt"),
        load("surfacetopography-gwyddion-export-german.txt"),
        load("surfacetopography-txt_example.txt"),
        load("surfacetopography-csv-1.csv"),
        // Decimal commas, `;`, CRLF, Latin-1, lone CR, a unit-less intensity header.
        b"# Breite: 2,0 \xb5m\n# H\xf6he: 2,0 \xb5m\n# Werteinheiten: \xb5m\n1,5 2,25\n-0,5 4\n"
            .to_vec(),
        b"1,5;2,25;3\r\n-0,5;4;1,5e-3;\r\n".to_vec(),
        b"1, 2, 3\r4, 5, 6\r".to_vec(),
        b"# Width: 2 um\n# Height: 1 um\n# Value units: a.u.\n0.5 NaN\n".to_vec(),
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
});

/// `(reader, seed)` for the table readers (0–4) and the spectral file readers (5–9).
static TABLE_SEEDS: LazyLock<Vec<(usize, Vec<u8>)>> = LazyLock::new(|| {
    let head = |path: &str, n: usize, eol: &str| {
        let text = std::fs::read_to_string(format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR")))
            .unwrap();
        let mut s = text.lines().take(n).collect::<Vec<_>>().join(eol);
        s.push_str(eol);
        s.into_bytes()
    };
    vec![
        (0, head("docs/figures/measured.csv", 8, "\n")),
        (
            0,
            b"# m\r\ntheta_i_deg,theta_s_deg,value,uncertainty\r\n30,-30,1.5,0.01\r\n".to_vec(),
        ),
        (1, head("fixtures/synth-hwhm3-smooth.truth.csv", 6, "\r\n")),
        (
            1,
            b"theta_x_deg,theta_y_deg,area_um2\n45,0,3\n-1.5,2,0.5\n".to_vec(),
        ),
        (
            1,
            b"x1_um,z1_um,x2_um,z2_um,y1_um,zy1_um,y2_um,zy2_um\n0,5,10,6,0,1,20,1\n".to_vec(),
        ),
        (2, head("docs/figures/fig7.csv", 8, "\n")),
        (3, b"theta_r_deg,phi_r_deg\n30,0\n30,90\n60,-180\n".to_vec()),
        (4, head("docs/figures/fig4.csv", 8, "\r")),
        (
            5,
            head("crates/optics/data/aluminium_rakic1995.csv", 16, "\n"),
        ),
        (6, b"wavelength_nm,n\r\n400,1.52\r\n700,1.50\r\n".to_vec()),
        (
            7,
            head(
                "crates/flakescatter/tests/data/spectral/binder_alpha.csv",
                6,
                "\n",
            ),
        ),
        (
            8,
            head(
                "crates/flakescatter/tests/data/spectral/reference_spectra.csv",
                8,
                "\n",
            ),
        ),
        (
            9,
            b"theta_i_deg,aspecular_deg,L,a,b\n45,15,90.5,-0.6,-1.4\n45,45,40,-0.2,-0.9\n".to_vec(),
        ),
    ]
});

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

/// Reader options from one byte, as the fuzz targets draw them.
fn options(b: u8) -> (ReadOptions, ValueKind) {
    let options = ReadOptions {
        pixel_um: (b & 1 != 0).then_some((0.5, 0.25)),
        z_unit: [None, Some(ZUnit::Um), Some(ZUnit::Nm), Some(ZUnit::M)][usize::from(b >> 1) & 3],
        accept_md5_mismatch: b & 8 != 0,
        decimal: [DecimalMark::Auto, DecimalMark::Point, DecimalMark::Comma]
            [usize::from(b >> 4) % 3],
        channel: (b & 64 != 0).then_some(0),
        as_stored: b % 7 == 3,
    };
    let kind = if b & 128 != 0 {
        ValueKind::Intensity
    } else {
        ValueKind::Height
    };
    (options, kind)
}

const EXTENSIONS: [Option<&str>; 5] = [None, Some("x3p"), Some("sdf"), Some("txt"), Some("dat")];

static TRIED: AtomicUsize = AtomicUsize::new(0);
static LOADED: AtomicUsize = AtomicUsize::new(0);

proptest! {
    // Fixed seed; about 30 000 map inputs and 20 000 table inputs take a few seconds. A
    // panic found here once (a profile header over one-column rows) is kept as a
    // regression test in `bad_input.rs`.
    #![proptest_config(ProptestConfig {
        cases: 30_000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_f1a4e),
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_maps_never_panic(
        seed in any::<prop::sample::Index>(),
        muts in proptest::collection::vec(mutation(), 1..4),
        flags in any::<u8>(),
        ext in 0..EXTENSIONS.len(),
    ) {
        let seed = &MAP_SEEDS[seed.index(MAP_SEEDS.len())];
        let bytes = apply(seed.clone(), &muts);
        let (mut options, kind) = options(flags);
        // The text-only options make X3P and SDF heights fail at once (a flag is honoured
        // or refused); leave them out of most calibrated cases so the readers are reached.
        if flags & 4 == 0 && (!seed.is_ascii() || seed.starts_with(b"aISO")) {
            options.z_unit = None;
            options.decimal = DecimalMark::Auto;
        }
        // Either outcome is fine; a panic fails the test.
        let _ = list_channels_bytes(&bytes, EXTENSIONS[ext], &options);
        if let Ok((map, _)) = read_bytes(&bytes, EXTENSIONS[ext], &options, kind) {
            prop_assert_eq!(map.heights().len(), map.nx() * map.ny());
            prop_assert!(map.dx() > 0.0 && map.dy() > 0.0);
            LOADED.fetch_add(1, Ordering::Relaxed);
        }
        let n = TRIED.fetch_add(1, Ordering::Relaxed) + 1;
        if n.is_multiple_of(4000) {
            eprintln!("fuzz: {n} mutated maps tried, {} loaded", LOADED.load(Ordering::Relaxed));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 20_000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x7ab1e5),
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_tables_never_panic_and_errors_name_the_file(
        seed in any::<prop::sample::Index>(),
        muts in proptest::collection::vec(mutation(), 1..4),
    ) {
        let (reader, seed) = &TABLE_SEEDS[seed.index(TABLE_SEEDS.len())];
        let bytes = apply(seed.clone(), &muts);
        let r = &bytes[..];
        let err = match reader {
            0 => measured::read_measured_from(r, "m.csv").err(),
            1 => flakes::read_flakes_from(r, "m.csv").err(),
            2 => flakes::read_histogram_from(r, "m.csv").err(),
            3 => detectors::read_detectors_from(r, "m.csv").err(),
            4 => curves::read_curve_from(r, "m.csv").err(),
            5 => spectral::read_complex_index_from(r, "m.csv").err(),
            6 => spectral::read_coat_index_from(r, "m.csv").err(),
            7 => spectral::read_absorption_from(r, "m.csv").err(),
            8 => spectral::read_spectra_from(r, "m.csv").err(),
            _ => spectral::read_multiangle_from(r, "m.csv").err(),
        };
        if let Some(e) = err {
            prop_assert!(e.to_string().contains("m.csv"), "{}", e);
        }
    }
}

/// The native instrument files (`fixtures/real/instruments`), one per reader, with the
/// format's extension (so the extension check is exercised too).
static INSTRUMENT_SEEDS: LazyLock<Vec<(Vec<u8>, &'static str)>> = LazyLock::new(|| {
    [
        ("gwyfile-test.gwy", "gwy"),
        ("plu-1.plu", "plu"),
        ("metropro-1.dat", "dat"),
        ("opd-1.opd", "opd"),
        ("sur-2.sur", "sur"),
        ("al3d-1.al3d", "al3d"),
        ("frt-1.frt", "frt"),
        ("frt-2.frt", "frt"),
    ]
    .into_iter()
    .map(|(name, ext)| (load(&format!("instruments/{name}")), ext))
    .collect()
});

proptest! {
    // Fewer cases: the seeds are 0.1–4 MB each. Most mutations land in the first 2 KiB
    // (headers, directories, tags), where the size fields are; truncations anywhere.
    #![proptest_config(ProptestConfig {
        cases: 5_000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x1257_0a3d),
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_instrument_files_never_panic(
        seed in any::<prop::sample::Index>(),
        muts in proptest::collection::vec(mutation(), 1..4),
        flags in any::<u8>(),
        named in any::<bool>(),
        channel in 0usize..4,
    ) {
        let (seed, ext) = &INSTRUMENT_SEEDS[seed.index(INSTRUMENT_SEEDS.len())];
        let near_header: Vec<Mutation> = muts
            .into_iter()
            .map(|m| match m {
                Mutation::FlipBit(i, b) => Mutation::FlipBit(i % 2048, b),
                Mutation::Overwrite(i, b) => Mutation::Overwrite(i % 2048, b),
                Mutation::Insert(i, b) => Mutation::Insert(i % 2048, b),
                t @ Mutation::Truncate(_) => t,
            })
            .collect();
        let bytes = apply(seed.clone(), &near_header);
        let (mut options, kind) = options(flags);
        options.decimal = DecimalMark::Auto;
        options.channel = (flags & 64 != 0).then_some(channel);
        let ext = named.then_some(*ext);
        let _ = list_channels_bytes(&bytes, ext, &options);
        if let Ok((map, _)) = read_bytes(&bytes, ext, &options, kind) {
            prop_assert_eq!(map.heights().len(), map.nx() * map.ny());
            prop_assert!(map.dx() > 0.0 && map.dy() > 0.0);
        }
    }
}
