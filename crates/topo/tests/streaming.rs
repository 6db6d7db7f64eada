//! Streaming (issue 49): runs over [`HeightSource`]s read band by band give the
//! in-memory results bit for bit (plain, isotropic, pixel tilts), a run split into
//! ranges of tiles and finished in order equals one call, read errors propagate as
//! [`TopoError::Source`], and the edge cases (a map smaller than a tile, a window larger
//! than the map) are those of the in-memory run.
//!
//! The reference is the in-memory run of the same model on the whole map, which reads
//! the map as one band; the counts it does not share with the streamed run (pixels,
//! valid and usable points) are checked against brute-force counts written here.

use std::borrow::Cow;
use std::sync::Mutex;

use flakescatter_optics::detector::Cone;
use flakescatter_stats::HeightMap;
use flakescatter_topo::{
    BoxedError, HeightSource, IsotropicOptions, TileSumsKind, TopoError, TopoModel, TopoOptions,
    TopoPoint, TopoResult,
};
use rand::{RngExt, SeedableRng};

/// A map in memory served in bands of at most `band_rows` rows (copies), recording the
/// rows of every read; `fail_at` makes the read that starts at or after that row fail.
struct Banded<'a> {
    map: &'a HeightMap,
    band_rows: usize,
    reads: Mutex<Vec<(usize, usize)>>,
    fail_at: Option<usize>,
}

impl<'a> Banded<'a> {
    fn new(map: &'a HeightMap, band_rows: usize) -> Self {
        Self {
            map,
            band_rows,
            reads: Mutex::new(Vec::new()),
            fail_at: None,
        }
    }
}

impl HeightSource for Banded<'_> {
    fn size(&self) -> (usize, usize) {
        (self.map.nx(), self.map.ny())
    }
    fn pitch(&self) -> (f64, f64) {
        (self.map.dx(), self.map.dy())
    }
    fn rows(&self, r0: usize, r1: usize) -> Result<Cow<'_, HeightMap>, BoxedError> {
        if self.fail_at.is_some_and(|f| r0 >= f) {
            return Err(format!(
                "store.zarr: array `height`: chunk of rows {r0}..{r1} is truncated"
            )
            .into());
        }
        self.reads.lock().unwrap().push((r0, r1));
        // A copy, never the map itself (the map's own source borrows all rows).
        let nx = self.map.nx();
        Ok(Cow::Owned(
            HeightMap::with_mask(
                nx,
                r1 - r0,
                self.map.dx(),
                self.map.dy(),
                self.map.heights()[r0 * nx..r1 * nx].to_vec(),
                self.map.valid()[r0 * nx..r1 * nx].to_vec(),
            )
            .unwrap(),
        ))
    }
    fn band_rows(&self) -> usize {
        self.band_rows
    }
}

/// 600 × 500 pixels of 0.5 µm: a seeded rough surface of tilted facets, with masked
/// points, NaN points and a masked block touching the top edge (tiles of 32 µm are 64
/// pixels: 10 × 8 tiles, the last row and column cut).
fn rough_map() -> HeightMap {
    let (nx, ny) = (600, 500);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(49);
    // Facets of 16 × 16 pixels, each a plane of random slope, plus noise.
    let slopes: Vec<(f64, f64)> = (0..(nx / 16 + 1) * (ny / 16 + 1))
        .map(|_| (rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2)))
        .collect();
    let mut z = Vec::with_capacity(nx * ny);
    let mut valid = Vec::with_capacity(nx * ny);
    for r in 0..ny {
        for c in 0..nx {
            let (a, b) = slopes[(r / 16) * (nx / 16 + 1) + c / 16];
            let noise: f64 = rng.random_range(-0.01..0.01);
            let nan = rng.random_range(0.0..1.0) < 0.003;
            z.push(if nan {
                f64::NAN
            } else {
                100.0 + a * c as f64 * 0.5 + b * r as f64 * 0.5 + noise
            });
            valid.push(rng.random_range(0.0..1.0) >= 0.002 && !(r < 30 && (200..260).contains(&c)));
        }
    }
    HeightMap::with_mask(nx, ny, 0.5, 0.5, z, valid).unwrap()
}

fn cones() -> Vec<Cone> {
    (-40..=40)
        .map(|d| Cone::in_plane(f64::from(d).to_radians(), 1.5f64.to_radians()).unwrap())
        .collect()
}

/// Usable pixels counted pixel by pixel: the whole `k × k` window inside the map and
/// valid.
fn usable_brute_force(map: &HeightMap, k: usize) -> u64 {
    let (nx, ny, h) = (map.nx(), map.ny(), k / 2);
    let v = map.valid();
    let mut n = 0;
    for r in h..ny.saturating_sub(h) {
        for c in h..nx.saturating_sub(h) {
            n += u64::from((r - h..=r + h).all(|rr| (c - h..=c + h).all(|cc| v[rr * nx + cc])));
        }
    }
    n
}

fn bits(r: &TopoResult) -> Vec<[u64; 4]> {
    point_bits(&r.points)
}

/// Every number of the rows, as bits (NaN `relative` compares equal to itself).
fn point_bits(points: &[TopoPoint]) -> Vec<[u64; 4]> {
    points
        .iter()
        .map(|p| {
            [
                p.reflectance.to_bits(),
                p.reflectance_std_err.map_or(0, f64::to_bits),
                p.relative.to_bits(),
                p.rays,
            ]
        })
        .collect()
}

#[test]
fn streamed_plain_runs_equal_the_in_memory_run_bit_for_bit() {
    let map = rough_map();
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let (theta_i, cones) = ([0.0, 0.3, 0.7], cones());
    let whole = model.run(&[&map], &theta_i, &cones).unwrap();
    // Brute-force counts (not the model's): all pixels, valid and usable ones.
    assert_eq!(whole.pixels, 300_000);
    assert_eq!(whole.valid_pixels, vec![map.valid_count() as u64]);
    assert_eq!(whole.usable_pixels, usable_brute_force(&map, 5));
    assert_eq!(whole.tiles, 80);
    assert!(whole.points.iter().filter(|p| p.rays > 0).count() > 50);
    // Bands of one tile row (1 and 37 rows ask for less than one), two and three tile
    // rows, and the whole map; the first map twice, as two maps.
    for band_rows in [1, 37, 128, 200, 10_000] {
        let source = Banded::new(&map, band_rows);
        let r = model
            .run_sources(&[&source], &theta_i, &cones, &|_, _| {})
            .unwrap();
        assert_eq!(bits(&r), bits(&whole), "bands of {band_rows} rows");
        assert_eq!(
            (
                r.pixels,
                r.usable_pixels,
                r.rays_lost_tir,
                r.rays_lost_down,
                r.tiles
            ),
            (
                whole.pixels,
                whole.usable_pixels,
                whole.rays_lost_tir,
                whole.rays_lost_down,
                whole.tiles
            )
        );
        assert_eq!(r.valid_pixels, whole.valid_pixels);
        // Each read is at most the tile rows that fit, plus 2 + 2 halo rows.
        let reads = source.reads.lock().unwrap();
        let tile_rows = (band_rows / 64).max(1) * 64;
        assert!(
            reads.iter().all(|&(a, b)| b - a <= tile_rows + 4),
            "{reads:?}"
        );
        if band_rows < 500 {
            assert!(reads.len() > 1);
        }
    }
    let two = model.run(&[&map, &map], &theta_i, &cones).unwrap();
    let (a, b) = (Banded::new(&map, 70), Banded::new(&map, 300));
    let r = model
        .run_sources(&[&a, &b], &theta_i, &cones, &|_, _| {})
        .unwrap();
    assert_eq!(bits(&r), bits(&two));
    assert_eq!(r.pixels, 600_000);
}

#[test]
fn streamed_isotropic_runs_and_pixel_tilts_equal_the_in_memory_ones() {
    let map = rough_map();
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let cones = cones();
    let options = IsotropicOptions {
        node_spacing: Some(0.002),
    };
    let whole = model
        .run_isotropic_with(&[&map], &[0.2, 0.5], &cones, &options, &|_, _| {})
        .unwrap();
    assert_eq!(whole.usable_pixels, usable_brute_force(&map, 5));
    let tilts = model.pixel_tilts(&[&map], 1f64.to_radians()).unwrap();
    for band_rows in [1, 150, 10_000] {
        let source = Banded::new(&map, band_rows);
        let r = model
            .run_isotropic_sources(&[&source], &[0.2, 0.5], &cones, &options, &|_, _| {})
            .unwrap();
        assert_eq!(
            point_bits(&r.points),
            point_bits(&whole.points),
            "bands of {band_rows} rows"
        );
        assert_eq!(r.interpolation_error, whole.interpolation_error);
        assert_eq!(
            (
                r.rings_lost_tir.to_bits(),
                r.rings_lost_down.to_bits(),
                r.nodes
            ),
            (
                whole.rings_lost_tir.to_bits(),
                whole.rings_lost_down.to_bits(),
                whole.nodes
            )
        );
        let calls = Mutex::new(Vec::new());
        let t = model
            .pixel_tilts_sources(&[&source], 1f64.to_radians(), &|done, total| {
                calls.lock().unwrap().push((done, total));
            })
            .unwrap();
        assert_eq!(t, tilts, "pixel tilts, bands of {band_rows} rows");
        // Progress in tiles: rising, ending at every tile of the map.
        let calls = calls.into_inner().unwrap();
        let n = tilts.tiles.len() as u64;
        assert!(calls.windows(2).all(|w| w[0].0 <= w[1].0), "{calls:?}");
        assert_eq!(calls.last(), Some(&(n, n)), "{calls:?}");
    }
}

#[test]
fn a_run_split_into_ranges_and_finished_equals_one_call() {
    let map = rough_map();
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let (theta_i, cones) = ([0.1, 0.6], cones());
    let (a, b) = (Banded::new(&map, 64), Banded::new(&map, 1000));
    let sources: [&dyn HeightSource; 2] = [&a, &b];
    let total = model.tile_count(&sources);
    assert_eq!(total, 160);
    let one = model
        .run_sources(&sources, &theta_i, &cones, &|_, _| {})
        .unwrap();
    // Halves, and an uneven split that cuts a tile row and the first map.
    for cuts in [vec![0, 80, 160], vec![0, 13, 95, 96, 160]] {
        let parts: Vec<_> = cuts
            .windows(2)
            .map(|w| {
                model
                    .trace_tiles(&sources, &theta_i, &cones, w[0]..w[1], &|_, _| {})
                    .unwrap()
            })
            .collect();
        assert!(parts.iter().all(|p| p.kind == TileSumsKind::Plain));
        let r = model.finish(&sources, &theta_i, &cones, &parts).unwrap();
        assert_eq!(bits(&r), bits(&one), "cuts {cuts:?}");
        assert_eq!(
            TopoResult {
                points: Vec::new(),
                ..r
            },
            TopoResult {
                points: Vec::new(),
                ..one.clone()
            }
        );
        // Out of order, or leaving tiles out: refused.
        let mut swapped = parts.clone();
        swapped.swap(0, 1);
        assert!(matches!(
            model.finish(&sources, &theta_i, &cones, &swapped),
            Err(TopoError::Partials(_))
        ));
        assert!(matches!(
            model.finish(&sources, &theta_i, &cones, &parts[1..]),
            Err(TopoError::Partials(_))
        ));
    }
    let options = IsotropicOptions {
        node_spacing: Some(0.003),
    };
    let one = model
        .run_isotropic_sources(&sources, &theta_i, &cones, &options, &|_, _| {})
        .unwrap();
    let parts: Vec<_> = [0..70, 70..160]
        .into_iter()
        .map(|range| {
            model
                .trace_tiles_isotropic(&sources, &theta_i, &cones, &options, range, &|_, _| {})
                .unwrap()
        })
        .collect();
    let r = model
        .finish_isotropic(&sources, &theta_i, &cones, &options, &parts)
        .unwrap();
    // `nodes` counts what each part evaluated (the parts build their tables apart).
    assert!(r.nodes >= one.nodes);
    assert_eq!(point_bits(&r.points), point_bits(&one.points));
    assert_eq!(r.interpolation_error, one.interpolation_error);
    assert_eq!(
        (r.rings_lost_tir.to_bits(), r.usable_pixels, r.tiles),
        (one.rings_lost_tir.to_bits(), one.usable_pixels, one.tiles)
    );
    // A plain part cannot finish an isotropic run.
    let plain = model
        .trace_tiles(&sources, &theta_i, &cones, 0..160, &|_, _| {})
        .unwrap();
    assert!(matches!(
        model.finish_isotropic(&sources, &theta_i, &cones, &options, &[plain]),
        Err(TopoError::Partials(_))
    ));
    assert!(matches!(
        model.trace_tiles(&sources, &theta_i, &cones, 150..161, &|_, _| {}),
        Err(TopoError::Partials(_))
    ));
}

#[test]
fn a_read_error_in_the_middle_is_a_source_error_naming_what_the_reader_said() {
    let map = rough_map();
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let mut source = Banded::new(&map, 64);
    source.fail_at = Some(250);
    let e = model
        .run_sources(&[&source], &[0.2], &cones(), &|_, _| {})
        .unwrap_err();
    match &e {
        TopoError::Source { map: 0, error } => {
            assert!(
                error.to_string().contains("store.zarr: array `height`"),
                "{error}"
            );
        }
        other => panic!("{other:?}"),
    }
    assert!(
        e.to_string().starts_with("map 0 (0-based): store.zarr"),
        "{e}"
    );
    // The isotropic run and the pixel tilts likewise.
    let e = model
        .run_isotropic_sources(
            &[&source],
            &[0.2],
            &cones(),
            &IsotropicOptions::default(),
            &|_, _| {},
        )
        .unwrap_err();
    assert!(matches!(e, TopoError::Source { map: 0, .. }), "{e:?}");
    let e = model
        .pixel_tilts_sources(&[&source], 0.02, &|_, _| {})
        .unwrap_err();
    assert!(matches!(e, TopoError::Source { map: 0, .. }), "{e:?}");
}

#[test]
fn small_maps_and_large_windows_behave_as_in_memory() {
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let cones = cones();
    // Smaller than one tile (20 × 12 pixels of 0.5 µm, tiles of 64): one tile.
    let z: Vec<f64> = (0..240).map(|i| 0.05 * (i % 20) as f64).collect();
    let small = HeightMap::new(20, 12, 0.5, 0.5, z).unwrap();
    let whole = model.run(&[&small], &[0.0], &cones).unwrap();
    let source = Banded::new(&small, 5);
    let r = model
        .run_sources(&[&source], &[0.0], &cones, &|_, _| {})
        .unwrap();
    assert_eq!(bits(&r), bits(&whole));
    assert_eq!((r.tiles, r.usable_pixels), (1, 16 * 8));
    // A window larger than the map: the same error, before any read.
    let wide = TopoModel::new(TopoOptions {
        window: 13,
        ..TopoOptions::default()
    })
    .unwrap();
    let want = wide.run(&[&small], &[0.0], &cones).unwrap_err();
    let got = wide
        .run_sources(&[&source], &[0.0], &cones, &|_, _| {})
        .unwrap_err();
    assert_eq!(got, want);
    assert_eq!(
        got,
        TopoError::WindowTooLarge {
            window: 13,
            map: 0,
            nx: 20,
            ny: 12
        }
    );
    let e = wide
        .pixel_tilts_sources(&[&source], 0.02, &|_, _| {})
        .unwrap_err();
    assert_eq!(e, want);
    // No valid point: the in-memory error, found once the map is read.
    let dark = HeightMap::new(20, 12, 0.5, 0.5, vec![f64::NAN; 240]).unwrap();
    let want = model.run(&[&dark], &[0.0], &cones).unwrap_err();
    let got = model
        .run_sources(&[&Banded::new(&dark, 5)], &[0.0], &cones, &|_, _| {})
        .unwrap_err();
    assert_eq!(got, want);
    assert_eq!(
        got,
        TopoError::NoValidPixels {
            map: 0,
            pixels: 240
        }
    );
}
