//! Local surface normals of a height map by windowed least squares (physics.md §5 step 1,
//! the paper's "24 neighbouring points in a 5 × 5 square").
//!
//! Conventions: heights and pitches in micrometres; map axes `x = col · dx` (along the
//! columns) and `y = row · dy` (along the rows), row-major storage `row · nx + col`, as in
//! [`HeightMap`]. The plane `z = a x + b y + c` is fitted to all `k × k` points of the
//! window centred on the pixel (`k` odd, `h = (k − 1)/2`), and the unit normal is
//! `m = (−a, −b, 1)/sqrt(1 + a² + b²)` (`m.z > 0`, pointing into the air).
//!
//! **Skip rule.** A pixel gets no normal when any point of its window is invalid (NaN,
//! masked, or below the intensity cutoff) or lies outside the map: so the `h` outermost
//! rows and columns never have one.
//!
//! **Closed form.** On a full regular window the centred offsets `u = i·dx`,
//! `v = j·dy` (`i, j ∈ −h..=h`) are orthogonal to each other and to the constant, so the
//! normal equations are diagonal:
//! `a = Σ u z / Σ u² = Σ i z / (k · dx · S)` and `b = Σ j z / (k · dy · S)` with
//! `S = Σ_{i=−h}^{h} i² = h(h+1)(2h+1)/3`.
//! The sums are separable: a row pass forms each row's box sum `Σ_i z` and first moment
//! `Σ_i i z` (from the differences of symmetric pairs, `Σ_{i=1}^{h} i (z(+i) − z(−i))`)
//! for every column of a tile, a column pass combines `k` rows of them, so a normal
//! costs `O(k)` additions per pixel, in loops over columns that the compiler vectorises.
//! The sums are direct, not running, so nothing drifts along a tile, and heights are
//! taken relative to a reference height of the tile to avoid cancellation.

use flakescatter_optics::{UnitVec3, Vec3};
use flakescatter_stats::HeightMap;

use crate::simd::{Kernels, Lanes, dispatch};

/// Local normals of one map: one entry per pixel (row-major), `None` where the pixel
/// was skipped. Stored compactly as slopes; use [`Normals::get`] or [`Normals::to_vec`].
#[derive(Debug, Clone, PartialEq)]
pub struct Normals {
    nx: usize,
    ny: usize,
    window: usize,
    /// `(a, b)` = `(∂z/∂x, ∂z/∂y)` per pixel; NaN where skipped.
    slopes: Vec<[f64; 2]>,
    usable: usize,
}

impl Normals {
    /// Normals from slopes already computed (`slopes` row-major, NaN where skipped;
    /// `usable` the number of pixels that are not).
    pub(crate) fn from_slopes(
        nx: usize,
        ny: usize,
        window: usize,
        slopes: Vec<[f64; 2]>,
        usable: usize,
    ) -> Self {
        debug_assert_eq!(slopes.len(), nx * ny);
        Self {
            nx,
            ny,
            window,
            slopes,
            usable,
        }
    }

    /// Number of columns of the map.
    #[must_use]
    pub fn nx(&self) -> usize {
        self.nx
    }

    /// Number of rows of the map.
    #[must_use]
    pub fn ny(&self) -> usize {
        self.ny
    }

    /// The window side `k` used (odd).
    #[must_use]
    pub fn window(&self) -> usize {
        self.window
    }

    /// Number of pixels that have a normal (usable pixels).
    #[must_use]
    pub fn usable(&self) -> usize {
        self.usable
    }

    /// Fitted slopes `(a, b) = (∂z/∂x, ∂z/∂y)` (dimensionless, µm per µm) at column
    /// `col`, row `row`; `None` for a skipped or out-of-range pixel.
    #[must_use]
    pub fn slope(&self, col: usize, row: usize) -> Option<(f64, f64)> {
        if col >= self.nx || row >= self.ny {
            return None;
        }
        let [a, b] = self.slopes[row * self.nx + col];
        (!a.is_nan()).then_some((a, b))
    }

    /// Unit normal `(−a, −b, 1)/sqrt(1 + a² + b²)` at column `col`, row `row`; `None`
    /// for a skipped or out-of-range pixel.
    #[must_use]
    pub fn get(&self, col: usize, row: usize) -> Option<UnitVec3> {
        self.slope(col, row).map(|(a, b)| normal_from_slopes(a, b))
    }

    /// Every pixel's normal, row-major (`None` = skipped pixel).
    #[must_use]
    pub fn to_vec(&self) -> Vec<Option<UnitVec3>> {
        self.slopes
            .iter()
            .map(|&[a, b]| (!a.is_nan()).then(|| normal_from_slopes(a, b)))
            .collect()
    }
}

/// The unit normal `(−a, −b, 1)/sqrt(1 + a² + b²)` of the plane `z = a x + b y + c`.
#[must_use]
pub fn normal_from_slopes(a: f64, b: f64) -> UnitVec3 {
    let inv = 1.0 / (1.0 + a * a + b * b).sqrt();
    UnitVec3::new_unchecked(Vec3::new(-a * inv, -b * inv, inv))
}

/// A rectangle of output pixels: rows `r0..r1`, columns `c0..c1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Rect {
    pub r0: usize,
    pub r1: usize,
    pub c0: usize,
    pub c1: usize,
}

/// Reusable buffers for [`tile_slopes`].
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    box_sum: Vec<f64>,
    moment: Vec<f64>,
    bad: Vec<u32>,
    z: Vec<f64>,
    z_bad: Vec<u32>,
    col_m: Vec<f64>,
    col_js: Vec<f64>,
    col_bad: Vec<u32>,
}

/// The slopes `(a, b)` of the `k × k` windows (`k = 2h + 1`) centred on a run of
/// pixels of one row, summed directly from the differences of symmetric pairs:
/// `a = Σ_j Σ_{i=1}^{h} i (z(j, col + i) − z(j, col − i)) / (k dx S)`, and `b` alike.
/// Rounding is of the order of the height differences inside a window times 1e-16,
/// whatever the map's size or orientation, and does not depend on the tiling (the
/// absolute heights, not heights relative to a tile's reference, and the sums in
/// another order than [`tile_slopes`]'s). Each pixel's sums are formed in the order of
/// a pixel-by-pixel loop over its window (window rows, then pair offsets; the test
/// module's `direct_slopes` is that loop, and the run equals it bit for bit), but for
/// every column of the run at once, in loops over columns that the compiler
/// vectorises (under [`dispatch!`], additions and multiplications only, no
/// fused multiply–add). A pixel whose window holds an invalid point gets whatever its
/// heights give; callers read only usable pixels.
#[derive(Debug, Default)]
pub(crate) struct DirectRow {
    /// The row held (meaningful while `a` is not empty; [`DirectRow::tile`] empties it).
    row: usize,
    /// First column held; `a`, `b` hold the run's columns from here.
    c0: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    d: Vec<f64>,
}

impl DirectRow {
    /// Starts a tile `rect` of `map` ([`tile_slopes`]'s rectangle): rows are filled over
    /// the tile's columns whose window lies inside the map ([`inside_cols`]), and the
    /// row held before, of whatever map, is forgotten, so that the buffers can be
    /// reused from tile to tile and map to map.
    /// The sums run with `kernels`.
    pub(crate) fn tile<'a>(
        &'a mut self,
        map: &'a HeightMap,
        h: usize,
        rect: Rect,
        kernels: Kernels,
    ) -> TileRows<'a> {
        self.a.clear();
        TileRows {
            run: self,
            map,
            h,
            cols: inside_cols(map, h, rect),
            kernels,
        }
    }

    fn fill(
        &mut self,
        map: &HeightMap,
        h: usize,
        row: usize,
        cols: std::ops::Range<usize>,
        kernels: Kernels,
    ) {
        self.row = row;
        self.c0 = cols.start;
        let w = cols.len();
        self.a.clear();
        self.a.resize(w, 0.0);
        self.b.clear();
        self.b.resize(w, 0.0);
        self.d.resize(w, 0.0);
        dispatch!(kernels, |_lanes| row_sums(map, h, row, cols.start, self));
    }
}

/// The [`DirectRow`] of one tile ([`DirectRow::tile`]).
pub(crate) struct TileRows<'a> {
    run: &'a mut DirectRow,
    map: &'a HeightMap,
    h: usize,
    cols: std::ops::Range<usize>,
    kernels: Kernels,
}

impl TileRows<'_> {
    /// The slopes of pixel `(row, col)`, `col` in the tile's columns; the row is filled
    /// when it is not the one held.
    #[inline]
    pub(crate) fn slopes(&mut self, row: usize, col: usize) -> (f64, f64) {
        if self.run.a.is_empty() || self.run.row != row {
            self.run
                .fill(self.map, self.h, row, self.cols.clone(), self.kernels);
        }
        let i = col - self.run.c0;
        (self.run.a[i], self.run.b[i])
    }
}

/// The sums of one [`DirectRow`] fill (row `row`, columns from `c0`), run under
/// [`dispatch!`].
#[inline(always)]
fn row_sums(map: &HeightMap, h: usize, row: usize, c0: usize, run: &mut DirectRow) {
    let nx = map.nx();
    let z = map.heights();
    let k = 2 * h + 1;
    let w = run.a.len();
    let DirectRow { a, b, d, .. } = run;
    // a: window rows outer, pair offsets inner.
    for r in row - h..=row + h {
        let base = r * nx + c0;
        for i in 1..=h {
            let fi = i as f64;
            let (up, down) = (&z[base + i..base + i + w], &z[base - i..base - i + w]);
            for ((acc, &u), &v) in a.iter_mut().zip(up).zip(down) {
                *acc += fi * (u - v);
            }
        }
    }
    // b: per pair of rows, the column differences summed from the window's first
    // column on (from −0.0, as `Iterator::sum` of f64 does), then weighted.
    for i in 1..=h {
        let fi = i as f64;
        d.fill(-0.0);
        let (ub, db) = ((row + i) * nx + c0 - h, (row - i) * nx + c0 - h);
        for j in 0..k {
            let (up, down) = (&z[ub + j..ub + j + w], &z[db + j..db + j + w]);
            for ((acc, &u), &v) in d.iter_mut().zip(up).zip(down) {
                *acc += u - v;
            }
        }
        for (acc, &dd) in b.iter_mut().zip(d.iter()) {
            *acc += fi * dd;
        }
    }
    let hf = h as f64;
    let s = (hf * (hf + 1.0) * (2.0 * hf + 1.0)) / 3.0;
    let (den_x, den_y) = (k as f64 * map.dx() * s, k as f64 * map.dy() * s);
    for v in a.iter_mut() {
        *v /= den_x;
    }
    for v in b.iter_mut() {
        *v /= den_y;
    }
}

/// The columns of `rect` whose `k × k` window (`k = 2h + 1`) lies inside the map
/// horizontally: where [`tile_slopes`] may emit pixels (empty when the map is too
/// narrow for a window).
fn inside_cols(map: &HeightMap, h: usize, rect: Rect) -> std::ops::Range<usize> {
    rect.c0.max(h)..rect.c1.min(map.nx().saturating_sub(h))
}

/// Calls `emit(row, col, a, b)` for every usable pixel of `rect`, in row-major order,
/// and with `NAN_BAD` also `emit(row, col, NaN, NaN)` for every other pixel of `rect`
/// whose window lies inside the map (one that holds an invalid point); returns how many
/// usable pixels there were. Pixels of `rect` closer than `h` to the map's edge are
/// never emitted. `k = 2h + 1` is the window side.
///
/// Two passes over the tile's region (output rectangle plus the window halo), each a
/// direct sum over the window rather than a running one, so that the loops over
/// columns have no dependence from one pixel to the next and vectorise: the row pass
/// gives, per region row and output column, the box sum `Σ_i z`, the first moment
/// `Σ_{i=1}^{h} i (z(+i) − z(−i))` and the invalid count; the column pass sums the
/// moments (for `a`), the rows' box sums paired `Σ_{j=1}^{h} j (S(+j) − S(−j))` (for
/// `b`) and the counts over the window's rows. Heights are relative to a reference of
/// the region, so rounding is of the order of the heights' spread over the tile times
/// 1e-16, with nothing accumulated from one pixel to the next. Both passes run under
/// the kernel layer's dispatch ([`dispatch!`]), so the compiler vectorises them for
/// the processor's instruction set (additions and multiplications only, no fused
/// multiply–add: the same bits in every build); `emit` is called outside it.
pub(crate) fn tile_slopes<const NAN_BAD: bool>(
    map: &HeightMap,
    h: usize,
    rect: Rect,
    scratch: &mut Scratch,
    kernels: Kernels,
    mut emit: impl FnMut(usize, usize, f64, f64),
) -> usize {
    let (nx, ny) = (map.nx(), map.ny());
    if nx < 2 * h + 1 || ny < 2 * h + 1 {
        return 0;
    }
    // Output pixels whose whole window lies inside the map.
    let (or0, or1) = (rect.r0.max(h), rect.r1.min(ny - h));
    let cols = inside_cols(map, h, rect);
    let (oc0, oc1) = (cols.start, cols.end);
    if or0 >= or1 || oc0 >= oc1 {
        return 0;
    }
    let out = Rect {
        r0: or0,
        r1: or1,
        c0: oc0,
        c1: oc1,
    };
    // On AVX2 and AVX-512 machines the sums also prefetch the rows
    // ([`Lanes::prefetch`]).
    dispatch!(kernels, |lanes| tile_sums(
        map,
        h,
        out,
        &mut *scratch,
        lanes
    ));
    let k = 2 * h + 1;
    let hf = h as f64;
    let s = (hf * (hf + 1.0) * (2.0 * hf + 1.0)) / 3.0;
    let inv_x = 1.0 / (k as f64 * map.dx() * s);
    let inv_y = 1.0 / (k as f64 * map.dy() * s);
    let ow = oc1 - oc0;
    let mut emitted = 0;
    for (o, r) in (or0..or1).enumerate() {
        let row = o * ow..(o + 1) * ow;
        let (m, js, nbad) = (
            &scratch.col_m[row.clone()],
            &scratch.col_js[row.clone()],
            &scratch.col_bad[row],
        );
        for (oc, ((&m, &js), &nbad)) in m.iter().zip(js).zip(nbad).enumerate() {
            if nbad == 0 {
                emit(r, oc0 + oc, m * inv_x, js * inv_y);
                emitted += 1;
            } else if NAN_BAD {
                emit(r, oc0 + oc, f64::NAN, f64::NAN);
            }
        }
    }
    emitted
}

/// Calls `emit(row, col)` for every usable pixel of `rect` (its whole `k × k` window,
/// `k = 2h + 1`, inside the map and valid), in row-major order, and returns how many
/// there were: the pixels [`tile_slopes::<false>`](tile_slopes) emits, found from the
/// invalid points' counts alone (for callers that compute the slopes themselves).
pub(crate) fn tile_usable(
    map: &HeightMap,
    h: usize,
    rect: Rect,
    scratch: &mut Scratch,
    mut emit: impl FnMut(usize, usize),
) -> usize {
    let (nx, ny) = (map.nx(), map.ny());
    let k = 2 * h + 1;
    if nx < k || ny < k {
        return 0;
    }
    let (or0, or1) = (rect.r0.max(h), rect.r1.min(ny - h));
    let cols = inside_cols(map, h, rect);
    if or0 >= or1 || cols.is_empty() {
        return 0;
    }
    let (oc0, ow) = (cols.start, cols.len());
    let valid = map.valid();
    // Row pass: per region row, the invalid points of each output column's k columns.
    let rh = or1 - or0 + 2 * h;
    let Scratch { bad, col_bad, .. } = scratch;
    bad.resize(rh * ow, 0);
    col_bad.resize(ow, 0);
    for (lr, r) in (or0 - h..or1 + h).enumerate() {
        let row = &valid[r * nx + oc0 - h..r * nx + oc0 + ow + h];
        let out = &mut bad[lr * ow..(lr + 1) * ow];
        out.fill(0);
        for t in 0..k {
            for (acc, &v) in out.iter_mut().zip(&row[t..t + ow]) {
                *acc += u32::from(!v);
            }
        }
    }
    // Column pass, one output row at a time.
    let mut emitted = 0;
    for (o, r) in (or0..or1).enumerate() {
        col_bad.fill(0);
        for t in 0..k {
            for (acc, &v) in col_bad.iter_mut().zip(&bad[(o + t) * ow..(o + t + 1) * ow]) {
                *acc += v;
            }
        }
        for (oc, &nbad) in col_bad.iter().enumerate() {
            if nbad == 0 {
                emit(r, oc0 + oc);
                emitted += 1;
            }
        }
    }
    emitted
}

/// Fills `scratch.col_m`, `col_js` and `col_bad` (row-major over `out`) with each
/// output pixel's `Σ i z`, `Σ j z` and invalid count over its window ([`tile_slopes`]).
#[inline(always)]
fn tile_sums<L: Lanes>(map: &HeightMap, h: usize, out: Rect, scratch: &mut Scratch, lanes: L) {
    let nx = map.nx();
    let k = 2 * h + 1;
    // Region read: the output rectangle plus the window halo.
    let (rr0, rr1) = (out.r0 - h, out.r1 + h);
    let (rc0, rc1) = (out.c0 - h, out.c1 + h);
    let rw = rc1 - rc0;
    let rh = rr1 - rr0;
    let ow = out.c1 - out.c0;
    let oh = out.r1 - out.r0;
    let heights = map.heights();
    let valid = map.valid();

    // Heights relative to a reference of the region; invalid points contribute 0 and
    // are counted in `bad`.
    let zref = (rr0..rr1)
        .flat_map(|r| r * nx + rc0..r * nx + rc1)
        .find(|&i| valid[i])
        .map_or(0.0, |i| heights[i]);
    let Scratch {
        box_sum,
        moment,
        bad,
        z,
        z_bad,
        col_m,
        col_js,
        col_bad,
    } = scratch;
    // Every element below is written before it is read, so the buffers are only
    // resized (tiles of one size need no memset).
    z.resize(rw, 0.0);
    z_bad.resize(rw, 0);
    box_sum.resize(rh * ow, 0.0);
    moment.resize(rh * ow, 0.0);
    bad.resize(rh * ow, 0);
    col_m.resize(oh * ow, 0.0);
    col_js.resize(oh * ow, 0.0);
    col_bad.resize(oh * ow, 0);

    // Row pass, the rows `AHEAD` below asked for as each row starts (the first
    // `AHEAD` before): each row of a tile is a few cache lines a map row apart, which
    // the processor's own prefetch does not foresee.
    const AHEAD: usize = 8;
    let row_of = |r: usize| r * nx + rc0..r * nx + rc0 + rw;
    for r in rr0..rr1.min(rr0 + AHEAD) {
        lanes.prefetch(&heights[row_of(r)], &valid[row_of(r)]);
    }
    for (lr, r) in (rr0..rr1).enumerate() {
        if r + AHEAD < rr1 {
            let ahead = row_of(r + AHEAD);
            lanes.prefetch(&heights[ahead.clone()], &valid[ahead]);
        }
        let base = r * nx + rc0;
        let (hrow, vrow) = (&heights[base..base + rw], &valid[base..base + rw]);
        for (((zz, zb), &v), &hv) in z.iter_mut().zip(z_bad.iter_mut()).zip(vrow).zip(hrow) {
            *zz = if v { hv - zref } else { 0.0 };
            *zb = u32::from(!v);
        }
        let span = lr * ow..(lr + 1) * ow;
        let (sum, mom, nbad) = (
            &mut box_sum[span.clone()],
            &mut moment[span.clone()],
            &mut bad[span],
        );
        sum.copy_from_slice(&z[..ow]);
        nbad.copy_from_slice(&z_bad[..ow]);
        for t in 1..k {
            for (acc, &v) in sum.iter_mut().zip(&z[t..t + ow]) {
                *acc += v;
            }
            for (acc, &v) in nbad.iter_mut().zip(&z_bad[t..t + ow]) {
                *acc += v;
            }
        }
        mom.fill(0.0);
        for i in 1..=h {
            let w = i as f64;
            let (up, down) = (&z[h + i..h + i + ow], &z[h - i..h - i + ow]);
            for ((acc, &u), &d) in mom.iter_mut().zip(up).zip(down) {
                *acc += w * (u - d);
            }
        }
    }

    // Column pass, one output row at a time over all its columns.
    for o in 0..oh {
        let row = |t: usize| (o + t) * ow..(o + t + 1) * ow;
        let span = o * ow..(o + 1) * ow;
        let (cm, cjs, cbad) = (
            &mut col_m[span.clone()],
            &mut col_js[span.clone()],
            &mut col_bad[span],
        );
        cm.copy_from_slice(&moment[row(0)]);
        cbad.copy_from_slice(&bad[row(0)]);
        for t in 1..k {
            for (acc, &v) in cm.iter_mut().zip(&moment[row(t)]) {
                *acc += v;
            }
            for (acc, &v) in cbad.iter_mut().zip(&bad[row(t)]) {
                *acc += v;
            }
        }
        cjs.fill(0.0);
        for j in 1..=h {
            let w = j as f64;
            let (up, down) = (&box_sum[row(h + j)], &box_sum[row(h - j)]);
            for ((acc, &u), &d) in cjs.iter_mut().zip(up).zip(down) {
                *acc += w * (u - d);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference for [`DirectRow`]: the slopes `(a, b)` of the `k × k` window
    /// (`k = 2h + 1`) centred on `(row, col)`, summed pixel by pixel (the whole window
    /// inside the map).
    fn direct_slopes(map: &HeightMap, h: usize, row: usize, col: usize) -> (f64, f64) {
        let nx = map.nx();
        let z = map.heights();
        let k = 2 * h + 1;
        let window_row = |r: usize| &z[r * nx + col - h..r * nx + col - h + k];
        let (mut sa, mut sb) = (0.0, 0.0);
        // a: within each window row, i (z(col + i) − z(col − i)).
        for r in row - h..=row + h {
            let w = window_row(r);
            for i in 1..=h {
                sa += i as f64 * (w[h + i] - w[h - i]);
            }
        }
        // b: rows row ± i, differenced column by column.
        for i in 1..=h {
            let (up, down) = (window_row(row + i), window_row(row - i));
            let d: f64 = up.iter().zip(down).map(|(u, v)| u - v).sum();
            sb += i as f64 * d;
        }
        let hf = h as f64;
        let s = (hf * (hf + 1.0) * (2.0 * hf + 1.0)) / 3.0;
        (
            sa / (k as f64 * map.dx() * s),
            sb / (k as f64 * map.dy() * s),
        )
    }

    /// Heights of a plane `z = p x + q y + c` plus, with `rough`, a seeded uniform part
    /// in ±0.5 µm, on an `nx × ny` map of pitch 0.3 × 0.4 µm.
    fn map(nx: usize, ny: usize, p: f64, q: f64, rough: bool) -> HeightMap {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let z = (0..nx * ny)
            .map(|i| {
                let (row, col) = (i / nx, i % nx);
                let noise = if rough {
                    rng.random_range(-0.5..0.5)
                } else {
                    0.0
                };
                p * col as f64 * 0.3 + q * row as f64 * 0.4 + 7.0 + noise
            })
            .collect();
        HeightMap::new(nx, ny, 0.3, 0.4, z).unwrap()
    }

    /// `tile_usable` emits exactly the pixels `tile_slopes::<false>` emits (whole
    /// window inside the map and valid), in the same order, for windows of 3, 5 and 9,
    /// tiles inside, across and at every edge of a map with scattered invalid points
    /// and an invalid block, and maps narrower than a window.
    #[test]
    fn usable_pixels_are_those_with_slopes() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (nx, ny) = (61, 47);
        let base = map(nx, ny, 0.2, -0.1, true);
        let valid: Vec<bool> = (0..nx * ny)
            .map(|i| {
                let (row, col) = (i / nx, i % nx);
                !(rng.random_range(0.0..1.0) < 0.02 || (20..26).contains(&row) && col < 9)
            })
            .collect();
        let holed = HeightMap::with_mask(nx, ny, 0.3, 0.4, base.heights().to_vec(), valid).unwrap();
        let narrow = map(4, 30, 0.1, 0.1, false);
        let mut scratch = Scratch::default();
        let mut checked = 0;
        for m in [&base, &holed, &narrow] {
            for h in [1, 2, 4] {
                for rect in [
                    Rect {
                        r0: 0,
                        r1: m.ny(),
                        c0: 0,
                        c1: m.nx(),
                    },
                    Rect {
                        r0: 0,
                        r1: 13,
                        c0: 0,
                        c1: 17,
                    },
                    Rect {
                        r0: 10,
                        r1: 30,
                        c0: 5,
                        c1: 40,
                    },
                    Rect {
                        r0: m.ny().saturating_sub(9),
                        r1: m.ny(),
                        c0: m.nx().saturating_sub(11),
                        c1: m.nx(),
                    },
                ] {
                    let mut want = Vec::new();
                    let n = tile_slopes::<false>(
                        m,
                        h,
                        rect,
                        &mut scratch,
                        Kernels::Auto,
                        |r, c, _, _| {
                            want.push((r, c));
                        },
                    );
                    let mut got = Vec::new();
                    let k = tile_usable(m, h, rect, &mut scratch, |r, c| got.push((r, c)));
                    assert_eq!(got, want, "h {h}, {rect:?}");
                    assert_eq!((k, n), (got.len(), want.len()));
                    checked += got.len();
                }
            }
        }
        assert!(checked > 5000, "{checked} pixels compared");
    }

    #[test]
    fn direct_slopes_of_a_plane_are_its_gradient() {
        // Closed form: every symmetric pair of a plane differs by p·2i·dx (q·2j·dy),
        // so the window sums are p·k·dx·S and q·k·dy·S.
        let m = map(13, 11, 0.37, -1.25, false);
        let mut run = DirectRow::default();
        for h in 1..=3 {
            let rect = Rect {
                r0: 0,
                r1: 11,
                c0: 0,
                c1: 13,
            };
            let row = run.tile(&m, h, rect, Kernels::Auto).slopes(5, 6);
            for (a, b) in [direct_slopes(&m, h, 5, 6), row] {
                assert!((a - 0.37).abs() < 1e-12, "h = {h}: a = {a}");
                assert!((b + 1.25).abs() < 1e-12, "h = {h}: b = {b}");
            }
        }
    }

    #[test]
    fn a_tile_of_another_map_gets_its_own_rows() {
        // The buffers are reused from tile to tile and map to map: a tile of another
        // map (or window) asking for the same row and columns as the last one must not
        // get the last one's slopes (closed form: the planes' gradients).
        let (flat, steep) = (map(20, 9, 0.1, 0.0, false), map(20, 9, 0.8, -0.3, false));
        let mut run = DirectRow::default();
        for (m, h, p, q) in [
            (&flat, 2, 0.1, 0.0),
            (&steep, 2, 0.8, -0.3),
            (&steep, 1, 0.8, -0.3),
            (&flat, 1, 0.1, 0.0),
        ] {
            let rect = Rect {
                r0: 0,
                r1: 9,
                c0: 2,
                c1: 18,
            };
            let (a, b) = run.tile(m, h, rect, Kernels::Auto).slopes(4, 7);
            assert!(
                (a - p).abs() < 1e-12 && (b - q).abs() < 1e-12,
                "h {h}: ({a}, {b})"
            );
        }
    }

    #[test]
    fn direct_row_equals_direct_slopes_pixel_by_pixel() {
        // The same sums in the same order, so equal, not just close; runs of every
        // length from one column to the whole row, rows visited out of order, and a
        // point that is not finite inside some windows (their values are not read,
        // the others must not change).
        let mut m = map(37, 19, 0.2, 0.9, true);
        let (nx, ny) = (m.nx(), m.ny());
        let mut z = m.heights().to_vec();
        z[9 * nx + 17] = f64::NAN;
        m = HeightMap::new(nx, ny, 0.3, 0.4, z).unwrap();
        let bad = |h: usize, row: usize, col: usize| row.abs_diff(9) <= h && col.abs_diff(17) <= h;
        let mut run = DirectRow::default();
        // Portable and with the processor's best instruction set: the same sums.
        let both = [Kernels::Auto, Kernels::Portable];
        for (h, kernels) in (1..=3).flat_map(|h| both.map(|k| (h, k))) {
            for &(c0, c1) in &[(h, nx - h), (h, h + 1), (h + 3, nx - h - 5), (20, 21)] {
                let rect = Rect {
                    r0: 0,
                    r1: ny,
                    c0,
                    c1,
                };
                let mut tile = run.tile(&m, h, rect, kernels);
                for row in (h..ny - h).rev().chain(h..ny - h) {
                    for col in c0..c1 {
                        let got = tile.slopes(row, col);
                        if bad(h, row, col) {
                            continue;
                        }
                        assert_eq!(got, direct_slopes(&m, h, row, col), "h {h} ({row}, {col})");
                    }
                }
            }
        }
    }
}
