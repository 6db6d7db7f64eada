//! Pixel-level orientation statistics: the area-weighted distribution of the local
//! normals the topographic model traces (physics.md §5.2).
//!
//! Conventions: angles in radians, areas in µm², map axes as in [`HeightMap`]. Every
//! usable pixel (complete `k × k` window of valid points) contributes its normal's polar
//! angle `θn = atan(sqrt(a² + b²))` from the windowed slopes `(a, b)` (summed directly,
//! as the isotropic model does), weighted by its **true area** `dx · dy / m.z =
//! dx · dy · sqrt(1 + a² + b²)`: the area of the local plane whose projection is the
//! pixel. That is the factor `1/m.z` of the topographic model's ray weight
//! `F γ / (m.z cos θt)`; the rest, `F γ / cos θt`, is what the distribution model
//! (physics.md §4) applies to an area-weighted density of normals. Bins are those of
//! [`flakescatter_stats::histogram::bin_edges`]: `[lo, hi)` of equal width from 0, the
//! last cut at π/2.
//!
//! Sums are also kept per statistics tile (the tiles of [`crate::model`]) so that the
//! spread between tiles can carry the uncertainty of anything computed from them:
//! neighbouring pixels share windows and flakes and are far from independent.

use flakescatter_stats::HeightMap;
use flakescatter_stats::distribution::{DistributionError, Orientation};
use flakescatter_stats::histogram::bin_edges;
use rayon::prelude::*;

use crate::TopoError;
use crate::model::TopoModel;
use crate::normals::{DirectRow, Scratch, tile_usable};
use crate::source::HeightSource;

/// Tiles whose pixels' bins are held at once (a few MB for tiles of 64² pixels).
const TILT_BATCH: usize = 256;

/// Sums of one statistics tile.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TileTilts {
    /// Usable pixels.
    pub pixels: u64,
    /// Their true area, µm².
    pub area_um2: f64,
    /// `Σ area · θn²`, µm² rad².
    pub area_theta2: f64,
}

/// The area-weighted distribution of the usable pixels' normals over a set of maps.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelTilts {
    /// Bin edges, radians (`bins + 1` values).
    pub edges: Vec<f64>,
    /// True area of the usable pixels in each bin, µm².
    pub bin_area_um2: Vec<f64>,
    /// Per statistics tile, maps in order, tiles row-major.
    pub tiles: Vec<TileTilts>,
    /// Usable pixels over all maps.
    pub usable_pixels: u64,
    /// All pixels over all maps.
    pub pixels: u64,
}

impl PixelTilts {
    /// Total true area of the usable pixels, µm².
    #[must_use]
    pub fn total_area_um2(&self) -> f64 {
        self.bin_area_um2.iter().sum()
    }

    /// Area fraction per bin (sums to 1).
    #[must_use]
    pub fn area_fractions(&self) -> Vec<f64> {
        let total = self.total_area_um2();
        self.bin_area_um2.iter().map(|a| a / total).collect()
    }

    /// The distribution as a tabulated [`Orientation`] (same edges and fractions).
    ///
    /// # Errors
    /// Never for tilts built by [`TopoModel::pixel_tilts`] (at least one usable pixel);
    /// the `Result` is passed through.
    pub fn orientation(&self) -> Result<Orientation, DistributionError> {
        Orientation::tabulated(self.edges.clone(), self.bin_area_um2.clone())
    }

    /// Usable pixels as a fraction of all pixels (the coverage that multiplies the
    /// distribution model in physics.md §5.2).
    #[must_use]
    pub fn coverage(&self) -> f64 {
        self.usable_pixels as f64 / self.pixels as f64
    }

    /// Area-weighted mean square tilt `m2 = Σ a θ² / Σ a`, rad² (exact, not binned).
    #[must_use]
    pub fn mean_square_tilt(&self) -> f64 {
        let (a, s) = self
            .tiles
            .iter()
            .fold((0.0, 0.0), |(a, s), t| (a + t.area_um2, s + t.area_theta2));
        s / a
    }

    /// Standard error of [`PixelTilts::mean_square_tilt`] from the spread between tiles:
    /// the ratio-estimator form `sqrt(T/(T − 1) Σ_t (S_t − m2 A_t)²) / Σ_t A_t` over the
    /// `T` tiles with usable pixels. NaN with fewer than two such tiles.
    #[must_use]
    pub fn mean_square_tilt_std_err(&self) -> f64 {
        let m2 = self.mean_square_tilt();
        let used: Vec<&TileTilts> = self.tiles.iter().filter(|t| t.pixels > 0).collect();
        let t = used.len() as f64;
        if used.len() < 2 {
            return f64::NAN;
        }
        let total: f64 = used.iter().map(|t| t.area_um2).sum();
        let ss: f64 = used
            .iter()
            .map(|x| (x.area_theta2 - m2 * x.area_um2).powi(2))
            .sum();
        (t / (t - 1.0) * ss).sqrt() / total
    }
}

impl TopoModel {
    /// The area-weighted distribution of the usable pixels' normals over `maps`, in bins
    /// of `bin_width` radians (module [`crate::pixels`]).
    ///
    /// # Errors
    /// [`TopoError::Empty`] for no map, [`TopoError::BinWidth`] unless
    /// `0 < bin_width ≤ π/4`, [`TopoError::WindowTooLarge`] / [`TopoError::NoValidPixels`]
    /// for a map that cannot be used, [`TopoError::NoUsablePixels`] when no pixel has a
    /// complete window.
    pub fn pixel_tilts(
        &self,
        maps: &[&HeightMap],
        bin_width: f64,
    ) -> Result<PixelTilts, TopoError> {
        if maps.is_empty() {
            return Err(TopoError::Empty("height map"));
        }
        let edges = bin_edges(bin_width).map_err(|_| TopoError::BinWidth(bin_width))?;
        for (i, map) in maps.iter().enumerate() {
            self.check_map(i, map)?;
        }
        let sources: Vec<&dyn HeightSource> = maps.iter().map(|&m| m as _).collect();
        self.tilts_of(&sources, edges, bin_width, &|_, _| {})
    }

    /// As [`TopoModel::pixel_tilts`] over maps read band by band from `sources`
    /// (module docs of [`crate::model`], "Streaming"): the same numbers, bit for bit.
    /// `progress(done, total)` counts tiles, called on the calling thread after each
    /// batch of tiles.
    ///
    /// # Errors
    /// As [`TopoModel::pixel_tilts`], [`TopoError::NoValidPixels`] once a map has been
    /// read and held no valid point, and [`TopoError::Source`] when a source cannot
    /// give a band.
    pub fn pixel_tilts_sources(
        &self,
        sources: &[&dyn HeightSource],
        bin_width: f64,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<PixelTilts, TopoError> {
        if sources.is_empty() {
            return Err(TopoError::Empty("height map"));
        }
        let edges = bin_edges(bin_width).map_err(|_| TopoError::BinWidth(bin_width))?;
        let k = self.options().window;
        for (i, s) in sources.iter().enumerate() {
            let (nx, ny) = s.size();
            if k > nx || k > ny {
                return Err(TopoError::WindowTooLarge {
                    window: k,
                    map: i,
                    nx,
                    ny,
                });
            }
        }
        self.tilts_of(sources, edges, bin_width, progress)
    }

    /// The tilts of every tile of `sources`, band by band, each batch of tiles in
    /// parallel and reduced in tile order (pixels in raster order within a tile);
    /// `progress(done, total)` in tiles after each batch.
    fn tilts_of(
        &self,
        sources: &[&dyn HeightSource],
        edges: Vec<f64>,
        bin_width: f64,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<PixelTilts, TopoError> {
        let nb = edges.len() - 1;
        let h = self.options().window / 2;
        let mut bin_area_um2 = vec![0.0; nb];
        let mut tiles = Vec::new();
        let mut usable = 0;
        let total = self.tile_count(sources);
        let valid = self.for_each_batch(sources, 0..total, TILT_BATCH, |_, map, batch| {
            let per_tile: Vec<(TileTilts, Vec<(usize, f64)>)> = batch
                .par_iter()
                .map_init(
                    || (Scratch::default(), DirectRow::default()),
                    |(scratch, direct), &rect| {
                        let mut direct = direct.tile(map, h, rect, self.kernels());
                        let pixel_area = map.dx() * map.dy();
                        let mut t = TileTilts::default();
                        let mut bins = Vec::new();
                        tile_usable(map, h, rect, scratch, |row, col| {
                            let (a, b) = direct.slopes(row, col);
                            let r2 = a * a + b * b;
                            let theta = r2.sqrt().atan();
                            let area = pixel_area * (1.0 + r2).sqrt();
                            t.pixels += 1;
                            t.area_um2 += area;
                            t.area_theta2 += area * theta * theta;
                            bins.push((((theta / bin_width) as usize).min(nb - 1), area));
                        });
                        (t, bins)
                    },
                )
                .collect();
            for (t, bins) in per_tile {
                usable += t.pixels;
                tiles.push(t);
                for (i, a) in bins {
                    bin_area_um2[i] += a;
                }
            }
            progress(tiles.len() as u64, total);
        })?;
        let pixels = self.check_valid(sources, &valid, usable)?;
        Ok(PixelTilts {
            edges,
            bin_area_um2,
            tiles,
            usable_pixels: usable,
            pixels,
        })
    }
}
