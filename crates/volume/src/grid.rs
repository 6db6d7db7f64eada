//! A periodic uniform grid of columns over the tile, and exact ray–cylinder hits.
//!
//! Conventions: lengths in µm, the tile `[0, L)²` periodic, `z` up. The grid has
//! `G × G` square columns of side `h = L/G` spanning the film's whole depth. Every flake
//! is listed in each column its axis-aligned lateral bounding box (half-widths from the
//! cylinder's support function, [`Flake::half_extent`]) overlaps, together with which
//! periodic image (`±L` in `x` and `y`) lies there. A ray walks the columns in order of
//! distance (Amanatides–Woo); a hit found in the current column at a distance no larger
//! than where the ray leaves that column is the nearest, because any surface point the
//! ray reaches inside a column belongs to a flake listed in that column.
//!
//! A uniform grid is chosen over a bounding volume hierarchy because the layer is a thin slab
//! (tens of µm) of flakes a few columns wide: a straight segment between two events
//! crosses only a few columns, and the periodic wrap is free (column indices modulo
//! `G`); the benchmark `volume` measures segments per second.
//!
//! Memory: a query reads its columns' offsets, entries and flakes, three loads that
//! depend on one another. Rays that start at independent random points find them out
//! of the cache; the tracer orders the entry points along a Z-order curve (module
//! `trace`), so that a ray finds most of them where its neighbour left them, which
//! made an explicit early load of the first columns of groups of rays (once 12 % of
//! the time) worth nothing, and it was removed. Per-entry records carrying
//! each listed image's centre and bounding radius (exact `f64`, or rounded to 16 bits
//! with a conservative test) were measured and were slower: they spare the flake load
//! of most rejected entries, but those flakes lie close in memory (the layer keeps them
//! in Morton order), and the larger grid costs more cache misses than that saves.
//!
//! Where the time goes (paper's coating, columns one diameter wide, counted with
//! callgrind on a 1240 µm tile so that the numbers do not depend on the machine's load):
//! a query walks 1.9 columns and lists 8.5 entries, 1.7 of them pass the sphere reject
//! and 0.5 become the hit; 1.9 of the 8.5 are flakes met in the column before, which
//! the walk passes over (`sides`, 14 % fewer instructions per query: 741 against
//! 858). With rays in the Z-order of their entry points (module `trace`) the memory
//! waits are mostly gone and the mispredicted reject is the largest cost, so the
//! sphere rejects of a block of entries are made without branches, the survivors kept,
//! and only those tested further (3–4 % faster; with independent entry points, when
//! memory dominated, it had been slower). These were measured and were slower, so they
//! are not used: an `f32` centre and radius per
//! flake in a separate array, rejecting before the flake is loaded (one more dependent
//! load on the way to the flake); per-column blocks of four entries' `f32` centres and
//! radii with a vectorised reject (fewer mispredictions, 1.84 M against 2.47 M per run,
//! but more instructions, 269 M against 227 M, and a grid about six times larger); columns
//! sorted by height, stopping once the remaining entries lie beyond the best hit or the
//! column (20 % fewer entries tested, slower on the full tile).

use flakescatter_optics::Vec3;

use crate::layer::Flake;

/// Which part of a flake a ray meets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Surface {
    /// The face with outward normal `m`.
    Top,
    /// The face with outward normal `−m`.
    Bottom,
    /// The side wall.
    Rim,
}

/// The nearest flake surface along a ray.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Hit {
    /// Distance along the (unit) ray direction, µm.
    pub tau: f64,
    /// Index of the flake.
    pub flake: u32,
    /// Which surface.
    pub surface: Surface,
    /// Outward unit normal of that surface at the hit point.
    pub normal: Vec3,
}

/// What a ray meets first.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Next {
    /// A flake surface.
    Flake(Hit),
    /// Nothing before `tau_max` (the film's top or bottom).
    Boundary,
    /// The ray crossed more columns than allowed.
    TooLong,
}

/// Bits of an entry's `sides`: its flake's bounding box (this image) also covers the
/// column at `i − 1`, `i + 1`, `j − 1`, `j + 1`.
const LEFT: u32 = 1;
const RIGHT: u32 = 2;
const BELOW: u32 = 4;
const ABOVE: u32 = 8;

/// Most flakes a grid can list (entries keep the index in 24 bits).
pub(crate) const MAX_GRID_FLAKES: usize = 1 << 24;

/// Distance below which a ray leaving a flake ignores that same flake (µm): a ray that
/// leaves a convex body outward cannot meet it again, and this absorbs rounding.
const SELF_EPS: f64 = 1e-9;

/// The column grid (CSR layout). Entries are `flake << 8 | sides << 4 | image`:
/// `image = (sx + 1) + 3 (sy + 1)` for the periodic shift `(sx L, sy L)`,
/// `sx, sy ∈ {−1, 0, 1}`, and `sides` the neighbouring columns that the same image's
/// bounding box also covers ([`LEFT`], [`RIGHT`], [`BELOW`], [`ABOVE`]), so that the
/// walk can pass over a flake it has tested in the column it came from.
#[derive(Debug, Clone)]
pub(crate) struct FlakeGrid {
    tile: f64,
    side: usize,
    cell: f64,
    inv_cell: f64,
    offsets: Vec<u32>,
    entries: Vec<u32>,
    /// The shift `(sx L, sy L)` of each image code (16 slots, codes 9 to 15 unused, so
    /// that indexing with the entry's low four bits needs no bounds check).
    images: [(f64, f64); 16],
}

impl FlakeGrid {
    /// A grid of columns of side about `cell_um` (at least `L/2048`, at most `L`).
    pub fn new(flakes: &[Flake], tile: f64, cell_um: f64) -> Self {
        let side = ((tile / cell_um).floor() as usize).clamp(1, 2048);
        let cell = tile / side as f64;
        let inv_cell = side as f64 / tile;
        let g = side as i64;
        let span = |k: &Flake| {
            let ex = k.half_extent(&Vec3::x());
            let ey = k.half_extent(&Vec3::y());
            let i0 = ((k.centre.x - ex) * inv_cell).floor() as i64;
            let i1 = ((k.centre.x + ex) * inv_cell).floor() as i64;
            let j0 = ((k.centre.y - ey) * inv_cell).floor() as i64;
            let j1 = ((k.centre.y + ey) * inv_cell).floor() as i64;
            // The box is narrower than the tile (the tile exceeds every flake's extent),
            // so it spans at most G + 1 unwrapped columns; two of them may wrap onto the
            // same column, with different images, and both are listed.
            (i0, i1, j0, j1)
        };
        let mut counts = vec![0u32; side * side + 1];
        for k in flakes {
            let (i0, i1, j0, j1) = span(k);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let c = j.rem_euclid(g) as usize * side + i.rem_euclid(g) as usize;
                    counts[c + 1] += 1;
                }
            }
        }
        for c in 0..side * side {
            counts[c + 1] += counts[c];
        }
        let offsets = counts;
        let mut fill = offsets.clone();
        let mut entries = vec![0u32; offsets[side * side] as usize];
        for (f, k) in flakes.iter().enumerate() {
            let (i0, i1, j0, j1) = span(k);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let c = j.rem_euclid(g) as usize * side + i.rem_euclid(g) as usize;
                    // Column i (unwrapped) holds the image shifted by −floor(i / G) tiles.
                    let sx = -i.div_euclid(g);
                    let sy = -j.div_euclid(g);
                    let image = (sx + 1) + 3 * (sy + 1);
                    let side_bit = |covers: bool, bit: u32| if covers { bit } else { 0 };
                    let sides = side_bit(i > i0, LEFT)
                        | side_bit(i < i1, RIGHT)
                        | side_bit(j > j0, BELOW)
                        | side_bit(j < j1, ABOVE);
                    entries[fill[c] as usize] = ((f as u32) << 8) | sides << 4 | image as u32;
                    fill[c] += 1;
                }
            }
        }
        Self {
            tile,
            side,
            cell,
            inv_cell,
            offsets,
            entries,
            images: std::array::from_fn(|c| {
                if c < 9 {
                    (((c % 3) as f64 - 1.0) * tile, ((c / 3) as f64 - 1.0) * tile)
                } else {
                    (0.0, 0.0)
                }
            }),
        }
    }

    /// Columns per side.
    pub fn side(&self) -> usize {
        self.side
    }

    /// Bytes held by the grid.
    pub fn memory_bytes(&self) -> usize {
        (self.offsets.capacity() + self.entries.capacity()) * std::mem::size_of::<u32>()
    }

    /// The nearest flake surface along `o + τ k`, `0 < τ < tau_max`, with `o.x, o.y` in
    /// the tile. `last` is the flake the ray just left (ignored below [`SELF_EPS`]);
    /// with `rims_transparent` a flake entered through its rim is passed through.
    /// Walks at most `max_cells` columns.
    // One query with the ray, its limits and the two per-path flags: a struct would only
    // rename them.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn nearest(
        &self,
        flakes: &[Flake],
        o: &Vec3,
        k: &Vec3,
        tau_max: f64,
        last: Option<u32>,
        rims_transparent: bool,
        max_cells: u64,
    ) -> Next {
        let side = self.side;
        // Column indices wrapped into the tile, and the shift of the current column's
        // tile copy (the ray is followed without wrapping along one segment).
        let mut wi = ((o.x * self.inv_cell) as usize).min(side - 1);
        let mut wj = ((o.y * self.inv_cell) as usize).min(side - 1);
        let (mut bx, mut by) = (0.0, 0.0);
        let (step_i, delta_x, mut next_x) = axis_setup(o.x, k.x, wi, self.cell);
        let (step_j, delta_y, mut next_y) = axis_setup(o.y, k.y, wj, self.cell);
        let l = self.tile;
        let images = &self.images;
        let mut best = tau_max;
        let mut hit: Option<Hit> = None;
        let mut visited = 0u64;
        // The entries to pass over: `sides` (shifted into place) pointing back at the
        // previous column; none in the first.
        let mut skip = 0u32;
        loop {
            let c = wj * side + wi;
            let cell = &self.entries[self.offsets[c] as usize..self.offsets[c + 1] as usize];
            // The origin relative to this column's copy of the tile.
            let (ox, oy) = (o.x - bx, o.y - by);
            // Two passes per block of entries: the sphere reject of every entry without
            // branches (its outcome is hard to predict), keeping the survivors; then
            // the survivors in order, with the reject's last test (against the best hit
            // so far) and the exact cylinder. The same tests in the same order as one
            // pass would make, on the same numbers, so the same hits.
            for block in cell.chunks(BLOCK) {
                let mut kept = [0u32; BLOCK];
                let mut n = 0;
                for &e in block {
                    let (_, rb2, b, dd) = sphere_terms(flakes, images, e, ox, oy, o.z, k);
                    // Listed in the column the walk came from too: this image was tested
                    // there (or in a column before that), and its tests only get stricter
                    // as the best hit shrinks, so testing it again cannot give a nearer
                    // hit. (Across a wrap of the tile the origin is relative to another
                    // copy of the tile, so a second test would differ by rounding.)
                    let fresh = e & skip == 0;
                    let near = !(dd - b * b > rb2) & !((b > 0.0) & (dd > rb2));
                    kept[n] = e;
                    n += usize::from(fresh & near);
                }
                for &e in &kept[..n] {
                    let (d, rb2, b, _) = sphere_terms(flakes, images, e, ox, oy, o.z, k);
                    if -b - rb2.sqrt() >= best {
                        continue;
                    }
                    let f = e >> 8;
                    let flake = &flakes[f as usize];
                    let min_tau = if last == Some(f) { SELF_EPS } else { 0.0 };
                    if let Some((tau, surface, normal)) = intersect_solid(flake, &d, k, best)
                        && tau > min_tau
                        && tau < best
                        && !(rims_transparent && surface == Surface::Rim)
                    {
                        best = tau;
                        hit = Some(Hit {
                            tau,
                            flake: f,
                            surface,
                            normal,
                        });
                    }
                }
            }
            let exit = next_x.min(next_y);
            if best <= exit || exit >= tau_max {
                break;
            }
            if next_x < next_y {
                next_x += delta_x;
                skip = if step_i > 0 { LEFT << 4 } else { RIGHT << 4 };
                if step_i > 0 {
                    wi += 1;
                    if wi == side {
                        wi = 0;
                        bx += l;
                    }
                } else if wi == 0 {
                    wi = side - 1;
                    bx -= l;
                } else {
                    wi -= 1;
                }
            } else {
                next_y += delta_y;
                skip = if step_j > 0 { BELOW << 4 } else { ABOVE << 4 };
                if step_j > 0 {
                    wj += 1;
                    if wj == side {
                        wj = 0;
                        by += l;
                    }
                } else if wj == 0 {
                    wj = side - 1;
                    by -= l;
                } else {
                    wj -= 1;
                }
            }
            visited += 1;
            if visited > max_cells {
                return Next::TooLong;
            }
        }
        match hit {
            Some(h) => Next::Flake(h),
            None => Next::Boundary,
        }
    }
}

/// Entries whose sphere rejects are made together (see [`FlakeGrid::nearest`]).
const BLOCK: usize = 32;

/// For entry `e` and the ray origin `(ox, oy, oz)` relative to the column's copy of the
/// tile: `d` = origin − the flake image's centre, the bounding sphere's `r² + (t/2)²`,
/// `b = d·k` and `|d|²` (the terms of the bounding-sphere reject of `intersect`, the
/// same operations in the same order, so the same bits).
#[inline(always)]
fn sphere_terms(
    flakes: &[Flake],
    images: &[(f64, f64); 16],
    e: u32,
    ox: f64,
    oy: f64,
    oz: f64,
    k: &Vec3,
) -> (Vec3, f64, f64, f64) {
    let (sx, sy) = images[(e & 15) as usize];
    let flake = &flakes[(e >> 8) as usize];
    let d = Vec3::new(
        ox - (flake.centre.x + sx),
        oy - (flake.centre.y + sy),
        oz - flake.centre.z,
    );
    let (r, ht) = (flake.radius_um, 0.5 * flake.thickness_um);
    let rb2 = r * r + ht * ht;
    let b = d.x * k.x + d.y * k.y + d.z * k.z;
    let dd = d.x * d.x + d.y * d.y + d.z * d.z;
    (d, rb2, b, dd)
}

/// `(step, distance between column walls, distance to the first wall)` along one axis.
fn axis_setup(o: f64, k: f64, i: usize, cell: f64) -> (i64, f64, f64) {
    if k > 0.0 {
        (1, cell / k, ((i + 1) as f64 * cell - o) / k)
    } else if k < 0.0 {
        (-1, -cell / k, (i as f64 * cell - o) / k)
    } else {
        (0, f64::INFINITY, f64::INFINITY)
    }
}

/// Entry of the ray `d + τ k` (`d` = origin − flake centre, `k` unit) into the solid
/// cylinder: `(τ, surface, outward normal)` for the entry point with `τ > 0` and
/// `τ < limit`, or `None`. Exact: the slab `|s| ≤ t/2` along the axis intersected with
/// the infinite cylinder of radius `r`; the later of the two entries is where the ray
/// enters the solid, through a face when the slab entry is the later one.
#[cfg(test)]
pub(crate) fn intersect(
    flake: &Flake,
    d: &Vec3,
    k: &Vec3,
    limit: f64,
) -> Option<(f64, Surface, Vec3)> {
    let r = flake.radius_um;
    let ht = 0.5 * flake.thickness_um;
    // Bounding sphere: reject rays that pass it or start beyond it going away.
    let rb2 = r * r + ht * ht;
    let b = d.dot(k);
    let dd = d.norm_squared();
    if dd - b * b > rb2 || (b > 0.0 && dd > rb2) || -b - rb2.sqrt() >= limit {
        return None;
    }
    intersect_solid(flake, d, k, limit)
}

/// `intersect` after its bounding-sphere reject (which [`FlakeGrid::nearest`] makes
/// itself, on the same values): the slab and the infinite cylinder.
#[inline(always)]
fn intersect_solid(flake: &Flake, d: &Vec3, k: &Vec3, limit: f64) -> Option<(f64, Surface, Vec3)> {
    let r = flake.radius_um;
    let ht = 0.5 * flake.thickness_um;
    let m = flake.normal.into_inner();
    let s0 = d.dot(&m);
    let sk = k.dot(&m);
    let (ts_in, ts_out) = if sk != 0.0 {
        let a = (ht - s0) / sk;
        let c = (-ht - s0) / sk;
        if a < c { (a, c) } else { (c, a) }
    } else if s0.abs() <= ht {
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        return None;
    };
    // The slab alone already misses: behind the ray or beyond the limit.
    if ts_out <= 0.0 || ts_in >= limit {
        return None;
    }
    let w0 = d - s0 * m;
    let wk = k - sk * m;
    let qa = wk.norm_squared();
    let qb = w0.dot(&wk);
    let qc = w0.norm_squared() - r * r;
    let (tc_in, tc_out) = if qa > 1e-300 {
        let disc = qb * qb - qa * qc;
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        ((-qb - sq) / qa, (-qb + sq) / qa)
    } else if qc <= 0.0 {
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        return None;
    };
    let t_in = ts_in.max(tc_in);
    let t_out = ts_out.min(tc_out);
    if t_in > t_out || t_in <= 0.0 || t_in >= limit {
        return None;
    }
    if ts_in >= tc_in {
        if sk < 0.0 {
            Some((t_in, Surface::Top, m))
        } else {
            Some((t_in, Surface::Bottom, -m))
        }
    } else {
        Some((t_in, Surface::Rim, (w0 + t_in * wk) / r))
    }
}

#[cfg(test)]
mod tests {
    //! The grid walk against a search without a grid: every flake, every one of its
    //! nine periodic images, the same exact cylinder test, the nearest accepted hit.
    //! This checks the listing of flakes in columns, the periodic images, the walk's
    //! stopping rule and the written-out sphere reject of `nearest`.

    use flakescatter_optics::Vec3;
    use flakescatter_stats::{GaussianWidth, Orientation};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::{FlakeGrid, Next, SELF_EPS, Surface, intersect};
    use crate::layer::{Flake, Layer};
    use crate::params::{Amount, Diameter, LayerParams, LayerSpec};

    fn layer(tile: f64, hwhm_deg: f64, seed: u64) -> Layer {
        let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
        let mut spec = LayerSpec::new(o, tile, seed);
        spec.film_um = 20.0;
        spec.diameter = Diameter::LogNormal {
            mean_um: 8.0,
            rel_sd: 0.3,
        };
        spec.thickness_um = 0.6;
        spec.amount = Amount::VolumeFraction(0.06);
        Layer::generate(&LayerParams::new(spec).unwrap()).unwrap()
    }

    /// The nearest accepted hit over all flakes and all their periodic images along the
    /// segment (a segment may cross several tiles), by the rules of `nearest`.
    fn brute(
        flakes: &[Flake],
        tile: f64,
        o: &Vec3,
        k: &Vec3,
        tau_max: f64,
        last: Option<u32>,
        rims_transparent: bool,
    ) -> Option<(f64, u32, Surface)> {
        let end = o + tau_max * k;
        let shifts = |a: f64, b: f64| {
            let lo = (a.min(b) / tile).floor() as i64 - 1;
            let hi = (a.max(b) / tile).floor() as i64 + 1;
            lo..=hi
        };
        let mut best: Option<(f64, u32, Surface)> = None;
        for (f, flake) in flakes.iter().enumerate() {
            let f = f as u32;
            for sx in shifts(o.x, end.x) {
                for sy in shifts(o.y, end.y) {
                    let c = flake.centre + Vec3::new(sx as f64 * tile, sy as f64 * tile, 0.0);
                    let limit = best.map_or(tau_max, |b| b.0);
                    let min_tau = if last == Some(f) { SELF_EPS } else { 0.0 };
                    if let Some((tau, surface, _)) = intersect(flake, &(o - c), k, limit)
                        && tau > min_tau
                        && !(rims_transparent && surface == Surface::Rim)
                    {
                        best = Some((tau, f, surface));
                    }
                }
            }
        }
        best
    }

    #[test]
    fn nearest_agrees_with_a_search_over_every_flake_and_image() {
        let mut checked = 0;
        let mut hits = 0;
        // A tile a few flakes wide (most flakes wrap), and a wider one, with flat and
        // strongly tilted flakes; columns from a fraction of a flake to the whole tile.
        for (tile, hwhm, seed, cells) in [
            (40.0, 10.0, 1, &[3.0, 8.0, 40.0][..]),
            (120.0, 40.0, 2, &[4.0, 8.0, 16.0][..]),
        ] {
            let layer = layer(tile, hwhm, seed);
            let flakes = layer.flakes();
            let film = layer.film_um();
            assert!(flakes.len() > 10, "{} flakes", flakes.len());
            for &cell in cells {
                let grid = FlakeGrid::new(flakes, tile, cell);
                let mut rng = ChaCha8Rng::seed_from_u64(seed * 100 + cell as u64);
                for ray in 0..3000 {
                    let o = Vec3::new(
                        tile * rng.random::<f64>(),
                        tile * rng.random::<f64>(),
                        -film * rng.random::<f64>(),
                    );
                    // Directions uniform on the sphere, a fifth of them nearly parallel
                    // to the film (long walks that wrap around the tile several times).
                    let cz: f64 = if ray % 5 == 0 {
                        (0.05 + 0.05 * rng.random::<f64>()) * if ray % 2 == 0 { 1.0 } else { -1.0 }
                    } else {
                        2.0 * rng.random::<f64>() - 1.0
                    };
                    let phi = std::f64::consts::TAU * rng.random::<f64>();
                    let s = (1.0 - cz * cz).sqrt();
                    let k = Vec3::new(s * phi.cos(), s * phi.sin(), cz);
                    if k.z.abs() < 1e-3 {
                        continue;
                    }
                    let tau_max = if k.z > 0.0 {
                        -o.z / k.z
                    } else {
                        (-film - o.z) / k.z
                    };
                    let last = (ray % 3 == 0).then(|| rng.random_range(0..flakes.len() as u32));
                    let rims_transparent = ray % 4 == 0;
                    let want = brute(flakes, tile, &o, &k, tau_max, last, rims_transparent);
                    let got =
                        grid.nearest(flakes, &o, &k, tau_max, last, rims_transparent, 1 << 20);
                    match (got, want) {
                        (Next::Boundary, None) => {}
                        (Next::Flake(h), Some((tau, f, surface))) => {
                            assert_eq!((h.flake, h.surface), (f, surface), "ray {ray}");
                            assert!((h.tau - tau).abs() <= 1e-9 * (1.0 + tau), "ray {ray}");
                            hits += 1;
                        }
                        (got, want) => panic!("ray {ray}: grid {got:?}, search {want:?}"),
                    }
                    checked += 1;
                }
            }
        }
        assert!(
            checked > 15_000 && hits > 3_000,
            "{checked} rays, {hits} hits"
        );
    }
}
