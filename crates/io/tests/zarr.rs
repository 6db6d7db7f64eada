//! Zarr v3 height-map stores (docs/formats.md "Zarr v3 maps"): a write → read round
//! trip bit for bit, windows against the same slice of the written map, a store written
//! by zarr-python against numpy's numbers, stores written by hand (JSON and raw chunk
//! bytes, independent of both zarrs and our writer), and every bad store the layout
//! refuses, each with the array or attribute named.

use std::path::{Path, PathBuf};

use flakescatter_io::zarr::{ZarrMap, ZarrProblem, ZarrWriteOptions, write_zarr};
use flakescatter_io::{
    ChannelSelector, MapError, MapFormat, ReadMapError, ReadOptions, ValueKind, read_intensity,
    read_map, read_selected, write_map,
};
use flakescatter_stats::heightmap::HeightMap;
use rand::{RngExt, SeedableRng};

/// A `nx × ny` map of awkward doubles (random bits of every exponent, -0.0,
/// subnormals) with a few invalid points, 0.18 × 0.25 µm pixels.
fn awkward_map(nx: usize, ny: usize, seed: u64) -> (HeightMap, Vec<f64>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let z: Vec<f64> = (0..nx * ny)
        .map(|i| match i % 11 {
            0 => -0.0,
            1 => f64::MIN_POSITIVE / 3.0,
            2 => f64::NAN,
            _ => {
                let v = f64::from_bits(rng.random::<u64>());
                if v.is_finite() { v } else { 1.0 / 3.0 }
            }
        })
        .collect();
    (HeightMap::new(nx, ny, 0.18, 0.25, z.clone()).unwrap(), z)
}

fn bits(v: &[f64]) -> Vec<Option<u64>> {
    v.iter()
        .map(|x| x.is_finite().then(|| x.to_bits()))
        .collect()
}

#[test]
fn round_trip_is_bit_exact_and_windows_are_slices() {
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("map.zarr");
    let (nx, ny) = (10, 7);
    let (map, z) = awkward_map(nx, ny, 49);
    // 3 x 4 chunks: partial chunks at the bottom (7 = 2·3 + 1) and right (10 = 2·4 + 2).
    let options = ZarrWriteOptions {
        chunk: (3, 4),
        zstd_level: Some(3),
    };
    write_zarr(&map, None, &store, &options).unwrap();
    let opened = ZarrMap::open(&store).unwrap();
    assert_eq!(opened.shape(), (ny, nx));
    assert_eq!(opened.pitch(), (0.18, 0.25));
    assert_eq!(opened.chunk_shape(), (3, 4));
    let back = opened.read().unwrap();
    assert_eq!(
        (back.nx(), back.ny(), back.dx(), back.dy()),
        (nx, ny, 0.18, 0.25)
    );
    assert_eq!(bits(back.heights()), bits(&z));
    assert_eq!(
        back.valid_count(),
        z.iter().filter(|v| v.is_finite()).count()
    );
    // Every window of every size and place: the same slice of the heights written.
    for y0 in 0..ny {
        for x0 in 0..nx {
            for h in 1..=ny - y0 {
                for w in 1..=nx - x0 {
                    let got = opened.read_window(y0, x0, h, w).unwrap();
                    let want: Vec<f64> = (y0..y0 + h)
                        .flat_map(|r| z[r * nx + x0..r * nx + x0 + w].to_vec())
                        .collect();
                    assert_eq!(bits(&got), bits(&want), "window {y0} {x0} {h} {w}");
                }
            }
        }
    }
    // Only the chunks a window touches are read: with the bottom-right chunk [2, 2]
    // replaced by bytes that do not decode, a window inside chunks [0..2, 0..2] still
    // reads, and one reaching into chunk [2, 2] (or the whole map) is refused.
    let last = store.join("height/c/2/2");
    let kept = std::fs::read(&last).unwrap();
    std::fs::write(&last, b"not zstd").unwrap();
    let inside = opened.read_window(0, 0, 6, 8).unwrap();
    assert_eq!(bits(&inside[..8]), bits(&z[..8]));
    for (y0, x0, h, w) in [(6, 8, 1, 1), (0, 0, ny, nx), (5, 7, 2, 2)] {
        let e = opened.read_window(y0, x0, h, w).unwrap_err();
        assert!(
            matches!(
                e.problem,
                ZarrProblem::Array {
                    array: "height",
                    ..
                }
            ),
            "{e}"
        );
    }
    std::fs::write(&last, kept).unwrap();
    let m = opened.read_window_map(2, 3, 4, 5).unwrap();
    assert_eq!((m.nx(), m.ny(), m.dx(), m.dy()), (5, 4, 0.18, 0.25));
    // Outside the map, or empty: refused, naming the window.
    for (y0, x0, h, w) in [(0, 0, 8, 1), (0, 9, 1, 2), (7, 0, 1, 1), (0, 0, 0, 3)] {
        let e = opened.read_window(y0, x0, h, w).unwrap_err();
        assert!(matches!(e.problem, ZarrProblem::Window { .. }), "{e}");
        assert!(e.to_string().contains("map.zarr"), "{e}");
    }
    // Uncompressed chunks read back the same; a non-empty directory is not written over.
    let raw = dir.path().join("raw.zarr");
    let options = ZarrWriteOptions {
        chunk: (1024, 1024),
        zstd_level: None,
    };
    write_zarr(&map, None, &raw, &options).unwrap();
    assert_eq!(
        bits(ZarrMap::open(&raw).unwrap().read().unwrap().heights()),
        bits(&z)
    );
    let e = write_zarr(&map, None, &raw, &options).unwrap_err();
    assert!(e.to_string().contains("not empty"), "{e}");
}

#[test]
fn read_map_and_intensity_dispatch_to_the_store() {
    let dir = tempfile::tempdir().unwrap();
    let (map, z) = awkward_map(6, 5, 7);
    let intensity = HeightMap::new(6, 5, 0.18, 0.25, (0..30).map(f64::from).collect()).unwrap();
    let store = dir.path().join("both.zarr");
    write_zarr(&map, Some(&intensity), &store, &ZarrWriteOptions::default()).unwrap();
    let (m, format) = read_map(&store, &ReadOptions::default()).unwrap();
    assert_eq!(format, MapFormat::Zarr);
    assert_eq!(bits(m.heights()), bits(&z));
    assert_eq!(m.metadata().get("format").map(String::as_str), Some("zarr"));
    let (i, _) = read_intensity(&store, &ReadOptions::default()).unwrap();
    assert_eq!(i.heights(), intensity.heights());
    assert_eq!(i.quantity(), ValueKind::Intensity);
    // The intensity array as the intensity channel of the same store.
    let sel = read_selected(
        &store,
        &ReadOptions::default(),
        None,
        Some(&ChannelSelector::Name("intensity".into())),
    )
    .unwrap();
    assert_eq!(sel.channels.len(), 2);
    assert_eq!(sel.intensity.unwrap().0.heights(), intensity.heights());
    // A store named without `.zarr` is recognised by its zarr.json.
    let plain = dir.path().join("plain");
    std::fs::rename(&store, &plain).unwrap();
    assert_eq!(
        read_map(&plain, &ReadOptions::default()).unwrap().1,
        MapFormat::Zarr
    );
    // The pitch override applies; --z-unit is refused.
    let o = ReadOptions {
        pixel_um: Some((1.0, 2.0)),
        ..ReadOptions::default()
    };
    let (m, _) = read_map(&plain, &o).unwrap();
    assert_eq!((m.dx(), m.dy()), (1.0, 2.0));
    let o = ReadOptions {
        z_unit: Some(flakescatter_io::ZUnit::Nm),
        ..ReadOptions::default()
    };
    let e = read_map(&plain, &o).unwrap_err().to_string();
    assert!(e.contains("z_unit") && e.contains("Zarr"), "{e}");
    // write_map of an intensity image: the `intensity` array alone; read as heights it
    // is refused as the intensities it holds.
    let only = dir.path().join("only-intensity.zarr");
    let mut im = intensity.clone();
    im.set_quantity(ValueKind::Intensity);
    write_map(&im, &only, MapFormat::Zarr).unwrap();
    let e = read_map(&only, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("holds intensities") && e.contains("`intensity`"),
        "{e}"
    );
    assert_eq!(
        read_intensity(&only, &ReadOptions::default())
            .unwrap()
            .0
            .heights(),
        intensity.heights()
    );
    // A regular file named .zarr is not a store.
    let file = dir.path().join("file.zarr");
    std::fs::write(&file, b"1 2\n3 4\n").unwrap();
    let e = read_map(&file, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a directory holding zarr.json"), "{e}");
}

/// `tests/data/zarr/expected.txt`: (shape, valid, mean, intensity sum, heights).
fn expected() -> ((usize, usize), usize, f64, f64, Vec<f64>) {
    let text = std::fs::read_to_string(data("expected.txt")).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let mut field = |name: &str| {
        let l = lines.next().unwrap();
        l.strip_prefix(name).unwrap().trim().to_string()
    };
    let shape: Vec<usize> = field("shape")
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    let valid = field("valid").parse().unwrap();
    let mean = field("mean").parse().unwrap();
    let isum = field("intensity_sum").parse().unwrap();
    let heights = lines
        .map(|l| {
            if l == "nan" {
                f64::NAN
            } else {
                l.parse().unwrap()
            }
        })
        .collect();
    ((shape[0], shape[1]), valid, mean, isum, heights)
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/zarr")
        .join(name)
}

#[test]
fn store_written_by_zarr_python_reads_as_numpy_says() {
    let ((ny, nx), valid, mean, isum, heights) = expected();
    let store = data("python.zarr");
    let opened = ZarrMap::open(&store).unwrap();
    assert_eq!(opened.shape(), (ny, nx));
    assert_eq!(opened.pitch(), (0.18, 0.25));
    assert!(opened.has_mask() && opened.has_intensity());
    let (map, format) = read_map(&store, &ReadOptions::default()).unwrap();
    assert_eq!(format, MapFormat::Zarr);
    assert_eq!(bits(map.heights()), bits(&heights));
    assert_eq!(map.valid_count(), valid);
    let ours: Vec<f64> = map
        .heights()
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let our_mean = ours.iter().sum::<f64>() / ours.len() as f64;
    assert!(
        (our_mean - mean).abs() <= 1e-15 * mean.abs(),
        "{our_mean} vs {mean}"
    );
    let (i, _) = read_intensity(&store, &ReadOptions::default()).unwrap();
    assert_eq!(i.heights().iter().sum::<f64>(), isum);
    // Windows across the 2 x 3 chunks and at the edges, against numpy's heights.
    for (y0, x0, h, w) in [(1, 2, 3, 4), (4, 6, 1, 1), (0, 0, 5, 7), (3, 0, 2, 7)] {
        let got = opened.read_window(y0, x0, h, w).unwrap();
        let want: Vec<f64> = (y0..y0 + h)
            .flat_map(|r| heights[r * nx + x0..r * nx + x0 + w].to_vec())
            .collect();
        assert_eq!(bits(&got), bits(&want), "window {y0} {x0} {h} {w}");
    }
}

/// One array of a hand-written store: its name, zarr.json and chunks (key, bytes).
type HandArray = (&'static str, String, Vec<(&'static str, Vec<u8>)>);

/// A store written by hand: the root group with `attrs`, and each array as
/// (name, its zarr.json, its chunks as (key, bytes)). Uncompressed little-endian chunks.
fn hand_store(dir: &Path, attrs: &str, arrays: &[HandArray]) -> PathBuf {
    let root = dir.join("hand.zarr");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    std::fs::write(
        root.join("zarr.json"),
        format!(r#"{{"zarr_format":3,"node_type":"group","attributes":{attrs}}}"#),
    )
    .unwrap();
    for (name, meta, chunks) in arrays {
        std::fs::create_dir_all(root.join(name)).unwrap();
        std::fs::write(root.join(name).join("zarr.json"), meta).unwrap();
        for (key, bytes) in chunks {
            let p = root.join(name).join("c").join(key);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, bytes).unwrap();
        }
    }
    root
}

/// Array metadata: `shape`, `chunk` (JSON arrays), `dtype` and fill value.
fn meta(shape: &str, chunk: &str, dtype: &str, fill: &str) -> String {
    format!(
        r#"{{"zarr_format":3,"node_type":"array","shape":{shape},"data_type":"{dtype}",
        "chunk_grid":{{"name":"regular","configuration":{{"chunk_shape":{chunk}}}}},
        "chunk_key_encoding":{{"name":"default","configuration":{{"separator":"/"}}}},
        "fill_value":{fill},"codecs":[{{"name":"bytes","configuration":{{"endian":"little"}}}}],
        "attributes":{{}}}}"#
    )
}

fn le(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

const ATTRS: &str = r#"{"pitch_x_um":0.5,"pitch_y_um":0.25,"height_unit":"um"}"#;

/// A good 2 x 3 store in one chunk of 2 x 2 and one partial chunk (column 2).
fn good_height() -> HandArray {
    (
        "height",
        meta("[2,3]", "[2,2]", "float64", r#""NaN""#),
        vec![
            ("0/0", le(&[1.0, 2.0, 4.0, 5.0])),
            // The partial chunk is stored whole: column 3 lies outside the map.
            ("0/1", le(&[3.0, -9.0, f64::NAN, -9.0])),
        ],
    )
}

#[test]
fn hand_written_store_reads_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let mask = (
        "mask",
        meta("[2,3]", "[2,3]", "uint8", "1"),
        vec![("0/0", vec![1, 0, 1, 1, 1, 7])],
    );
    let store = hand_store(dir.path(), ATTRS, &[good_height(), mask]);
    let (m, _) = read_map(&store, &ReadOptions::default()).unwrap();
    assert_eq!((m.nx(), m.ny(), m.dx(), m.dy()), (3, 2, 0.5, 0.25));
    // Row-major [[1, 2, 3], [4, 5, NaN]]; the mask (0 = invalid) removes column 1 of
    // row 0; 7 is non-zero, so valid (its height is NaN all the same).
    assert_eq!(
        bits(m.heights()),
        bits(&[1.0, f64::NAN, 3.0, 4.0, 5.0, f64::NAN])
    );
    assert_eq!(m.valid_count(), 4);
    // Pitch attributes on the height array win over the group's.
    let mut h = good_height();
    h.1 = h.1.replace(
        r#""attributes":{}"#,
        r#""attributes":{"pitch_x_um":2.0,"pitch_y_um":3.0}"#,
    );
    let store = hand_store(dir.path(), ATTRS, &[h]);
    assert_eq!(ZarrMap::open(&store).unwrap().pitch(), (2.0, 3.0));
}

/// Opens `store` through `read_map`, expecting a Zarr problem whose message holds
/// every one of `words`.
fn refused(store: &Path, words: &[&str]) -> ZarrProblem {
    let e = read_map(store, &ReadOptions::default()).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("hand.zarr"), "{text}");
    for w in words {
        assert!(text.contains(w), "{w:?} not in {text}");
    }
    match e {
        ReadMapError::Format {
            error: MapError::Zarr(p),
            ..
        } => p,
        other => panic!("{other:?}"),
    }
}

#[test]
fn bad_stores_are_refused_naming_the_array_and_attribute() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let with =
        |name: &'static str, m: String, chunks: Vec<(&'static str, Vec<u8>)>| (name, m, chunks);
    // Wrong data type of `height`: int32, a string.
    for dtype in ["int32", "string"] {
        let fill = if dtype == "string" { r#""""# } else { "0" };
        let s = hand_store(
            d,
            ATTRS,
            &[with("height", meta("[2,3]", "[2,2]", dtype, fill), vec![])],
        );
        let p = refused(&s, &["`height`", dtype, "float64"]);
        assert!(
            matches!(
                p,
                ZarrProblem::DataType {
                    array: "height",
                    ..
                }
            ),
            "{p:?}"
        );
    }
    // A mask of another data type.
    let s = hand_store(
        d,
        ATTRS,
        &[
            good_height(),
            with("mask", meta("[2,3]", "[2,3]", "float32", "1.0"), vec![]),
        ],
    );
    assert!(matches!(
        refused(&s, &["`mask`", "float32", "bool or uint8"]),
        ZarrProblem::DataType { array: "mask", .. }
    ));
    // Missing, zero, negative, non-numeric and null pitch attributes.
    for (attrs, name, found) in [
        (
            r#"{"pitch_y_um":0.25,"height_unit":"um"}"#,
            "pitch_x_um",
            "missing",
        ),
        (
            r#"{"pitch_x_um":0.5,"height_unit":"um"}"#,
            "pitch_y_um",
            "missing",
        ),
        (
            r#"{"pitch_x_um":0,"pitch_y_um":0.25,"height_unit":"um"}"#,
            "pitch_x_um",
            "0",
        ),
        (
            r#"{"pitch_x_um":0.5,"pitch_y_um":-1.5,"height_unit":"um"}"#,
            "pitch_y_um",
            "-1.5",
        ),
        (
            r#"{"pitch_x_um":"0.5","pitch_y_um":0.25,"height_unit":"um"}"#,
            "pitch_x_um",
            "\"0.5\"",
        ),
        (
            r#"{"pitch_x_um":null,"pitch_y_um":0.25,"height_unit":"um"}"#,
            "pitch_x_um",
            "null",
        ),
    ] {
        let s = hand_store(d, attrs, &[good_height()]);
        let p = refused(&s, &[name, found, "positive finite"]);
        assert!(
            matches!(p, ZarrProblem::Attribute { attribute, .. } if attribute == name),
            "{p:?}"
        );
    }
    // Height unit missing or another unit.
    for attrs in [
        r#"{"pitch_x_um":0.5,"pitch_y_um":0.25}"#,
        r#"{"pitch_x_um":0.5,"pitch_y_um":0.25,"height_unit":"nm"}"#,
    ] {
        let s = hand_store(d, attrs, &[good_height()]);
        refused(&s, &["height_unit", "\"um\""]);
    }
    // Chunks that do not tile the array: a chunk file of the wrong size (5 values for
    // a 2 x 2 chunk), a one-dimensional chunk grid for a 2-D array, an empty chunk side.
    let s = hand_store(
        d,
        ATTRS,
        &[with(
            "height",
            meta("[2,3]", "[2,2]", "float64", r#""NaN""#),
            vec![("0/0", le(&[1.0, 2.0, 3.0, 4.0, 5.0]))],
        )],
    );
    let e = ZarrMap::open(&s).unwrap().read().unwrap_err();
    assert!(
        matches!(
            e.problem,
            ZarrProblem::Array {
                array: "height",
                ..
            }
        ),
        "{e}"
    );
    refused(&s, &["`height`"]);
    for chunk in ["[2]", "[0,2]"] {
        let s = hand_store(
            d,
            ATTRS,
            &[with(
                "height",
                meta("[2,3]", chunk, "float64", r#""NaN""#),
                vec![],
            )],
        );
        refused(&s, &["`height`"]);
    }
    // A mask or intensity of another shape than `height`.
    for name in ["mask", "intensity"] {
        let (dtype, fill) = if name == "mask" {
            ("bool", "true")
        } else {
            ("float64", "0.0")
        };
        let s = hand_store(
            d,
            ATTRS,
            &[
                good_height(),
                with(name, meta("[3,2]", "[2,2]", dtype, fill), vec![]),
            ],
        );
        let p = refused(&s, &[name, "[3, 2]", "[2, 3], the shape of `height`"]);
        assert!(matches!(p, ZarrProblem::Shape { .. }), "{p:?}");
    }
    // A height array of three dimensions.
    let s = hand_store(
        d,
        ATTRS,
        &[with(
            "height",
            meta("[2,3,1]", "[2,2,1]", "float64", r#""NaN""#),
            vec![],
        )],
    );
    refused(&s, &["`height`", "two non-zero dimensions"]);
    // No height array at all; a `.zarr` directory without zarr.json.
    let s = hand_store(d, ATTRS, &[]);
    assert_eq!(refused(&s, &["neither"]), ZarrProblem::NoArray);
    std::fs::remove_file(s.join("zarr.json")).unwrap();
    refused(&s, &["no zarr.json"]);
}
