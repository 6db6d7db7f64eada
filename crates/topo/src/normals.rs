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
//! The sums are separable: a row pass keeps a running box sum `Σ_i z` and a running first
//! moment `Σ_i i z` along each row (updated in O(1) per step), a column pass does the same
//! down each column, so a normal costs O(1) per pixel whatever `k`. Running sums restart on
//! every tile (a few hundred pixels at most), which bounds the rounding drift, and heights
//! are taken relative to a reference height of the tile to avoid cancellation.

use flakescatter_optics::{UnitVec3, Vec3};
use flakescatter_stats::HeightMap;

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
}

/// The slopes `(a, b)` of the `k × k` window (`k = 2h + 1`) centred on `(row, col)`,
/// summed directly (no running sums) from the differences of symmetric pairs:
/// `a = Σ_j Σ_{i=1}^{h} i (z(j, col + i) − z(j, col − i)) / (k dx S)`, and `b` alike. Rounding is then of the order of the height differences inside the window
/// times 1e-16, whatever the map's size or orientation (the running sums of
/// [`tile_slopes`] drift by up to about 1e-11 rad over a tile of a deep film). The
/// caller guarantees that the whole window is valid and inside the map.
pub(crate) fn direct_slopes(map: &HeightMap, h: usize, row: usize, col: usize) -> (f64, f64) {
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

/// Calls `emit(row, col, a, b)` for every usable pixel of `rect`, in row-major order,
/// and returns how many there were. `k = 2h + 1` is the window side.
pub(crate) fn tile_slopes(
    map: &HeightMap,
    h: usize,
    rect: Rect,
    scratch: &mut Scratch,
    mut emit: impl FnMut(usize, usize, f64, f64),
) -> usize {
    let (nx, ny) = (map.nx(), map.ny());
    if nx < 2 * h + 1 || ny < 2 * h + 1 {
        return 0;
    }
    // Output pixels whose whole window lies inside the map.
    let (or0, or1) = (rect.r0.max(h), rect.r1.min(ny - h));
    let (oc0, oc1) = (rect.c0.max(h), rect.c1.min(nx - h));
    if or0 >= or1 || oc0 >= oc1 {
        return 0;
    }
    let k = 2 * h + 1;
    let hf = h as f64;
    let s = (hf * (hf + 1.0) * (2.0 * hf + 1.0)) / 3.0;
    let inv_x = 1.0 / (k as f64 * map.dx() * s);
    let inv_y = 1.0 / (k as f64 * map.dy() * s);
    // Region read: the output rectangle plus the window halo.
    let (rr0, rr1) = (or0 - h, or1 + h);
    let (rc0, rc1) = (oc0 - h, oc1 + h);
    let rw = rc1 - rc0;
    let rh = rr1 - rr0;
    let ow = oc1 - oc0;
    let heights = map.heights();
    let valid = map.valid();

    // Heights relative to a reference of the region; invalid points contribute 0 and
    // are counted in `bad`.
    let mut zref = 0.0;
    'find: for r in rr0..rr1 {
        for c in rc0..rc1 {
            let i = r * nx + c;
            if valid[i] {
                zref = heights[i];
                break 'find;
            }
        }
    }
    scratch.z.clear();
    scratch.z.resize(rw, 0.0);
    scratch.box_sum.clear();
    scratch.box_sum.resize(rh * ow, 0.0);
    scratch.moment.clear();
    scratch.moment.resize(rh * ow, 0.0);
    scratch.bad.clear();
    scratch.bad.resize(rh * ow, 0);

    // Row pass: running Σ_i z, Σ_i i z and invalid count over columns c-h..=c+h.
    for (lr, r) in (rr0..rr1).enumerate() {
        let base = r * nx + rc0;
        let mut nbad_row = 0u32;
        for (j, zz) in scratch.z.iter_mut().enumerate() {
            let i = base + j;
            if valid[i] {
                *zz = heights[i] - zref;
            } else {
                *zz = 0.0;
                nbad_row += 1;
            }
        }
        let z = &scratch.z;
        let out = lr * ow;
        if nbad_row as usize == rw {
            scratch.bad[out..out + ow].fill(k as u32);
            continue;
        }
        // First window (centre at local column h) directly.
        let (mut sum, mut mom, mut bad) = (0.0, 0.0, 0u32);
        for t in 0..k {
            sum += z[t];
            mom += (t as f64 - hf) * z[t];
            bad += u32::from(!valid[base + t]);
        }
        scratch.box_sum[out] = sum;
        scratch.moment[out] = mom;
        scratch.bad[out] = bad;
        for oc in 1..ow {
            // Window centre moves from local column oc+h-1 to oc+h.
            let leaving = oc - 1;
            let entering = oc - 1 + k;
            // M(c+1) = M(c) + h z[c-h] + (h+1) z[c+h+1] - S(c+1).
            sum += z[entering] - z[leaving];
            mom += hf * z[leaving] + (hf + 1.0) * z[entering] - sum;
            bad = bad + u32::from(!valid[base + entering]) - u32::from(!valid[base + leaving]);
            scratch.box_sum[out + oc] = sum;
            scratch.moment[out + oc] = mom;
            scratch.bad[out + oc] = bad;
        }
    }

    // Column pass: Σ_j of the row moments (for a), Σ_j j·(row sums) (for b), Σ_j bad.
    // Done for all columns at once, row by row, so memory is walked contiguously.
    let mut col_m = vec![0.0; ow];
    let mut col_s = vec![0.0; ow];
    let mut col_js = vec![0.0; ow];
    let mut col_bad = vec![0u32; ow];
    let mut emitted = 0;
    for t in 0..k {
        let row = t * ow;
        let jt = t as f64 - hf;
        for oc in 0..ow {
            col_m[oc] += scratch.moment[row + oc];
            col_s[oc] += scratch.box_sum[row + oc];
            col_js[oc] += jt * scratch.box_sum[row + oc];
            col_bad[oc] += scratch.bad[row + oc];
        }
    }
    for (o, r) in (or0..or1).enumerate() {
        if o > 0 {
            let leaving = (o - 1) * ow;
            let entering = (o - 1 + k) * ow;
            for oc in 0..ow {
                let sl = scratch.box_sum[leaving + oc];
                let se = scratch.box_sum[entering + oc];
                col_m[oc] += scratch.moment[entering + oc] - scratch.moment[leaving + oc];
                col_s[oc] += se - sl;
                col_js[oc] += hf * sl + (hf + 1.0) * se - col_s[oc];
                col_bad[oc] = col_bad[oc] + scratch.bad[entering + oc] - scratch.bad[leaving + oc];
            }
        }
        for oc in 0..ow {
            if col_bad[oc] == 0 {
                emit(r, oc0 + oc, col_m[oc] * inv_x, col_js[oc] * inv_y);
                emitted += 1;
            }
        }
    }
    emitted
}
