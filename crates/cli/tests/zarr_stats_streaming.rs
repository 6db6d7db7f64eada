//! `stats --pixel-normals-only` streams Zarr stores band by band (issue 49,
//! docs/guide.md "Big maps"). On a 600 × 500 store in chunks of 48 × 64 points (chunks
//! and tiles do not align), with a mask, NaNs and an intensity cutoff from the store's
//! `intensity` array:
//!
//! * the streamed histogram is, byte for byte, the one of the same store read whole
//!   (`--pixel-um 0.5`, the store's own pitch, sends it through the in-memory loader)
//!   and the pixel-level histogram `--pixel-normals` writes after segmenting; the JSON's
//!   `pixel_level` is the same object;
//! * the usable pixels, their total true area and the histogram are those of the closed
//!   form written here (docs/physics.md §5: on a full `k × k` window of pitch `dx, dy`
//!   the least-squares slopes are `a = Σ i z / (k dx S)`, `b = Σ j z / (k dy S)`,
//!   `S = h(h+1)(2h+1)/3`; a pixel is usable when its whole window is valid; its weight
//!   is its true area `dx dy sqrt(1 + a² + b²)`, binned by `θ = atan(sqrt(a² + b²))`).
//!
//! Bad input exits 2 naming the flag, the store or the array.

mod common;

use std::path::Path;

use common::{run, s, scratch, stderr};
use flakescatter::io::zarr::{ZarrWriteOptions, write_zarr};
use flakescatter::stats::heightmap::HeightMap;

/// A seeded value in [0, 1) (splitmix64 of `i`).
fn unit(i: u64) -> f64 {
    let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as f64 / 2f64.powi(64)
}

const NX: usize = 600;
const NY: usize = 500;
const PITCH: f64 = 0.5;
const CUTOFF: f64 = 0.3;

/// Heights of tilted 20 × 20 facets with noise, NaNs and masked points; an intensity
/// image of one brightness per facet, with NaNs.
fn maps() -> (HeightMap, HeightMap) {
    let (mut z, mut valid, mut intensity) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..NY {
        for c in 0..NX {
            let facet = ((r / 20) * 31 + c / 20) as u64;
            let (a, b) = (0.5 * unit(facet) - 0.25, 0.5 * unit(facet + 7919) - 0.25);
            let i = (r * NX + c) as u64 * 4 + 1_000_000;
            z.push(if unit(i) < 0.002 {
                f64::NAN
            } else {
                a * c as f64 * PITCH + b * r as f64 * PITCH + 0.02 * unit(i + 1)
            });
            valid.push(unit(i + 2) > 0.002);
            intensity.push(if unit(i + 3) < 0.001 {
                f64::NAN
            } else {
                unit(facet + 31_337)
            });
        }
    }
    (
        HeightMap::with_mask(NX, NY, PITCH, PITCH, z, valid).unwrap(),
        HeightMap::new(NX, NY, PITCH, PITCH, intensity).unwrap(),
    )
}

fn write_store(heights: &HeightMap, intensity: Option<&HeightMap>, dir: &Path) {
    let options = ZarrWriteOptions {
        chunk: (48, 64),
        ..ZarrWriteOptions::default()
    };
    write_zarr(heights, intensity, dir, &options).unwrap();
}

/// The closed form of the module docs with a 5 × 5 window: usable pixels, their total
/// true area and the true area per 1° bin.
fn closed_form(heights: &HeightMap, intensity: Option<&HeightMap>) -> (u64, f64, Vec<f64>) {
    let (k, h) = (5usize, 2i64);
    let s = (h * (h + 1) * (2 * h + 1)) as f64 / 3.0;
    let z = heights.heights();
    let keep: Vec<bool> = (0..NX * NY)
        .map(|i| {
            heights.valid()[i]
                && z[i].is_finite()
                && intensity.is_none_or(|m| {
                    let v = m.heights()[i];
                    v.is_finite() && v >= CUTOFF
                })
        })
        .collect();
    let (mut usable, mut total, mut bins) = (0u64, 0.0, vec![0.0; 90]);
    for r in 2..NY - 2 {
        for c in 2..NX - 2 {
            let at = |i: i64, j: i64| (r as i64 + j) as usize * NX + (c as i64 + i) as usize;
            let window = (-h..=h).flat_map(|j| (-h..=h).map(move |i| (i, j)));
            if !window.clone().all(|(i, j)| keep[at(i, j)]) {
                continue;
            }
            let z0 = z[at(0, 0)];
            let (mut si, mut sj) = (0.0, 0.0);
            for (i, j) in window {
                si += i as f64 * (z[at(i, j)] - z0);
                sj += j as f64 * (z[at(i, j)] - z0);
            }
            let a = si / (k as f64 * PITCH * s);
            let b = sj / (k as f64 * PITCH * s);
            let r2 = a * a + b * b;
            let area = PITCH * PITCH * (1.0 + r2).sqrt();
            let theta = r2.sqrt().atan().to_degrees();
            usable += 1;
            total += area;
            bins[(theta as usize).min(89)] += area;
        }
    }
    (usable, total, bins)
}

/// The `area_fraction` column of a histogram CSV.
fn fractions(csv: &[u8]) -> Vec<f64> {
    let text = String::from_utf8_lossy(csv);
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        header,
        [
            "theta_lo_deg",
            "theta_hi_deg",
            "area_fraction",
            "p_per_rad",
            "p_tilde"
        ]
    );
    lines
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect()
}

/// `stats` with `args`, succeeding: (histogram CSV, JSON summary).
fn stats(dir: &Path, tag: &str, args: &[&str]) -> (Vec<u8>, serde_json::Value) {
    let csv = dir.join(format!("{tag}.csv"));
    let mut a = vec!["stats"];
    a.extend_from_slice(args);
    a.extend_from_slice(&["--out", s(&csv), "--json"]);
    let out = run(&a);
    assert!(out.status.success(), "{tag}: {}", stderr(&out));
    let j = serde_json::from_slice(&out.stdout).unwrap();
    (std::fs::read(&csv).unwrap(), j)
}

#[test]
fn streamed_pixel_normals_equal_the_map_read_whole_and_the_closed_form() {
    let d = scratch("zarr-stats", "equal");
    let (heights, intensity) = maps();
    let store = d.join("m.zarr");
    write_store(&heights, Some(&intensity), &store);
    let map = ["--map", s(&store)];
    let cut = ["--intensity-channel", "intensity", "--cutoff", "0.3"];
    for cutoff in [true, false] {
        let base: Vec<&str> = if cutoff {
            [&map[..], &cut[..]].concat()
        } else {
            map.to_vec()
        };
        let with = |extra: &[&'static str]| [&base[..], extra].concat();
        let (streamed, js) = stats(&d, "streamed", &with(&["--pixel-normals-only"]));
        let (whole, jw) = stats(
            &d,
            "whole",
            &with(&["--pixel-normals-only", "--pixel-um", "0.5"]),
        );
        assert_eq!(streamed, whole, "cutoff {cutoff}: the histogram CSV");
        assert_eq!(js["pixel_level"], jw["pixel_level"]);
        assert_eq!(js["total_area_um2"], jw["total_area_um2"]);
        assert_eq!(js["histogram_of"], "pixel normals");
        // The histogram of --pixel-normals, which segments the map first.
        let (segmented, jp) = stats(&d, "segmented", &with(&["--pixel-normals"]));
        assert_eq!(streamed, segmented, "cutoff {cutoff}: the histogram CSV");
        assert_eq!(js["pixel_level"], jp["pixel_level"]);
        // The closed form.
        let (usable, total, bins) = closed_form(&heights, cutoff.then_some(&intensity));
        let px = &js["pixel_level"];
        assert_eq!(px["usable_pixels"].as_u64(), Some(usable));
        assert_eq!(px["pixels"].as_u64(), Some((NX * NY) as u64));
        assert!(usable > 100_000, "{usable}");
        let got = js["total_area_um2"].as_f64().unwrap();
        assert!(
            (got - total).abs() <= 1e-12 * total,
            "total true area {got} against {total}"
        );
        let f = fractions(&streamed);
        assert_eq!(f.len(), 90);
        for (k, (&g, &a)) in f.iter().zip(&bins).enumerate() {
            assert!(
                (g - a / total).abs() <= 1e-12,
                "bin {k}: {g} against {}",
                a / total
            );
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// `stats --map MAP --pixel-normals-only` with `extra`, failing with exit status 2:
/// its standard error.
fn refused(map: &Path, extra: &[&str]) -> String {
    let mut a = vec!["stats", "--map", s(map), "--pixel-normals-only"];
    a.extend_from_slice(extra);
    let out = run(&a);
    let e = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{a:?}: {e}");
    assert!(out.stdout.is_empty(), "{a:?}");
    assert!(!e.contains("panicked"), "{e}");
    e
}

#[test]
fn bad_input_exits_2_naming_the_flag_the_store_or_the_array() {
    let d = scratch("zarr-stats", "refused");
    let (heights, intensity) = maps();
    let store = d.join("m.zarr");
    write_store(&heights, Some(&intensity), &store);
    // A store without heights (its `height` array removed): named with the array.
    let bare = d.join("intensity-only.zarr");
    write_store(&heights, Some(&intensity), &bare);
    std::fs::remove_dir_all(bare.join("height")).unwrap();
    let e = refused(&bare, &[]);
    assert!(
        e.contains("intensity-only.zarr") && e.contains("height"),
        "{e}"
    );
    // A cutoff without intensities: on a store without an `intensity` array, named.
    let plain = d.join("plain.zarr");
    write_store(&heights, None, &plain);
    let e = refused(&plain, &["--cutoff", "0.3"]);
    assert!(e.contains("--cutoff") && e.contains("plain.zarr"), "{e}");
    let e = refused(
        &plain,
        &["--intensity-channel", "intensity", "--cutoff", "0.3"],
    );
    assert!(
        e.contains("plain.zarr") && e.contains("\"intensity\""),
        "{e}"
    );
    // The flake-level flags: refused naming both flags.
    let out = s(&d.join("x.csv")).to_owned();
    for extra in [
        &["--per-map", &out][..],
        &["--flakes-out", &out],
        &["--plot", "p.svg"],
        &["--pixel-normals"],
        &["--z-step-um", "0.1"],
        &["--noise-um", "0.1"],
        &["--min-pixels", "50"],
    ] {
        let e = refused(&store, extra);
        assert!(
            e.contains("--pixel-normals-only") && e.contains(extra[0]),
            "{e}"
        );
    }
    assert!(!d.join("x.csv").exists());
    // Without maps.
    let o = run(&["stats", "--pixel-normals-only"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--map"), "{}", stderr(&o));
    // The pixel-level flags without either pixel-level mode.
    for flag in ["--window", "--tile-um"] {
        let o = run(&["stats", "--map", s(&store), flag, "7"]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(
            e.contains(&format!("{flag} 7")) && e.contains("--pixel-normals-only"),
            "{e}"
        );
    }
    // A chunk truncated in the middle of the store: named with the array.
    let broken = d.join("broken.zarr");
    write_store(&heights, Some(&intensity), &broken);
    let chunk = broken.join("height/c/5/4");
    let bytes = std::fs::read(&chunk).unwrap();
    std::fs::write(&chunk, &bytes[..bytes.len() / 2]).unwrap();
    let e = refused(&broken, &[]);
    assert!(e.contains("broken.zarr") && e.contains("`height`"), "{e}");
    // A map that cannot be used: the message of the map read whole.
    let small = HeightMap::new(6, 4, 0.5, 0.5, (0..24).map(f64::from).collect()).unwrap();
    let tiny = d.join("small.zarr");
    write_zarr(&small, None, &tiny, &ZarrWriteOptions::default()).unwrap();
    let e = refused(&tiny, &["--window", "7"]);
    assert!(e.contains("--window 7: larger than height map"), "{e}");
    assert_eq!(e, refused(&tiny, &["--window", "7", "--pixel-um", "0.5"]));
    let dark = HeightMap::new(6, 6, 0.5, 0.5, vec![f64::NAN; 36]).unwrap();
    let nan = d.join("dark.zarr");
    write_zarr(&dark, None, &nan, &ZarrWriteOptions::default()).unwrap();
    let e = refused(&nan, &[]);
    assert!(
        e.contains("dark.zarr") && e.contains("no valid pixel"),
        "{e}"
    );
    assert_eq!(e, refused(&nan, &["--pixel-um", "0.5"]));
    // A reading option the band reader does not take is not dropped: the whole-map
    // loader refuses it for a store, naming it (`stats` and `topo` alike).
    let e = refused(&store, &["--z-unit", "nm"]);
    assert!(e.contains("--z-unit"), "{e}");
    let o = run(&["topo", s(&store), "--z-unit", "nm", "--theta-i", "30"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--z-unit"), "{}", stderr(&o));
    std::fs::remove_dir_all(&d).unwrap();
}
