//! The topographic model averaged over the sample's rotation about its normal
//! (physics.md §5.1): every azimuth, exactly, not a handful of rotated copies.
//!
//! Conventions: angles in radians, lengths in micrometres, the frame and signed `θs` of
//! `flakescatter_optics` (physics.md §1); results absolute, as in [`crate::model`].
//!
//! # What is computed
//! Rotating the sample by `ψ` about `z` turns a pixel's normal
//! `m = (sin θn cos φn, sin θn sin φn, cos θn)` into the one of azimuth `φ = φn + ψ`. The
//! plain model's ray weight `w(θn, φ) = F γ / (m.z cos θt) / N_pixels` (physical) and exit
//! direction `k_out(θn, φ)` depend on `φ`; the isotropic model gives detector `j`
//!
//! `ρ_j = (1/N_pixels) Σ_pixels (1/m.z) · h_j(θn)`,
//! `h_j(θ) = (1/2π) ∫_0^{2π} F γ / cos θt · 1[k_out(θ, φ) ∈ cone j] dφ`,
//!
//! the average of the plain model over `ψ ∈ [0, 2π)`. A pixel enters only through its
//! polar angle `θn` and its area factor `1/m.z`, so the result does not depend on how the
//! map lies on its grid (rotations, transpositions and flips leave it unchanged). With
//! `paper-printed` weighting the factor per pixel is 1 and `h_j` holds `F γ` times the
//! detector's `cos ϑ'_j / cos ϑ_j` (the printed eq. 14), as in the plain model.
//!
//! How `h_j(θ)` is computed, per incidence and node `θ` (the escaping arc of the ring
//! in closed form, the cones' boundaries found on it by Newton's method, the azimuth
//! integrals by Gauss–Legendre quadrature), is written out beside the code, in
//! `isotropic/ring.rs` (the ring and a cone, the equations), `isotropic/response.rs`
//! (sampling and quadrature) and `isotropic/search.rs` (the rims' roots); the table and
//! its interpolation in `isotropic/table.rs`; the
//! scheduling of tiles and table nodes and the reduction in `isotropic/schedule.rs`.
//!
//! # Tabulation and its error
//! `h_j` is evaluated on nodes `θ_k = k δ` (default
//! `δ = α_min/`[`DEFAULT_NODES_PER_APERTURE`], 0.0117° for α = 1.5°), only where pixels
//! need them: tiles are processed in batches, and the nodes a batch needs that are not
//! in the table yet are computed before its tiles are contracted (a node's value does
//! not depend on when it is computed). A pixel at `x = θn/δ` in cell `c = ⌊x⌋`,
//! `t = x − c`, gets `(1 − t) h_j(θ_c) + t h_j(θ_{c+1})`: its area factor is deposited
//! on the two nodes and each tile's deposits are contracted with the table. The error
//! of this linear interpolation is `O(δ²)` where `h_j` is smooth and `O(δ^1.5)` where a
//! ring starts or stops meeting a cone, since `h_j` then rises like `sqrt(θ − θc)`. In
//! such an **edge cell** (`h_j` zero at one node and not at the other) `h_j²` is smooth,
//! and it is interpolated instead: linearly from the two nodes on the lit side, its
//! root clamped into the cell, `h ≈ sqrt(h²)`. This square-root law is applied where
//! `h²` is straight over three lit nodes (second difference below a tenth of the
//! first); other edges (an arc ending at the horizon, where the exit Fresnel factor
//! vanishes smoothly, or an edge next to another change of shape) stay linear.
//!
//! Each result carries an **estimate** of the interpolation error per detector,
//! summed over pixels without cancellation: in cells away from edges, `|fine − coarse|`
//! per pixel, the difference between interpolating from every node and from every
//! second node (spacing `2δ`), which is `hat(t') · |h_k − (h_{k−1} + h_{k+1})/2|` for a
//! pixel in the coarse cell around odd node `k` (`hat` = 1 at `k`, 0 at `k ± 1`), a
//! bound on the fine error wherever halving the spacing at least halves it (4× for
//! smooth `h`, 2.8× at square-root edges); in edge cells, the difference between the
//! square-root and the linear interpolation. Against a per-pixel brute-force
//! integration (tests) the error of the default spacing is at most 2e-3 of the value
//! on a 1300-pixel map and 4e-3 next to specular on a 10⁶-pixel rough map, and the
//! estimate exceeds it in all but a handful of detectors, by at most 1.1×.
//!
//! # Window slopes
//! The slopes are summed directly per pixel ([`crate::normals`]), not with the running
//! sums of the plain model: their rounding (up to 1e-11 rad on deep films) changes
//! with the order of the sums, i.e. when the map is transposed, and the interpolation
//! would amplify it by `1/δ`. With direct sums a transposed, flipped or rotated map
//! gives the same result to 1e-9 (a test).
//!
//! # Uncertainty and determinism
//! Standard errors come from the spread between statistics tiles exactly as in
//! [`crate::model`] (the per-tile sums of the interpolated responses). Pixels are
//! deposited in raster order per tile, each node is computed on its own and stored by
//! index, and tile sums are reduced in tile order: results are bit-identical for any
//! number of rayon threads.
//!
//! # Example
//! At normal incidence a plane tilted by `θ` sends its ring of exit directions around
//! the normal at `asin(n sin 2θ)`; a cone about the normal wider than that collects all
//! of it, `coverage · F` with the Fresnel factor `F` at the ring's exit angle, while a
//! plain-model detector in the plane of incidence at the same angle but on the other
//! side (the ray goes one way only) gets nothing:
//! ```
//! use flakescatter_optics::detector::Cone;
//! use flakescatter_optics::fresnel::air_to_coating;
//! use flakescatter_stats::HeightMap;
//! use flakescatter_topo::{TopoModel, TopoOptions};
//!
//! let (nx, theta) = (30, 4f64.to_radians());
//! let z: Vec<f64> = (0..nx * nx).map(|i| (i % nx) as f64 * 0.5 * theta.tan()).collect();
//! let map = HeightMap::new(nx, nx, 0.5, 0.5, z)?;
//! let model = TopoModel::new(TopoOptions::default())?;
//! let theta_o = (1.5 * (2.0 * theta).sin()).asin();
//! let cones = [
//!     Cone::in_plane(0.0, theta_o + 0.05)?,       // holds the whole ring
//!     Cone::in_plane(-theta_o, 0.01)?,            // the far side of the plane
//! ];
//! let iso = model.run_isotropic(&[&map], &[0.0], &cones)?;
//! let plain = model.run(&[&map], &[0.0], &cones)?;
//! let (fi, fo) = (air_to_coating(0.0, 1.5), air_to_coating(theta_o, 1.5));
//! let f = 0.5 * (fi.ts * fo.ts + fi.tp * fo.tp);
//! let rho = iso.points[0].reflectance;
//! assert!((rho - iso.usable_fraction() * f).abs() < 1e-9 * rho, "{rho} {}", iso.usable_fraction() * f);
//! assert!(iso.points[1].reflectance > 0.0 && plain.points[1].rays == 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use flakescatter_optics::detector::{self, Cone};
use flakescatter_stats::HeightMap;

use std::ops::Range;

use crate::TopoError;
use crate::model::split::{check_parts, check_range};
use crate::model::{
    TileSums, TileSumsKind, TopoModel, TopoPoint, TopoWarning, aperture_index, tile_warnings,
};
use crate::source::HeightSource;

mod response;
mod ring;
mod schedule;
mod search;
mod table;

use response::IsoSetup;
use schedule::IsoSums;

/// What is fixed during an isotropic run.
struct IsoRun<'a> {
    setup: IsoSetup<'a>,
    /// The distinct apertures of the user's cones.
    apertures: Vec<f64>,
    /// Internal detectors per incidence.
    ndet: usize,
    /// Node spacing, radians.
    delta: f64,
}

/// Default number of `θn` nodes per radian of the smallest aperture: the node spacing
/// is `δ = α_min / DEFAULT_NODES_PER_APERTURE` (0.0117° for α = 1.5°).
pub const DEFAULT_NODES_PER_APERTURE: f64 = 128.0;

/// Options of the isotropic average.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct IsotropicOptions {
    /// Spacing `δ` of the `θn` nodes, radians (finite, > 0, at most 0.01 rad); `None`
    /// for `α_min /` [`DEFAULT_NODES_PER_APERTURE`].
    pub node_spacing: Option<f64>,
}

/// What a run of the isotropic model gives: one [`TopoPoint`] per incidence × detector
/// (incidence-major, as [`crate::TopoResult`]) with its interpolation error estimate,
/// and the totals.
///
/// In each point, `rays` counts the pixels whose interpolated response to the detector
/// is non-zero (pixels whose ring, at one of the two nodes around their `θn`, meets the
/// cone); `reflectance_std_err` is the between-tile standard error (NaN with one tile).
#[derive(Debug, Clone, PartialEq)]
pub struct IsotropicResult {
    /// Rows, incidence-major.
    pub points: Vec<TopoPoint>,
    /// Estimated absolute interpolation error of each row's `reflectance` (module docs,
    /// "Tabulation and its error"), aligned with `points`.
    pub interpolation_error: Vec<f64>,
    /// Number of maps accumulated.
    pub maps: usize,
    /// Pixels over all maps (the normalisation `N_pixels`).
    pub pixels: u64,
    /// Pixels with a normal (complete window of valid points), over all maps.
    pub usable_pixels: u64,
    /// Rings traced: usable pixels × incidences.
    pub rings_traced: u64,
    /// Σ over pixels and incidences of the azimuth fraction of each ring lost to total
    /// internal reflection (rays' worth; interpolated between nodes like the response).
    pub rings_lost_tir: f64,
    /// Σ over pixels and incidences of the azimuth fraction heading down (`k2.z ≤ 0`).
    pub rings_lost_down: f64,
    /// Statistics tiles over all maps.
    pub tiles: u64,
    /// Valid points of each map (measured and passing any intensity cutoff), maps in
    /// order.
    pub valid_pixels: Vec<u64>,
    /// Tile side, µm.
    pub block_um: f64,
    /// Node spacing `δ` used, radians.
    pub node_spacing: f64,
    /// Table nodes evaluated, summed over incidences.
    pub nodes: usize,
    /// What the tile count says about the standard errors (as [`crate::TopoResult::warnings`]).
    pub warnings: Vec<TopoWarning>,
}

impl IsotropicResult {
    /// Usable pixels as a fraction of all pixels.
    #[must_use]
    pub fn usable_fraction(&self) -> f64 {
        self.usable_pixels as f64 / self.pixels as f64
    }
}

impl TopoModel {
    /// The isotropic average of the model over the sample's rotation about its normal
    /// (module [`crate::isotropic`]), with default options.
    ///
    /// # Errors
    /// As [`TopoModel::run`].
    pub fn run_isotropic(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
    ) -> Result<IsotropicResult, TopoError> {
        self.run_isotropic_with(
            maps,
            theta_i,
            cones,
            &IsotropicOptions::default(),
            &|_, _| {},
        )
    }

    /// As [`TopoModel::run_isotropic`] with `options`, calling `progress(done, total)`
    /// (in tiles) from the calling thread after each batch of tiles, never from inside
    /// a parallel section: `done` counts the tiles reduced so far, one batch behind (0
    /// at the first call), and the last call has `done == total`.
    ///
    /// # Errors
    /// As [`TopoModel::run`], and [`TopoError::NodeSpacing`] for a node spacing that
    /// is not finite, not positive or above 0.01 rad.
    pub fn run_isotropic_with(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
        options: &IsotropicOptions,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<IsotropicResult, TopoError> {
        self.refuse_absorption()?;
        self.check_run(maps, theta_i, cones)?;
        let sources: Vec<&dyn HeightSource> = maps.iter().map(|&m| m as _).collect();
        self.isotropic_of(&sources, theta_i, cones, options, progress)
    }

    /// As [`TopoModel::run_isotropic_with`] over maps read band by band from `sources`
    /// (module docs of [`crate::model`], "Streaming"): the same numbers, bit for bit,
    /// as the maps in memory.
    ///
    /// # Errors
    /// As [`TopoModel::run_isotropic_with`] and [`TopoModel::run_sources`].
    pub fn run_isotropic_sources(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        options: &IsotropicOptions,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<IsotropicResult, TopoError> {
        self.refuse_absorption()?;
        self.check_sources(sources, theta_i, cones)?;
        self.isotropic_of(sources, theta_i, cones, options, progress)
    }

    /// Traces the tiles numbered `tiles` (of [`TopoModel::tile_count`]) with the
    /// isotropic model and returns their per-tile sums, for
    /// [`TopoModel::finish_isotropic`] (as [`TopoModel::trace_tiles`] for the plain
    /// model).
    ///
    /// # Errors
    /// As [`TopoModel::run_isotropic_sources`] (but for the checks that need all tiles,
    /// made by the finish); [`TopoError::Partials`] for a range that is empty or reaches
    /// past the last tile.
    pub fn trace_tiles_isotropic(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        options: &IsotropicOptions,
        tiles: Range<u64>,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<TileSums, TopoError> {
        self.refuse_absorption()?;
        self.check_sources(sources, theta_i, cones)?;
        check_range(&tiles, self.tile_count(sources))?;
        let run = self.isotropic_setup(theta_i, cones, options)?;
        let nslots = theta_i.len() * run.ndet;
        let mut out = TileSums::empty(
            TileSumsKind::Isotropic,
            tiles.clone(),
            2 * nslots + 2,
            nslots,
            sources.len(),
        );
        let (valid, nodes) = {
            let TileSums {
                rows,
                counts,
                usable,
                ..
            } = &mut out;
            schedule::trace_range(
                self,
                sources,
                &run.setup,
                run.ndet,
                run.delta,
                tiles,
                progress,
                &mut |p| {
                    p.append_to(rows, counts);
                    *usable += p.usable();
                },
            )?
        };
        out.valid = valid;
        out.nodes = nodes;
        Ok(out)
    }

    /// The isotropic result of a run from its parts ([`TopoModel::trace_tiles_isotropic`]
    /// over consecutive ranges covering every tile, in tile order), reduced in tile
    /// order exactly as one call, so bit for bit the same (but `nodes`, the sum of the
    /// parts' table nodes: each part builds the table it needs). As
    /// [`TopoModel::finish`], `sources` give only their sizes and pitches.
    ///
    /// # Errors
    /// As [`TopoModel::run_isotropic_sources`]; [`TopoError::Partials`] as
    /// [`TopoModel::finish`].
    pub fn finish_isotropic(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        options: &IsotropicOptions,
        parts: &[TileSums],
    ) -> Result<IsotropicResult, TopoError> {
        self.refuse_absorption()?;
        self.check_sources(sources, theta_i, cones)?;
        let run = self.isotropic_setup(theta_i, cones, options)?;
        let nslots = theta_i.len() * run.ndet;
        let valid = check_parts(
            parts,
            TileSumsKind::Isotropic,
            (2 * nslots + 2, nslots),
            self.tile_count(sources),
            sources.len(),
        )?;
        let mut sums = IsoSums::new(nslots);
        for p in parts {
            for row in p.rows.chunks_exact(2 * nslots + 2) {
                let (s, rest) = row.split_at(nslots);
                let (d, lost) = rest.split_at(nslots);
                sums.add_floats(s, d, lost[0], lost[1]);
            }
            sums.usable += p.usable;
            for (r, &c) in sums.rays.iter_mut().zip(&p.counts) {
                *r += c;
            }
            sums.nodes += p.nodes;
        }
        self.isotropic_result(sources, &run, sums, &valid, theta_i, cones)
    }

    fn refuse_absorption(&self) -> Result<(), TopoError> {
        if self.absorption().is_some() {
            return Err(TopoError::Unsupported(
                "the isotropic average does not include binder absorption (its weight is integrated around each ring without the path factor); use the plain topographic model",
            ));
        }
        Ok(())
    }

    /// The node spacing, internal detectors and setup of an isotropic run.
    fn isotropic_setup<'a>(
        &'a self,
        theta_i: &[f64],
        cones: &[Cone],
        options: &IsotropicOptions,
    ) -> Result<IsoRun<'a>, TopoError> {
        let alpha_min = cones
            .iter()
            .map(Cone::half_angle)
            .fold(f64::INFINITY, f64::min);
        let delta = match options.node_spacing {
            Some(d) => {
                if !(d.is_finite() && d > 0.0 && d <= 0.01) {
                    return Err(TopoError::NodeSpacing(d));
                }
                d
            }
            None => alpha_min / DEFAULT_NODES_PER_APERTURE,
        };
        // Internal detectors per incidence: the user's cones, then a specular cone per
        // distinct aperture (for `relative`).
        let apertures = flakescatter_optics::detector::distinct_apertures(cones);
        let ndet = cones.len() + apertures.len();
        let setup = IsoSetup::new(self.options(), theta_i, cones, &apertures, delta)?;
        Ok(IsoRun {
            setup,
            apertures,
            ndet,
            delta,
        })
    }

    /// The isotropic run over `sources` after the checks.
    fn isotropic_of(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        options: &IsotropicOptions,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<IsotropicResult, TopoError> {
        let run = self.isotropic_setup(theta_i, cones, options)?;
        let mut sums = IsoSums::new(theta_i.len() * run.ndet);
        let total = self.tile_count(sources);
        let (valid, nodes) = schedule::trace_range(
            self,
            sources,
            &run.setup,
            run.ndet,
            run.delta,
            0..total,
            progress,
            &mut |p| sums.add_partial(&p),
        )?;
        sums.nodes = nodes;
        self.isotropic_result(sources, &run, sums, &valid, theta_i, cones)
    }

    /// The result from the reduced sums, after the checks that need the data.
    fn isotropic_result(
        &self,
        sources: &[&dyn HeightSource],
        run: &IsoRun<'_>,
        sums: IsoSums,
        valid: &[u64],
        theta_i: &[f64],
        cones: &[Cone],
    ) -> Result<IsotropicResult, TopoError> {
        let pixels = self.check_valid(sources, valid, sums.usable)?;
        let (points, interpolation_error) =
            self.isotropic_points(&run.setup, &sums, pixels, theta_i, cones, &run.apertures);
        let tiles = sums.tiles();
        Ok(IsotropicResult {
            points,
            interpolation_error,
            maps: sources.len(),
            pixels,
            usable_pixels: sums.usable,
            rings_traced: sums.usable * theta_i.len() as u64,
            rings_lost_tir: sums.lost_tir,
            rings_lost_down: sums.lost_down,
            tiles,
            valid_pixels: valid.to_vec(),
            block_um: self.block_um(),
            node_spacing: run.delta,
            warnings: tile_warnings(tiles),
            nodes: sums.nodes,
        })
    }

    /// The rows of a run (with each row's interpolation error estimate) from its sums
    /// over `pixels` pixels.
    fn isotropic_points(
        &self,
        setup: &IsoSetup<'_>,
        sums: &IsoSums,
        pixels: u64,
        theta_i: &[f64],
        cones: &[Cone],
        apertures: &[f64],
    ) -> (Vec<TopoPoint>, Vec<f64>) {
        let opts = self.options();
        let (stats, rays, defect) = (&sums.stats, &sums.rays, &sums.defect);
        let ndet = cones.len() + apertures.len();
        let ninc = theta_i.len();
        let total_tiles = sums.tiles();
        let inv_n = 1.0 / pixels as f64;
        let t = total_tiles as f64;
        // No spread to estimate from with one tile, nor in a detector no ring reached
        // (as in the plain model): None, not NaN.
        let se_factor = (total_tiles > 1).then(|| t / (t - 1.0));
        let ncones = cones.len();
        let mut points = Vec::with_capacity(ninc * ncones);
        let mut interpolation_error = Vec::with_capacity(ninc * ncones);
        for (ii, &ti) in theta_i.iter().enumerate() {
            let inc = &setup.incs[ii];
            let specular = detector::specular_direction(ti);
            let cc = opts.transmission.clearcoat_reflectance(&inc.entry);
            let value = |d: usize| {
                let s = ii * ndet + d;
                let seen_cc = opts.clearcoat && inc.cones[d].contains(&specular);
                let rho = stats.sum()[s] * inv_n + if seen_cc { cc } else { 0.0 };
                let se = se_factor
                    .filter(|_| rays[s] > 0)
                    .map(|f| (f * stats.m2()[s]).sqrt() * inv_n);
                (rho, se, seen_cc)
            };
            for (j, cone) in cones.iter().enumerate() {
                let (rho, se, seen_cc) = value(j);
                let a = aperture_index(apertures, cone);
                let (spec, _, _) = value(ncones + a);
                let proj = cone.projected_solid_angle();
                let s = ii * ndet + j;
                points.push(TopoPoint {
                    theta_i: ti,
                    cone: *cone,
                    reflectance: rho,
                    reflectance_std_err: se,
                    brdf: rho / proj,
                    brdf_std_err: se.map(|e| e / proj),
                    rays: rays[s],
                    relative: if spec > 0.0 { rho / spec } else { f64::NAN },
                    specular_reflectance: spec,
                    clearcoat_seen: seen_cc,
                });
                interpolation_error.push(defect[s] * inv_n);
            }
        }
        (points, interpolation_error)
    }
}
