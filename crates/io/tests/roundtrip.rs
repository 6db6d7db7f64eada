//! `read(write(map))` reproduces a map exactly (heights bit for bit on valid points, mask,
//! pitch), for the X3P, SDF and plain-text writers, over random maps (proptest), and
//! X3P → SDF → X3P keeps every height, the mask and the pitch.
//!
//! The reference is the input map itself, so this checks the writer and the reader
//! against each other; the readers are checked against files from other software in
//! `real_files.rs`.

use flakescatter_io::{
    ChannelSelector, MapFormat, ReadOptions, ValueKind, read_intensity_bytes, read_map,
    read_map_bytes, read_selected, read_selected_bytes, sdf, text, write_map, x3p,
};
use flakescatter_stats::heightmap::HeightMap;
use proptest::prelude::*;

#[path = "support/repack.rs"]
mod repack;
use repack::deflate_members;

/// Heights drawn from the whole f64 range (any finite bit pattern, including -0.0 and
/// subnormals) plus invalid points (NaN or masked-out finite values).
fn height() -> impl Strategy<Value = (f64, bool)> {
    prop_oneof![
        6 => any::<f64>().prop_filter("finite", |v| v.is_finite()).prop_map(|v| (v, true)),
        2 => (-1e3f64..1e3).prop_map(|v| (v, true)),
        1 => Just((f64::NAN, true)),
        1 => (-1e3f64..1e3).prop_map(|v| (v, false)),
    ]
}

fn pitch() -> impl Strategy<Value = f64> {
    prop_oneof![
        1e-4f64..1e4,
        Just(2.58),
        Just(0.1),
        Just(1.0 / 3.0),
        any::<f64>().prop_filter("usable pitch", |v| v.is_finite()
            && *v > 1e-200
            && *v < 1e200),
    ]
}

prop_compose! {
    fn heightmap()(nx in 1usize..12, ny in 1usize..12)
        (points in proptest::collection::vec(height(), nx * ny), nx in Just(nx), ny in Just(ny),
         dx in pitch(), dy in pitch()) -> HeightMap {
        let (z, valid): (Vec<f64>, Vec<bool>) = points.into_iter().unzip();
        HeightMap::with_mask(nx, ny, dx, dy, z, valid).unwrap()
    }
}

fn assert_same(a: &HeightMap, b: &HeightMap) {
    assert_eq!((a.nx(), a.ny()), (b.nx(), b.ny()));
    assert_eq!(
        a.dx().to_bits(),
        b.dx().to_bits(),
        "dx {} vs {}",
        a.dx(),
        b.dx()
    );
    assert_eq!(
        a.dy().to_bits(),
        b.dy().to_bits(),
        "dy {} vs {}",
        a.dy(),
        b.dy()
    );
    assert_eq!(a.valid(), b.valid());
    for (i, v) in a.valid().iter().enumerate() {
        if *v {
            assert_eq!(
                a.heights()[i].to_bits(),
                b.heights()[i].to_bits(),
                "point {i}"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 300,
        rng_seed: proptest::test_runner::RngSeed::Fixed(25178),
        ..ProptestConfig::default()
    })]

    #[test]
    fn x3p_round_trip(map in heightmap()) {
        let bytes = x3p::write_x3p_bytes(&map).unwrap();
        let (back, format) = read_map_bytes(&bytes, &ReadOptions::default()).unwrap();
        prop_assert_eq!(format, MapFormat::X3p);
        assert_same(&map, &back);
        prop_assert_eq!(back.metadata()["x3p.md5"].as_str(), "ok");
    }

    #[test]
    fn intensity_round_trip(map in heightmap()) {
        for bytes in [
            x3p::write_intensity_x3p_bytes(&map).unwrap(),
            text::write_intensity_text_string(&map).into_bytes(),
        ] {
            let (back, _) = read_intensity_bytes(&bytes, &ReadOptions::default()).unwrap();
            assert_same(&map, &back);
        }
    }

    #[test]
    fn sdf_text_round_trip(map in heightmap()) {
        let s = sdf::write_sdf_text(&map, ValueKind::Height);
        let (back, format) = read_map_bytes(s.as_bytes(), &ReadOptions::default()).unwrap();
        prop_assert_eq!(format, MapFormat::Sdf);
        assert_same(&map, &back);
        let s = sdf::write_sdf_text(&map, ValueKind::Intensity);
        let (back, _) = read_intensity_bytes(s.as_bytes(), &ReadOptions::default()).unwrap();
        assert_same(&map, &back);
    }

    #[test]
    fn x3p_to_sdf_to_x3p_is_exact(map in heightmap()) {
        let (from_x3p, _) =
            read_map_bytes(&x3p::write_x3p_bytes(&map).unwrap(), &ReadOptions::default()).unwrap();
        let s = sdf::write_sdf_text(&from_x3p, ValueKind::Height);
        let (from_sdf, _) = read_map_bytes(s.as_bytes(), &ReadOptions::default()).unwrap();
        assert_same(&from_x3p, &from_sdf);
        let (again, _) =
            read_map_bytes(&x3p::write_x3p_bytes(&from_sdf).unwrap(), &ReadOptions::default())
                .unwrap();
        assert_same(&from_x3p, &again);
    }

    #[test]
    fn sdf_binary_round_trip(map in heightmap()) {
        // Heights and mask exact; the pitch passes through f64 metres (× 1e-6, × 1e6),
        // two roundings of at most half an ulp each.
        let b = sdf::write_sdf_binary(&map, ValueKind::Height).unwrap();
        let (back, format) = read_map_bytes(&b, &ReadOptions::default()).unwrap();
        prop_assert_eq!(format, MapFormat::Sdf);
        prop_assert_eq!(back.valid(), map.valid());
        for (i, v) in map.valid().iter().enumerate() {
            if *v {
                prop_assert_eq!(back.heights()[i].to_bits(), map.heights()[i].to_bits());
            }
        }
        for (a, b) in [(map.dx(), back.dx()), (map.dy(), back.dy())] {
            prop_assert!((a - b).abs() <= 2.0 * f64::EPSILON * a, "{} vs {}", a, b);
        }
    }

    #[test]
    fn text_round_trip(map in heightmap()) {
        let s = text::write_text_string(&map);
        let (back, format) = read_map_bytes(s.as_bytes(), &ReadOptions::default()).unwrap();
        prop_assert_eq!(format, MapFormat::Text);
        assert_same(&map, &back);
    }
}

#[test]
fn files_round_trip_and_valid_bin_only_when_needed() {
    let dir = std::env::temp_dir();
    let pid = std::process::id();
    let full = HeightMap::new(2, 2, 0.5, 0.75, vec![1.0, -2.0, 3.5, 0.0]).unwrap();
    let holed = HeightMap::new(2, 2, 0.5, 0.75, vec![1.0, f64::NAN, 3.5, 0.0]).unwrap();
    for (map, has_valid) in [(&full, false), (&holed, true)] {
        for format in [MapFormat::X3p, MapFormat::Sdf, MapFormat::Text] {
            let path = dir.join(format!("flakescatter-io-rt-{pid}-{has_valid}.{format}"));
            write_map(map, &path, format).unwrap();
            let (back, f) = read_map(&path, &ReadOptions::default()).unwrap();
            if format == MapFormat::X3p {
                let bytes = std::fs::read(&path).unwrap();
                let zip = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
                let names: Vec<String> =
                    zip.file_names().map(|n| n.unwrap().into_owned()).collect();
                assert_eq!(names.iter().any(|n| n == "bindata/valid.bin"), has_valid);
            }
            std::fs::remove_file(&path).unwrap();
            assert_eq!(f, format);
            assert_same(map, &back);
        }
    }
    // The instrument formats are read, not written; the error says so.
    let e = write_map(&full, dir.join("x.gwy"), MapFormat::Gwy).unwrap_err();
    assert!(e.to_string().contains("not supported"), "{e}");
    // The binary header's counts are 16-bit.
    let wide = HeightMap::new(65536, 1, 1.0, 1.0, vec![0.0; 65536]).unwrap();
    assert!(sdf::write_sdf_binary(&wide, ValueKind::Height).is_err());
}

/// A file of 8 MiB or more that starts like a zip archive is read as X3P straight from
/// the file (its members inflated or copied out as they are read) rather than read
/// whole first, by `read_map` and `read_selected` (what the commands use): the same
/// map, the same metadata and the same errors as reading its bytes, whatever the
/// extension (`x3p`, none, one no format claims), for a stored and a deflated
/// `data.bin`. The reference is the written map itself.
#[test]
fn large_x3p_files_read_from_the_file_as_from_their_bytes() {
    let (nx, ny) = (1200, 1000);
    // Incompressible heights (random mantissas, from proptest's seeded generator), so
    // the file is about 9.6 MB.
    let mut rng = proptest::test_runner::TestRng::deterministic_rng(
        proptest::test_runner::RngAlgorithm::ChaCha,
    );
    let z: Vec<f64> = (0..nx * ny)
        .map(|i| {
            let v = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            if i % 1013 == 0 { f64::NAN } else { v }
        })
        .collect();
    let map = HeightMap::new(nx, ny, 0.25, 0.5, z).unwrap();
    let dir = std::env::temp_dir();
    let pid = std::process::id();
    let written = dir.join(format!("flakescatter-io-large-{pid}-written.x3p"));
    write_map(&map, &written, MapFormat::X3p).unwrap();
    let stored = std::fs::read(&written).unwrap();
    std::fs::remove_file(&written).unwrap();
    // As the writer writes it (data.bin stored: noise does not deflate), and with every
    // member deflated, as other software writes such a file (then inflated as it is
    // read).
    let deflated = deflate_members(&stored);
    for (tag, bytes, method) in [
        ("stored", stored, zip::CompressionMethod::Stored),
        ("deflated", deflated, zip::CompressionMethod::Deflated),
    ] {
        let mut zip = zip::ZipArchive::new(std::io::Cursor::new(&bytes)).unwrap();
        assert_eq!(
            zip.by_name("bindata/data.bin").unwrap().compression(),
            method
        );
        drop(zip);
        large_file_reads(&map, &bytes, &format!("{pid}-{tag}"));
    }
}

/// [`large_x3p_files_read_from_the_file_as_from_their_bytes`] for one archive, `bytes`
/// of `map`, in files named after `tag`.
fn large_file_reads(map: &HeightMap, bytes: &[u8], tag: &str) {
    let dir = std::env::temp_dir();
    let x3p_path = dir.join(format!("flakescatter-io-large-{tag}.x3p"));
    std::fs::write(&x3p_path, bytes).unwrap();
    assert!(bytes.len() >= 8 << 20, "{} bytes", bytes.len());
    let (from_bytes, _) = read_map_bytes(bytes, &ReadOptions::default()).unwrap();
    assert_same(map, &from_bytes);
    let bare = dir.join(format!("flakescatter-io-large-{tag}"));
    let other = dir.join(format!("flakescatter-io-large-{tag}.dat"));
    let truncated = dir.join(format!("flakescatter-io-large-{tag}-cut.x3p"));
    std::fs::write(&bare, bytes).unwrap();
    std::fs::write(&other, bytes).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() - 1000]).unwrap();
    for path in [&x3p_path, &bare, &other] {
        let (back, format) = read_map(path, &ReadOptions::default()).unwrap();
        assert_eq!(format, MapFormat::X3p);
        assert_same(map, &back);
        assert_eq!(back.metadata(), from_bytes.metadata(), "{}", path.display());
        // Options are checked as for the bytes: channel 0 exists, 1 does not, and the
        // text-only `z_unit` is refused.
        let channel = |c| ReadOptions {
            channel: Some(c),
            ..ReadOptions::default()
        };
        assert!(read_map(path, &channel(0)).is_ok());
        let e = read_map(path, &channel(1)).unwrap_err().to_string();
        let want = read_map_bytes(bytes, &channel(1)).unwrap_err().to_string();
        assert!(e.contains(&want), "{e} / {want}");
        let unit = ReadOptions {
            z_unit: Some("um".parse::<flakescatter_io::ZUnit>().unwrap()),
            ..ReadOptions::default()
        };
        let e = read_map(path, &unit).unwrap_err().to_string();
        let want = read_map_bytes(bytes, &unit).unwrap_err().to_string();
        assert!(e.contains(&want), "{e} / {want}");
        // What the commands use: channel selectors, and an intensity channel, which an
        // X3P file does not have apart from its heights.
        let ext = path.extension().and_then(|e| e.to_str());
        let z = ChannelSelector::Name("Z".into());
        let picked = read_selected(path, &ReadOptions::default(), Some(&z), None).unwrap();
        assert_same(map, &picked.map);
        assert_eq!(picked.map.metadata(), from_bytes.metadata());
        assert_eq!((picked.format, picked.channel), (MapFormat::X3p, 0));
        let want =
            read_selected_bytes(bytes, ext, &ReadOptions::default(), Some(&z), None).unwrap();
        assert_eq!(picked.channels, want.channels);
        let e = read_selected(path, &ReadOptions::default(), None, Some(&z))
            .unwrap_err()
            .to_string();
        let want = read_selected_bytes(bytes, ext, &ReadOptions::default(), None, Some(&z))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&want), "{e} / {want}");
    }
    // A cut archive (no central directory) is refused naming the file, with the error
    // its bytes give.
    let e = read_map(&truncated, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    let want = read_map_bytes(&bytes[..bytes.len() - 1000], &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains(&want) && e.contains("-cut.x3p"), "{e} / {want}");
    for path in [&x3p_path, &bare, &other, &truncated] {
        std::fs::remove_file(path).unwrap();
    }
}

/// The X3P writer stores `data.bin` when deflating it would not pay and deflates it
/// otherwise, and either reads back exactly. The reference for what was written is the
/// zip crate's reading of the archive's central directory (method, sizes); for whether
/// deflate pays, the data themselves: float64 numbers with 52 random mantissa bits
/// cannot be deflated at level 1 to 90 % of their size (its fixed-Huffman literals cost
/// at least 8 bits a byte), while a map of 16 repeated levels deflates to well under a
/// tenth.
#[test]
fn x3p_data_bin_is_stored_when_deflating_it_does_not_pay() {
    let mut rng = proptest::test_runner::TestRng::deterministic_rng(
        proptest::test_runner::RngAlgorithm::ChaCha,
    );
    let mut noise = |n: usize| -> Vec<f64> {
        (0..n)
            .map(|_| (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
            .collect()
    };
    // (what, nx, ny, heights, stored): the large maps are sampled in slices, the small
    // one whole.
    let cases = [
        ("noise, 1024 x 512", 1024, 512, noise(1024 * 512), true),
        ("noise, 20 x 20", 20, 20, noise(400), true),
        (
            "16 levels, 1024 x 512",
            1024,
            512,
            (0..1024 * 512)
                .map(|i| f64::from(i / 4096 % 16) * 0.25)
                .collect(),
            false,
        ),
        (
            "16 levels, 20 x 20",
            20,
            20,
            (0..400).map(|i| f64::from(i / 25 % 16) * 0.25).collect(),
            false,
        ),
    ];
    for (what, nx, ny, z, stored) in cases {
        let map = HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap();
        let bytes = x3p::write_x3p_bytes(&map).unwrap();
        let mut zip = zip::ZipArchive::new(std::io::Cursor::new(&bytes)).unwrap();
        let data = zip.by_name("bindata/data.bin").unwrap();
        let raw = 8 * (nx * ny) as u64;
        assert_eq!(data.size(), raw, "{what}");
        if stored {
            assert_eq!(data.compression(), zip::CompressionMethod::Stored, "{what}");
            assert_eq!(data.compressed_size(), raw, "{what}");
        } else {
            assert_eq!(
                data.compression(),
                zip::CompressionMethod::Deflated,
                "{what}"
            );
            assert!(
                data.compressed_size() * 10 < raw,
                "{what}: {}",
                data.compressed_size()
            );
        }
        drop(data);
        let (back, _) = read_map_bytes(&bytes, &ReadOptions::default()).unwrap();
        assert_same(&map, &back);
    }
}
