//! `topo` streams Zarr stores band by band (issue 49, docs/guide.md "Big maps"): on a
//! 600 × 500 store in chunks of 48 × 64 points (chunks, bands and 64-pixel tiles do not
//! align), with a mask, NaNs and its intensity cutoff from the store's `intensity`
//! array, the rows (plain and `--isotropic`) are the in-memory facade's on the map as
//! built here, to the last bit (the CSV holds the shortest text that reads back to the
//! same number), and `--json` counts the valid points of the map; a chunk truncated in
//! the middle exits 2 naming the store and the array; a window larger than the store
//! gets the in-memory message.

mod common;

use std::path::Path;

use common::{run, s, scratch, stderr};
use flakescatter::io::zarr::{ZarrWriteOptions, write_zarr};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::{
    Coating, Curves, DetectorSet, Instrument, Settings, TopoSettings, isotropic_curves,
    topographic_curves,
};

/// A seeded value in [0, 1) (splitmix64 of `i`).
fn unit(i: u64) -> f64 {
    let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as f64 / 2f64.powi(64)
}

/// Heights of tilted 20 × 20 facets with noise, NaNs and masked points; an intensity
/// image of one brightness per facet, with NaNs; 600 × 500 pixels of 0.5 µm.
fn maps() -> (HeightMap, HeightMap) {
    let (nx, ny) = (600usize, 500usize);
    let (mut z, mut valid, mut intensity) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..ny {
        for c in 0..nx {
            let facet = ((r / 20) * 31 + c / 20) as u64;
            let (a, b) = (0.5 * unit(facet) - 0.25, 0.5 * unit(facet + 7919) - 0.25);
            let i = (r * nx + c) as u64 * 4 + 1_000_000;
            z.push(if unit(i) < 0.002 {
                f64::NAN
            } else {
                a * c as f64 * 0.5 + b * r as f64 * 0.5 + 0.02 * unit(i + 1)
            });
            valid.push(unit(i + 2) > 0.002);
            // One brightness per facet (so that the cutoff takes whole facets away)
            // and a few pixels without a value.
            intensity.push(if unit(i + 3) < 0.001 {
                f64::NAN
            } else {
                unit(facet + 31_337)
            });
        }
    }
    (
        HeightMap::with_mask(nx, ny, 0.5, 0.5, z, valid).unwrap(),
        HeightMap::new(nx, ny, 0.5, 0.5, intensity).unwrap(),
    )
}

fn csv(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    (header, rows)
}

/// The command's rows against the facade's curves, number by number.
fn same_rows(text: &str, want: &Curves) {
    let (header, rows) = csv(text);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), want.rows.len());
    let cell = |s: &str| -> Option<f64> { (!s.is_empty()).then(|| s.parse().unwrap()) };
    for (row, w) in rows.iter().zip(&want.rows) {
        assert_eq!(cell(&row[col("brdf_per_sr")]), Some(w.brdf), "{row:?}");
        assert_eq!(cell(&row[col("reflectance")]), w.reflectance, "{row:?}");
        assert_eq!(
            cell(&row[col("relative")]),
            w.relative.is_finite().then_some(w.relative)
        );
        assert_eq!(row[col("rays")].parse::<u64>().ok(), w.rays, "{row:?}");
        assert_eq!(cell(&row[col("std_err")]), w.std_err, "{row:?}");
    }
}

fn write_store(map: &HeightMap, intensity: &HeightMap, dir: &Path) {
    let options = ZarrWriteOptions {
        chunk: (48, 64),
        ..ZarrWriteOptions::default()
    };
    write_zarr(map, Some(intensity), dir, &options).unwrap();
}

#[test]
fn streamed_topo_gives_the_in_memory_rows_bit_for_bit() {
    let d = scratch("zarr-stream", "equal");
    let (heights, intensity) = maps();
    let store = d.join("m.zarr");
    write_store(&heights, &intensity, &store);
    let mut masked = heights.clone();
    masked.apply_intensity_cutoff(&intensity, 0.3).unwrap();
    let ts: Vec<f64> = (-20..=20).map(|k| f64::from(k * 2).to_radians()).collect();
    let instrument = Instrument::new(
        vec![20f64.to_radians(), 50f64.to_radians()],
        DetectorSet::InPlane(ts),
        1.5f64.to_radians(),
    )
    .unwrap();
    let (coating, settings, topo) = (
        Coating::default(),
        Settings::default(),
        TopoSettings::default(),
    );
    let args = |extra: &[&'static str]| {
        let mut a = vec![
            "topo",
            s(&store),
            "--intensity-channel",
            "intensity",
            "--cutoff",
            "0.3",
            "--theta-i",
            "20,50",
            "--theta-s",
            "-40:40:2",
        ];
        a.extend_from_slice(extra);
        a
    };
    let out = run(&args(&[]));
    assert!(out.status.success(), "{}", stderr(&out));
    let (want, totals) = topographic_curves(
        &coating,
        &instrument,
        &settings,
        &topo,
        &[&masked],
        &|_, _| {},
    )
    .unwrap();
    assert!(totals.usable_pixels > 100_000, "{}", totals.usable_pixels);
    same_rows(&String::from_utf8_lossy(&out.stdout), &want);
    let out = run(&args(&["--isotropic"]));
    assert!(out.status.success(), "{}", stderr(&out));
    let (want, _) = isotropic_curves(
        &coating,
        &instrument,
        &settings,
        &topo,
        None,
        &[&masked],
        &|_, _| {},
    )
    .unwrap();
    same_rows(&String::from_utf8_lossy(&out.stdout), &want);
    // The JSON summary: the map's size and its valid points after the cutoff.
    let out = run(&args(&["--json"]));
    assert!(out.status.success(), "{}", stderr(&out));
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let m = &j["inputs"]["maps"][0];
    assert_eq!((m["nx"].as_u64(), m["ny"].as_u64()), (Some(600), Some(500)));
    assert_eq!(
        m["valid_pixels"].as_u64(),
        Some(masked.valid_count() as u64)
    );
    assert_eq!(j["counts"]["pixels"].as_u64(), Some(300_000));
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_truncated_chunk_exits_2_naming_the_store_and_the_array() {
    let d = scratch("zarr-stream", "truncated");
    let (heights, intensity) = maps();
    let store = d.join("broken.zarr");
    write_store(&heights, &intensity, &store);
    // Chunk row 5 (rows 240..288), column 4: read well after the first bands.
    let chunk = store.join("height/c/5/4");
    let bytes = std::fs::read(&chunk).unwrap();
    std::fs::write(&chunk, &bytes[..bytes.len() / 2]).unwrap();
    for extra in [&[][..], &["--isotropic"][..]] {
        let mut a = vec!["topo", s(&store), "--theta-i", "20"];
        a.extend_from_slice(extra);
        let out = run(&a);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        let e = stderr(&out);
        assert!(e.contains("broken.zarr") && e.contains("`height`"), "{e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_window_larger_than_the_store_gets_the_in_memory_message() {
    let d = scratch("zarr-stream", "small");
    let small = HeightMap::new(6, 4, 0.5, 0.5, (0..24).map(f64::from).collect()).unwrap();
    let (store, x3p) = (d.join("small.zarr"), d.join("small.x3p"));
    write_zarr(&small, None, &store, &ZarrWriteOptions::default()).unwrap();
    // The same map as X3P, read whole.
    let out = run(&["convert", s(&store), s(&x3p)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let message = |map: &Path| {
        let out = run(&["topo", s(map), "--window", "5"]);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        stderr(&out).replace(s(map), "MAP")
    };
    let streamed = message(&store);
    assert!(
        streamed.contains("--window 5: larger than height map MAP (6 x 4 pixels)"),
        "{streamed}"
    );
    assert_eq!(streamed, message(&x3p));
    std::fs::remove_dir_all(&d).unwrap();
}
