//! Streamed runs over Zarr stores (issue 49, `flakescatter::streaming`): a 600 × 500
//! map with a mask, NaNs and an intensity image, written as a store in chunks of 48 ×
//! 64 points (so chunks, bands and 64-pixel tiles do not align) and read band by band,
//! gives the in-memory facade's curves, totals and pixel-level distribution bit for
//! bit, with the intensity cutoff taken from the store's own `intensity` array or a
//! partner store; the range/finish split over two parts equals one call; a store
//! without the arrays a cutoff needs is refused naming the store.
//!
//! The reference is the in-memory run on the map as built here (the cutoff applied by
//! `HeightMap::apply_intensity_cutoff`), never read back from the store.

use std::path::PathBuf;

use flakescatter::io::zarr::{ZarrWriteOptions, write_zarr};
use flakescatter::stats::heightmap::{HeightMap, Quantity};
use flakescatter::streaming::{
    StoreCutoff, StoreError, ZarrSource, finish_isotropic, finish_topographic,
    isotropic_curves_streamed, pixel_orientation_streamed, tile_count, topographic_curves_streamed,
    trace_tiles,
};
use flakescatter::topo::HeightSource;
use flakescatter::{
    Coating, Curves, DetectorSet, Instrument, Settings, TopoSettings, isotropic_curves,
    pixel_orientation, topographic_curves,
};
use rand::{RngExt, SeedableRng};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fs-streaming-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Heights (a seeded facet surface, 0.5 µm pitch, NaNs and masked points) and an
/// intensity image (one seeded brightness per facet, some NaN), 600 × 500.
fn maps() -> (HeightMap, HeightMap) {
    let (nx, ny) = (600, 500);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let slopes: Vec<(f64, f64)> = (0..(nx / 20 + 1) * (ny / 20 + 1))
        .map(|_| (rng.random_range(-0.25..0.25), rng.random_range(-0.25..0.25)))
        .collect();
    let brightness: Vec<f64> = (0..slopes.len())
        .map(|_| rng.random_range(0.0..1.0))
        .collect();
    let (mut z, mut valid, mut intensity) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..ny {
        for c in 0..nx {
            let (a, b) = slopes[(r / 20) * (nx / 20 + 1) + c / 20];
            let nan = rng.random_range(0.0..1.0) < 0.002;
            z.push(if nan {
                f64::NAN
            } else {
                3.0 + a * c as f64 * 0.5 + b * r as f64 * 0.5 + rng.random_range(-0.02..0.02)
            });
            valid.push(rng.random_range(0.0..1.0) > 0.002);
            // One brightness per facet, a few pixels without a value.
            let facet = (r / 20) * (nx / 20 + 1) + c / 20;
            intensity.push(if rng.random_range(0.0..1.0) < 0.001 {
                f64::NAN
            } else {
                brightness[facet]
            });
        }
    }
    let heights = HeightMap::with_mask(nx, ny, 0.5, 0.5, z, valid).unwrap();
    let mut intensity = HeightMap::new(nx, ny, 0.5, 0.5, intensity).unwrap();
    intensity.set_quantity(Quantity::Intensity);
    (heights, intensity)
}

fn instrument() -> Instrument {
    let ts: Vec<f64> = (-30..=30).map(|d| f64::from(d).to_radians()).collect();
    Instrument::new(
        vec![15f64.to_radians(), 45f64.to_radians()],
        DetectorSet::InPlane(ts),
        1.5f64.to_radians(),
    )
    .unwrap()
}

/// Every number of the rows, as bits.
fn bits(c: &Curves) -> Vec<[u64; 5]> {
    c.rows
        .iter()
        .map(|r| {
            [
                r.brdf.to_bits(),
                r.reflectance.map_or(1, f64::to_bits),
                r.relative.to_bits(),
                r.std_err.map_or(1, f64::to_bits),
                r.rays.unwrap_or(u64::MAX),
            ]
        })
        .collect()
}

#[test]
fn streamed_stores_give_the_in_memory_numbers_bit_for_bit() {
    let d = scratch("equal");
    let (heights, intensity) = maps();
    let chunks = ZarrWriteOptions {
        chunk: (48, 64),
        ..ZarrWriteOptions::default()
    };
    let (own, hz, iz) = (d.join("own.zarr"), d.join("h.zarr"), d.join("i.zarr"));
    write_zarr(&heights, Some(&intensity), &own, &chunks).unwrap();
    write_zarr(&heights, None, &hz, &chunks).unwrap();
    write_zarr(&intensity, None, &iz, &chunks).unwrap();
    let cutoff = 0.2;
    let mut masked = heights.clone();
    masked.apply_intensity_cutoff(&intensity, cutoff).unwrap();
    let (coating, settings, instrument) = (Coating::default(), Settings::default(), instrument());
    let topo = TopoSettings::default();
    let plain = topographic_curves(
        &coating,
        &instrument,
        &settings,
        &topo,
        &[&masked],
        &|_, _| {},
    )
    .unwrap();
    let iso = isotropic_curves(
        &coating,
        &instrument,
        &settings,
        &topo,
        None,
        &[&masked],
        &|_, _| {},
    )
    .unwrap();
    let tilts = pixel_orientation(&[&masked], &topo, 1f64.to_radians()).unwrap();
    let sources = [
        ZarrSource::open(&own, &StoreCutoff::Own(cutoff)).unwrap(),
        ZarrSource::open(&hz, &StoreCutoff::Partner(iz.clone(), cutoff)).unwrap(),
    ];
    for source in &sources {
        let s: [&dyn HeightSource; 1] = [source];
        let (c, r) =
            topographic_curves_streamed(&coating, &instrument, &settings, &topo, &s, &|_, _| {})
                .unwrap();
        assert_eq!(bits(&c), bits(&plain.0), "{}", source.path().display());
        assert_eq!(c.source, plain.0.source);
        assert!(plain.1.usable_pixels > 100_000, "{}", plain.1.usable_pixels);
        assert_eq!(
            (
                r.pixels,
                r.usable_pixels,
                r.rays_lost_tir,
                r.tiles,
                &r.valid_pixels
            ),
            (
                300_000,
                plain.1.usable_pixels,
                plain.1.rays_lost_tir,
                80,
                &vec![masked.valid_count() as u64]
            )
        );
        let (c, r) = isotropic_curves_streamed(
            &coating,
            &instrument,
            &settings,
            &topo,
            None,
            &s,
            &|_, _| {},
        )
        .unwrap();
        assert_eq!(bits(&c), bits(&iso.0));
        assert_eq!(r.interpolation_error, iso.1.interpolation_error);
        let t = pixel_orientation_streamed(&s, &topo, 1f64.to_radians(), &|_, _| {}).unwrap();
        assert_eq!(t.tilts, tilts.tilts);
        assert_eq!(t.width, tilts.width);
    }
    // Without a cutoff: the store's mask and NaNs alone.
    let bare = ZarrSource::open(&hz, &StoreCutoff::None).unwrap();
    let want = topographic_curves(
        &coating,
        &instrument,
        &settings,
        &topo,
        &[&heights],
        &|_, _| {},
    )
    .unwrap();
    let (c, _) = topographic_curves_streamed(
        &coating,
        &instrument,
        &settings,
        &topo,
        &[&bare],
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(bits(&c), bits(&want.0));
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn split_runs_finish_to_the_one_call_curves() {
    let d = scratch("split");
    let (heights, intensity) = maps();
    let store = d.join("m.zarr");
    let chunks = ZarrWriteOptions {
        chunk: (48, 64),
        ..ZarrWriteOptions::default()
    };
    write_zarr(&heights, Some(&intensity), &store, &chunks).unwrap();
    let source = ZarrSource::open(&store, &StoreCutoff::Own(0.1)).unwrap();
    let s: [&dyn HeightSource; 1] = [&source];
    let (coating, settings, instrument) = (Coating::default(), Settings::default(), instrument());
    let topo = TopoSettings::default();
    let total = tile_count(&coating, &settings, &topo, &s).unwrap();
    assert_eq!(total, 80);
    let one = topographic_curves_streamed(&coating, &instrument, &settings, &topo, &s, &|_, _| {})
        .unwrap();
    let part = |iso: Option<Option<f64>>, r: std::ops::Range<u64>| {
        trace_tiles(
            &coating,
            &instrument,
            &settings,
            &topo,
            iso,
            &s,
            r,
            &|_, _| {},
        )
        .unwrap()
    };
    let parts = [part(None, 0..40), part(None, 40..80)];
    let (c, r) = finish_topographic(&coating, &instrument, &settings, &topo, &s, &parts).unwrap();
    assert_eq!(bits(&c), bits(&one.0));
    assert_eq!(
        (r.usable_pixels, r.tiles),
        (one.1.usable_pixels, one.1.tiles)
    );
    let one = isotropic_curves_streamed(
        &coating,
        &instrument,
        &settings,
        &topo,
        None,
        &s,
        &|_, _| {},
    )
    .unwrap();
    let parts = [part(Some(None), 0..40), part(Some(None), 40..80)];
    let (c, _) =
        finish_isotropic(&coating, &instrument, &settings, &topo, None, &s, &parts).unwrap();
    assert_eq!(bits(&c), bits(&one.0));
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_cutoff_without_an_intensity_array_is_refused_naming_the_store() {
    let d = scratch("refused");
    let (heights, intensity) = maps();
    let (hz, iz) = (d.join("h.zarr"), d.join("i.zarr"));
    write_zarr(&heights, None, &hz, &ZarrWriteOptions::default()).unwrap();
    write_zarr(&intensity, None, &iz, &ZarrWriteOptions::default()).unwrap();
    let e = ZarrSource::open(&hz, &StoreCutoff::Own(0.5)).unwrap_err();
    assert!(matches!(e, StoreError::NoIntensity { .. }), "{e:?}");
    assert!(
        e.to_string().contains("h.zarr") && e.to_string().contains("`intensity`"),
        "{e}"
    );
    // An intensity-only store is not a height map.
    let e = ZarrSource::open(&iz, &StoreCutoff::None).unwrap_err();
    assert!(
        e.to_string().contains("i.zarr") && e.to_string().contains("`height`"),
        "{e}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}
