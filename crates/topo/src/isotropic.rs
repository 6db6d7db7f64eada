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
//! # How `h_j(θ)` is computed (per incidence, per node `θ`)
//! With `k1 = (sin θt, 0, −cos θt)`, `γ = cos θt cos θ − sin θt sin θ cos φ` and
//! `k2 = k1 + 2γ m`, the inside exit cosine is `k2.z = A − B cos φ` with
//! `A = cos θt cos 2θ`, `B = sin θt sin 2θ ≥ 0`. Rays escape exactly where `k2.z > κ`,
//! `κ = sqrt(1 − 1/n²)` (otherwise they are totally internally reflected, `0 < k2.z ≤ κ`,
//! or head down, `k2.z ≤ 0`): one arc `cos φ < (A − κ)/B` symmetric about `φ = π`, whose
//! ends exit at the horizon. The lost fractions of the ring are therefore closed forms,
//! `P(k2.z ≤ x) = acos((A − x)/B)/π`.
//!
//! On the escaping arc, `k_out(φ)` is sampled at `M` equal steps (of `φ` on a whole
//! circle; of `v`, `φ = (lo + hi)/2 − (hi − lo)/2 · cos v`, on an arc whose ends exit at
//! the horizon like `sqrt(φ − lo)`), with `M` chosen so that consecutive exit
//! directions are less than `0.95 α_min` apart (`α_min` the smallest aperture). Every
//! detector whose axis lies within `α + 0.6 α_min` of a sample is a candidate: a point
//! of the ring inside a cone is within half a step of a sample, so no cone the ring
//! enters is missed. For each candidate cone the boundary condition
//! `k_out(φ)·r_j = cos α_j` is solved on every step where it changes sign (Newton's
//! method from the secant point, safeguarded by bisection, to 1e-13 rad), and a step
//! whose ends lie on the same side but whose derivative `d(k_out·r_j)/dφ` changes sign
//! (and whose ends are close enough to the rim for the step's length to reach it) is
//! searched for a hidden tangent pair (the extremum by the Illinois method on the
//! derivative, then two roots). The weight `F γ` (the exact Fresnel factors of
//! [`Transmission::path_factor`](flakescatter_optics::polarization::Transmission::path_factor)
//! at `cos ι = γ`, the inside exit cosine `k2.z` and `k_out.z`) is integrated over each
//! resulting azimuth interval by 8-point Gauss–Legendre (`gauss-quad`) on panels of at
//! most π/8, in `v` on a partial arc: a unit test finds it within 1e-12 of 32 points on
//! panels of π/64, also for intervals that end at the horizon.
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

use std::f64::consts::{PI, TAU};

use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::fresnel::{self, FresnelPower};
use flakescatter_optics::jones::RayPath;
use flakescatter_optics::polarization::Weighting;
use flakescatter_optics::{Vec3, refraction};
use flakescatter_stats::HeightMap;
use gauss_quad::legendre::GaussLegendre;
use rayon::prelude::*;

use crate::TopoError;
use crate::index::{self, ConeIndex, LANES, Lanes, Portable};
use crate::model::{TileStats, TopoModel, TopoOptions, TopoPoint, TopoWarning, path_factor_of};
use crate::normals::{DirectRow, Rect, Scratch, tile_usable};

/// Default number of `θn` nodes per radian of the smallest aperture: the node spacing
/// is `δ = α_min / DEFAULT_NODES_PER_APERTURE` (0.0117° for α = 1.5°).
pub const DEFAULT_NODES_PER_APERTURE: f64 = 128.0;

/// Tiles traced between two progress reports.
const BATCH: usize = 256;

/// Gauss–Legendre points per panel of the azimuth integrals.
const GL_POINTS: usize = 8;

/// Largest panel of the azimuth integrals, radians.
const PANEL: f64 = PI / 8.0;

/// Fewest samples of a ring.
const MIN_SAMPLES: usize = 32;

/// Most samples of a ring.
const MAX_SAMPLES: usize = 1 << 16;

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

/// One point of a ring: exit direction, its azimuth derivative, obliquity, `k2.z`.
#[derive(Debug, Clone, Copy, Default)]
struct RingPoint {
    o: [f64; 3],
    d: [f64; 3],
    gamma: f64,
    k2z: f64,
}

/// The ring of one node `θ` at one incidence.
#[derive(Debug, Clone, Copy)]
struct Ring {
    n: f64,
    st: f64,
    ct: f64,
    s: f64,
    c: f64,
}

/// Which azimuths escape.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Arc {
    None,
    Full,
    Range(f64, f64),
}

impl Ring {
    fn new(n: f64, st: f64, ct: f64, theta: f64) -> Self {
        let (s, c) = theta.sin_cos();
        Self { n, st, ct, s, c }
    }

    /// `A`, `B` of `k2.z = A − B cos φ`.
    fn ab(&self) -> (f64, f64) {
        let cos2 = self.c * self.c - self.s * self.s;
        let sin2 = 2.0 * self.s * self.c;
        (self.ct * cos2, (self.st * sin2).max(0.0))
    }

    /// Fraction of `φ ∈ [0, 2π)` with `k2.z ≤ x`.
    fn fraction_below(&self, x: f64) -> f64 {
        let (a, b) = self.ab();
        if b <= 0.0 {
            return if a <= x { 1.0 } else { 0.0 };
        }
        ((a - x) / b).clamp(-1.0, 1.0).acos() / PI
    }

    /// The escaping arc `k2.z > κ`.
    fn arc(&self, kappa: f64) -> Arc {
        let (a, b) = self.ab();
        if b <= 0.0 {
            return if a > kappa { Arc::Full } else { Arc::None };
        }
        let q = (a - kappa) / b;
        if q >= 1.0 {
            Arc::Full
        } else if q <= -1.0 {
            Arc::None
        } else {
            let lo = q.acos();
            if lo >= PI {
                Arc::None
            } else {
                Arc::Range(lo, TAU - lo)
            }
        }
    }

    /// The ray at azimuth `phi` (extended continuously to the horizon beyond the arc).
    #[inline]
    fn at(&self, phi: f64) -> RingPoint {
        let (sp, cp) = phi.sin_cos();
        let (n, s, c, st, ct) = (self.n, self.s, self.c, self.st, self.ct);
        let (mx, my) = (s * cp, s * sp);
        let gamma = ct * c - st * mx;
        let dgamma = st * s * sp;
        let (k2x, k2y, k2z) = (
            st + 2.0 * gamma * mx,
            2.0 * gamma * my,
            -ct + 2.0 * gamma * c,
        );
        let dk2x = 2.0 * (dgamma * mx - gamma * my);
        let dk2y = 2.0 * (dgamma * my + gamma * mx);
        let (ox, oy) = (n * k2x, n * k2y);
        let (dox, doy) = (n * dk2x, n * dk2y);
        let oz = (1.0 - ox * ox - oy * oy).max(0.0).sqrt();
        let doz = if oz > 0.0 {
            -(ox * dox + oy * doy) / oz
        } else {
            0.0
        };
        RingPoint {
            o: [ox, oy, oz],
            d: [dox, doy, doz],
            gamma,
            k2z,
        }
    }
}

/// One detector as the ring search needs it.
#[derive(Debug, Clone, Copy)]
struct Axis {
    a: [f64; 3],
    cos_alpha: f64,
    alpha: f64,
}

impl Axis {
    fn new(c: &Cone) -> Self {
        Self {
            a: [c.axis().x, c.axis().y, c.axis().z],
            cos_alpha: c.cos_half_angle(),
            alpha: c.half_angle(),
        }
    }

    /// Angle between the axis and the exit direction of `p`.
    #[inline]
    fn angle(&self, p: &RingPoint) -> f64 {
        (self.f(p) + self.cos_alpha).clamp(-1.0, 1.0).acos()
    }

    /// Arc length of the step from `p` to `q`, bounded above by 1.05 × the chord's
    /// angle (steps are short against the ring's curvature).
    #[inline]
    fn step_length(p: &RingPoint, q: &RingPoint) -> f64 {
        let d = [q.o[0] - p.o[0], q.o[1] - p.o[1], q.o[2] - p.o[2]];
        let chord = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        1.05 * 2.0 * (0.5 * chord).min(1.0).asin()
    }

    /// Whether the step from `p` to `q` (both outside) can come within `α` of the axis.
    fn may_enter(&self, p: &RingPoint, q: &RingPoint) -> bool {
        0.5 * (self.angle(p) + self.angle(q) - Self::step_length(p, q)) < self.alpha
    }

    /// Whether the step from `p` to `q` (both inside) can go beyond `α` from the axis.
    fn may_leave(&self, p: &RingPoint, q: &RingPoint) -> bool {
        0.5 * (self.angle(p) + self.angle(q) + Self::step_length(p, q)) > self.alpha
    }

    #[inline]
    fn f(&self, p: &RingPoint) -> f64 {
        self.a[0] * p.o[0] + self.a[1] * p.o[1] + self.a[2] * p.o[2] - self.cos_alpha
    }

    #[inline]
    fn df(&self, p: &RingPoint) -> f64 {
        self.a[0] * p.d[0] + self.a[1] * p.d[1] + self.a[2] * p.d[2]
    }
}

/// Per-incidence constants of the isotropic run.
struct IsoInc {
    st: f64,
    ct: f64,
    entry: FresnelPower,
    /// Entry amplitudes `(ts, tp)` and the incident direction, for the Jones path.
    entry_t: (f64, f64),
    k_in: Vec3,
    /// Internal detectors of this incidence: the user's cones, then one specular cone
    /// per distinct aperture.
    cones: Vec<Cone>,
    axes: Vec<Axis>,
    index: ConeIndex,
    /// Per internal detector: `1/cos θt` (physical) or `cos ϑ'/cos ϑ` (paper-printed).
    scale: Vec<f64>,
}

/// Everything fixed during an isotropic run.
struct IsoSetup<'a> {
    options: &'a TopoOptions,
    incs: Vec<IsoInc>,
    kappa: f64,
    /// Largest allowed distance between consecutive ring samples, radians.
    max_step: f64,
    gl: Vec<(f64, f64)>,
    inv_delta: f64,
}

/// Scratch buffers of the ring computation.
#[derive(Debug, Default)]
struct RingScratch {
    phi: Vec<f64>,
    pts: Vec<RingPoint>,
    pairs: Vec<(u32, u32)>,
    segs: Vec<u32>,
    intervals: Vec<(f64, f64)>,
}

/// The response of one node at one incidence: `(detector, h_j)` sorted by detector with
/// `h_j > 0`, and the lost fractions of the ring.
#[derive(Debug, Clone, Default)]
struct NodeResponse {
    entries: Vec<(u32, f64)>,
    /// `entries` in runs of consecutive detectors, for the contraction.
    runs: Vec<Run>,
    tir: f64,
    down: f64,
}

/// Up to [`LANES`] consecutive detectors `start, start + 1, …` and their values
/// (zero past `len`): what the contraction adds to eight consecutive sums at once.
#[derive(Debug, Clone, Copy)]
struct Run {
    start: u32,
    len: u32,
    v: [f64; LANES],
}

/// `entries` (sorted by detector) cut into runs of consecutive detectors, at most
/// [`LANES`] long.
fn runs_of(entries: &[(u32, f64)]) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for &(det, v) in entries {
        match runs.last_mut() {
            Some(r) if r.start + r.len == det && (r.len as usize) < LANES => {
                r.v[r.len as usize] = v;
                r.len += 1;
            }
            _ => {
                let mut vs = [0.0; LANES];
                vs[0] = v;
                runs.push(Run {
                    start: det,
                    len: 1,
                    v: vs,
                });
            }
        }
    }
    runs
}

impl IsoSetup<'_> {
    /// `h_j(θ)` for every detector of incidence `ii` (module docs).
    fn response(&self, ii: usize, theta: f64, sc: &mut RingScratch) -> NodeResponse {
        let inc = &self.incs[ii];
        let n = self.options.n;
        let ring = Ring::new(n, inc.st, inc.ct, theta);
        let down = ring.fraction_below(0.0);
        let tir = (ring.fraction_below(self.kappa) - down).max(0.0);
        let mut out = NodeResponse {
            entries: Vec::new(),
            runs: Vec::new(),
            tir,
            down,
        };
        let (lo, hi, full) = match ring.arc(self.kappa) {
            Arc::None => return out,
            Arc::Full => (0.0, TAU, true),
            Arc::Range(lo, hi) => (lo, hi, false),
        };
        self.sample(&ring, (lo, hi, full), sc);
        let m = sc.pts.len() - 1;

        // Candidate (detector, sample) pairs.
        sc.pairs.clear();
        for (i, p) in sc.pts.iter().enumerate() {
            for e in inc.index.candidates(p.o[0], p.o[1]) {
                if e.ax * p.o[0] + e.ay * p.o[1] + e.az * p.o[2] > e.cos_reach {
                    sc.pairs.push((e.index, i as u32));
                }
            }
        }
        sc.pairs.sort_unstable();
        sc.pairs.dedup();

        let mut start = 0;
        while start < sc.pairs.len() {
            let det = sc.pairs[start].0;
            let mut end = start;
            while end < sc.pairs.len() && sc.pairs[end].0 == det {
                end += 1;
            }
            // Steps next to a candidate sample: [i−1, i] and [i, i+1].
            sc.segs.clear();
            for &(_, i) in &sc.pairs[start..end] {
                if i > 0 {
                    sc.segs.push(i - 1);
                }
                if (i as usize) < m {
                    sc.segs.push(i);
                }
            }
            start = end;
            sc.segs.sort_unstable();
            sc.segs.dedup();
            let axis = inc.axes[det as usize];
            sc.intervals.clear();
            for k in 0..sc.segs.len() {
                let i = sc.segs[k] as usize;
                self.inside_on_step(&ring, &axis, sc, i);
            }
            let mut total = 0.0;
            for &(u, w) in &sc.intervals {
                total += self.integrate(&ring, inc, (lo, hi, full), u, w);
            }
            if total > 0.0 {
                out.entries
                    .push((det, total / TAU * inc.scale[det as usize]));
            }
        }
        out.runs = runs_of(&out.entries);
        out
    }

    /// Samples the arc `[lo, hi]` (`full` for the whole circle) with consecutive exit
    /// directions less than `max_step` apart; `sc.pts` gets `M + 1` points (the last at
    /// `hi`). A partial arc is sampled uniformly in `v`, `φ = (lo + hi)/2 −
    /// (hi − lo)/2 · cos v`, because the exit direction leaves the horizon like
    /// `sqrt(φ − lo)` at its ends.
    fn sample(&self, ring: &Ring, arc: (f64, f64, bool), sc: &mut RingScratch) {
        let (lo, hi, full) = arc;
        let (c0, c1) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let fill = |m: usize, sc: &mut RingScratch| -> f64 {
            sc.phi.clear();
            sc.pts.clear();
            for i in 0..=m {
                let phi = if i == m {
                    hi
                } else if i == 0 {
                    lo
                } else if full {
                    TAU * i as f64 / m as f64
                } else {
                    c0 - c1 * (PI * i as f64 / m as f64).cos()
                };
                sc.phi.push(phi);
                sc.pts.push(ring.at(phi));
            }
            sc.pts
                .windows(2)
                .map(|w| {
                    let d = [
                        w[1].o[0] - w[0].o[0],
                        w[1].o[1] - w[0].o[1],
                        w[1].o[2] - w[0].o[2],
                    ];
                    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                })
                .fold(0.0, f64::max)
        };
        let coarse = fill(MIN_SAMPLES, sc);
        if coarse <= self.max_step {
            return;
        }
        let mut m = ((MIN_SAMPLES as f64 * coarse / self.max_step * 1.1).ceil() as usize)
            .clamp(MIN_SAMPLES, MAX_SAMPLES);
        loop {
            let chord = fill(m, sc);
            if chord <= self.max_step || m >= MAX_SAMPLES {
                return;
            }
            m = (2 * m).min(MAX_SAMPLES);
        }
    }

    /// Appends the parts of step `i` (between samples `i` and `i + 1`) that lie inside
    /// the cone, merging with the previous interval when they touch.
    fn inside_on_step(&self, ring: &Ring, axis: &Axis, sc: &mut RingScratch, i: usize) {
        let (pa, pb) = (sc.pts[i], sc.pts[i + 1]);
        let (a, b) = (sc.phi[i], sc.phi[i + 1]);
        let (fa, fb) = (axis.f(&pa), axis.f(&pb));
        match (fa > 0.0, fb > 0.0) {
            (true, false) => {
                let r = root(ring, axis, (a, fa), (b, fb));
                push(a, r, &mut sc.intervals);
            }
            (false, true) => {
                let r = root(ring, axis, (a, fa), (b, fb));
                push(r, b, &mut sc.intervals);
            }
            (true, true) => {
                // A dip out of the cone inside the step? Every point of the step is
                // within (d_a + d_b + L)/2 of the axis (L the step's arc length), so
                // only steps near the rim can leave the cone.
                let (da, db) = (end_slope(axis, &pa, true), end_slope(axis, &pb, false));
                if da < 0.0 && db > 0.0 && axis.may_leave(&pa, &pb) {
                    let x = extremum(ring, axis, (a, da), (b, db));
                    let fx = axis.f(&ring.at(x));
                    if fx <= 0.0 {
                        let r1 = root(ring, axis, (a, fa), (x, fx));
                        let r2 = root(ring, axis, (x, fx), (b, fb));
                        push(a, r1, &mut sc.intervals);
                        push(r2, b, &mut sc.intervals);
                        return;
                    }
                }
                push(a, b, &mut sc.intervals);
            }
            (false, false) => {
                // A hidden visit of the cone inside the step? Only possible when
                // (d_a + d_b − L)/2 < α.
                let (da, db) = (end_slope(axis, &pa, true), end_slope(axis, &pb, false));
                if da > 0.0 && db < 0.0 && axis.may_enter(&pa, &pb) {
                    let x = extremum(ring, axis, (a, da), (b, db));
                    let fx = axis.f(&ring.at(x));
                    if fx > 0.0 {
                        let r1 = root(ring, axis, (a, fa), (x, fx));
                        let r2 = root(ring, axis, (x, fx), (b, fb));
                        push(r1, r2, &mut sc.intervals);
                    }
                }
            }
        }
    }

    /// `∫_u^w F γ dφ` over part of the escaping arc `[lo, hi]` (`full` for the whole
    /// circle). On a partial arc the exit direction leaves at the horizon at both ends,
    /// where `k_out.z` and the exit Fresnel factor go like `sqrt(φ − lo)`; the
    /// substitution `φ = (lo + hi)/2 − (hi − lo)/2 · cos v` makes the integrand analytic
    /// there. 8-point Gauss–Legendre on panels of at most π/8 (in `φ` or `v`).
    fn integrate(&self, ring: &Ring, inc: &IsoInc, arc: (f64, f64, bool), u: f64, w: f64) -> f64 {
        let (lo, hi, full) = arc;
        let (c0, c1) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let to_v = |phi: f64| ((c0 - phi) / c1).clamp(-1.0, 1.0).acos();
        let (a, b) = if full { (u, w) } else { (to_v(u), to_v(w)) };
        let opts = self.options;
        let n = opts.n;
        let panels = ((b - a) / PANEL).ceil().max(1.0);
        let h = (b - a) / panels;
        let mut total = 0.0;
        for p in 0..panels as usize {
            let mid = a + (p as f64 + 0.5) * h;
            let mut s = 0.0;
            for &(x, wt) in &self.gl {
                let v = mid + 0.5 * h * x;
                let (phi, jac) = if full {
                    (v, 1.0)
                } else {
                    let (sv, cv) = v.sin_cos();
                    (c0 - c1 * cv, c1 * sv)
                };
                let q = ring.at(phi);
                if q.k2z <= 0.0 || q.o[2] <= 0.0 {
                    continue;
                }
                // The same exact path factor as the plain model's ray (its Jones path
                // out of the plane of incidence), at this azimuth of the normal.
                let (sp, cp) = phi.sin_cos();
                let m = Vec3::new(ring.s * cp, ring.s * sp, ring.c);
                let k1 = Vec3::new(inc.st, 0.0, -inc.ct);
                let path = RayPath {
                    k_in: inc.k_in,
                    k1,
                    m,
                    k2: Vec3::new(q.o[0] / n, q.o[1] / n, q.k2z),
                    k_out: Vec3::new(q.o[0], q.o[1], q.o[2]),
                };
                s += wt
                    * jac
                    * path_factor_of(opts, &inc.entry, inc.entry_t, &path, q.gamma)
                    * q.gamma;
            }
            total += 0.5 * h * s;
        }
        total
    }
}

/// Appends `[u, w]` to `iv`, merging with the last interval when they touch.
fn push(u: f64, w: f64, iv: &mut Vec<(f64, f64)>) {
    if w <= u {
        return;
    }
    if let Some(last) = iv.last_mut()
        && last.1 == u
    {
        last.1 = w;
        return;
    }
    iv.push((u, w));
}

/// Slope of `f` at a step end for the extremum tests. At the horizon end of an arc
/// (`k_out.z = 0`) the exit direction rises vertically: `+∞` at the start of a step,
/// `−∞` at its end.
fn end_slope(axis: &Axis, p: &RingPoint, at_start: bool) -> f64 {
    if p.o[2] > 0.0 {
        axis.df(p)
    } else if at_start {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    }
}

/// The root of `f` between `(a, f(a))` and `(b, f(b))`, which have opposite signs
/// (`f ≤ 0` counts as outside): Newton's method from the secant point, safeguarded by
/// bisection, to 1e-13 rad or `|f| ≤ 1e-16`.
fn root(ring: &Ring, axis: &Axis, (a, fa): (f64, f64), (b, fb): (f64, f64)) -> f64 {
    // Keep `lo` on the outside (f ≤ 0) and `hi` on the inside.
    let (mut lo, mut hi) = if fa > 0.0 { (b, a) } else { (a, b) };
    let (flo, fhi) = if fa > 0.0 { (fb, fa) } else { (fa, fb) };
    let mut x = lo + (hi - lo) * (flo / (flo - fhi)).clamp(0.01, 0.99);
    for _ in 0..100 {
        let p = ring.at(x);
        let f = axis.f(&p);
        if f > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        if f.abs() <= 1e-16 || (hi - lo).abs() < 1e-13 {
            break;
        }
        let newton = x - f / axis.df(&p);
        let next = if newton.is_finite() && (newton - lo) * (newton - hi) < 0.0 {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - x).abs() < 1e-14 {
            x = next;
            break;
        }
        x = next;
    }
    x
}

/// The azimuth between `(a, f'(a))` and `(b, f'(b))` (slopes of opposite signs, from
/// [`end_slope`]) where `f'` vanishes: the Illinois variant of regula falsi, bisection
/// while an end slope is infinite, to 1e-13 rad.
fn extremum(
    ring: &Ring,
    axis: &Axis,
    (mut a, mut sa): (f64, f64),
    (mut b, mut sb): (f64, f64),
) -> f64 {
    let mut side = 0i8;
    for _ in 0..100 {
        if b - a < 1e-13 {
            break;
        }
        let x = if sa.is_finite() && sb.is_finite() {
            (a * sb - b * sa) / (sb - sa)
        } else {
            0.5 * (a + b)
        };
        let x = if x > a && x < b { x } else { 0.5 * (a + b) };
        let p = ring.at(x);
        let sx = if p.o[2] > 0.0 { axis.df(&p) } else { sa };
        if sx == 0.0 {
            return x;
        }
        if (sx > 0.0) == (sa > 0.0) {
            a = x;
            sa = sx;
            if side == -1 {
                sb *= 0.5;
            }
            side = -1;
        } else {
            b = x;
            sb = sx;
            if side == 1 {
                sa *= 0.5;
            }
            side = 1;
        }
    }
    0.5 * (a + b)
}

/// One table row: the response of one node at one incidence (empty until computed).
type Row = NodeResponse;

/// One tile's deposits (module docs): area factors and pixel counts on fine nodes,
/// area factors times the hat of the coarse cell on odd nodes, pixels per fine cell;
/// each list in ascending order of its node or cell.
#[derive(Debug, Default)]
struct TileDeposit {
    usable: u64,
    nodes: Vec<(u32, f64, f64)>,
    odd: Vec<(u32, f64)>,
    cells: Vec<(u32, u32)>,
    /// Every pixel's `t` and area factor `w`, grouped by fine cell in the order of
    /// `cells` (raster order within a cell), for the edge cells.
    pixel_t: Vec<f64>,
    pixel_w: Vec<f64>,
}

/// A detector whose response switches on or off inside a fine cell: `h` is zero at one
/// node and not at the other. Near such an edge `h ∝ sqrt(θ − θc)` times a smooth
/// factor, so `h²` is smooth: it is interpolated linearly, from the two nodes on the
/// lit side, as `q(t) = q0 + qs t` (`t ∈ [0, 1]` across the cell, root clamped into
/// the cell), and `h ≈ sqrt(max(q, 0))` replaces the linear `lin0 (1 − t) + lin1 t`.
///
/// The square-root law is applied only where `h²` is nearly straight over the lit
/// side's nodes ([`square_root_edge`]); elsewhere (a ring's arc ending at the horizon,
/// a response narrower than a few cells, or an edge next to another change of shape)
/// the cell stays linear. In both cases the difference between the two interpolations
/// enters the error estimate.
#[derive(Debug, Clone, Copy)]
struct Edge {
    det: u32,
    lin0: f64,
    lin1: f64,
    q0: f64,
    qs: f64,
    apply: bool,
}

impl Edge {
    /// Edge-aware minus linear interpolation at `t`.
    #[inline]
    fn correction(&self, t: f64) -> f64 {
        (self.q0 + self.qs * t).max(0.0).sqrt() - (self.lin0 * (1.0 - t) + self.lin1 * t)
    }
}

/// Whether `h²` at three consecutive lit nodes (nearest the edge first) is straight
/// enough for the square-root law: second difference below a tenth of the first.
/// Edges of another kind (a ring's arc ending at the horizon, where the exit Fresnel
/// factor vanishes) stay linear.
fn square_root_edge(q1: f64, q2: f64, q3: f64) -> bool {
    (q3 - 2.0 * q2 + q1).abs() <= 0.1 * (q2 - q1)
}

/// What the contraction needs per fine cell and incidence, computed once from the rows:
/// the detectors lit at either node (for `rays`) and the edges.
#[derive(Debug, Clone, Default)]
struct CellInfo {
    /// The lit detectors in runs `(first, count)` of at most [`LANES`] consecutive ones.
    lit: Vec<(u32, u32)>,
    edges: Vec<Edge>,
}

/// The cell information of fine cell `c`.
fn cell_info(rows: &[Row], c: usize) -> CellInfo {
    let (r0, r1) = (&rows[c].entries, &rows[c + 1].entries);
    let mut dets: Vec<u32> = r0.iter().chain(r1).map(|e| e.0).collect();
    dets.sort_unstable();
    dets.dedup();
    let mut lit: Vec<(u32, u32)> = Vec::new();
    for det in dets {
        match lit.last_mut() {
            Some((first, count)) if *first + *count == det && (*count as usize) < LANES => {
                *count += 1;
            }
            _ => lit.push((det, 1)),
        }
    }
    CellInfo {
        lit,
        edges: cell_edges(rows, c),
    }
}

/// `|h_k − (h_{k−1} + h_{k+1})/2|` for every detector lit at all three nodes around the
/// odd node `k` (coarse cells holding an edge are covered by the edge terms).
fn odd_defect(rows: &[Row], k: usize) -> Vec<Run> {
    let (a, b, c) = (&rows[k - 1].entries, &rows[k].entries, &rows[k + 1].entries);
    let entries: Vec<(u32, f64)> = b
        .iter()
        .filter_map(|&(det, v)| {
            let (va, vc) = (value_in(a, det), value_in(c, det));
            (va > 0.0 && vc > 0.0).then(|| (det, (v - 0.5 * (va + vc)).abs()))
        })
        .collect();
    runs_of(&entries)
}

/// Value of detector `det` in a sorted row (0 when absent).
fn value_in(row: &[(u32, f64)], det: u32) -> f64 {
    row.binary_search_by_key(&det, |e| e.0)
        .map_or(0.0, |i| row[i].1)
}

/// The edges of fine cell `c` (nodes `c − 2 … c + 3` computed): every detector lit at
/// only one node of the cell, with its square-root model (module docs, [`Edge`]).
fn cell_edges(rows: &[Row], c: usize) -> Vec<Edge> {
    let (r0, r1) = (&rows[c].entries, &rows[c + 1].entries);
    let mut out = Vec::new();
    let (mut i0, mut i1) = (0, 0);
    while i0 < r0.len() || i1 < r1.len() {
        let d0 = r0.get(i0).map_or(u32::MAX, |e| e.0);
        let d1 = r1.get(i1).map_or(u32::MAX, |e| e.0);
        let det = d0.min(d1);
        let v0 = if d0 == det { r0[i0].1 } else { 0.0 };
        let v1 = if d1 == det { r1[i1].1 } else { 0.0 };
        if d0 == det {
            i0 += 1;
        }
        if d1 == det {
            i1 += 1;
        }
        if v0 == 0.0 && v1 > 0.0 {
            let h2 = value_in(&rows[c + 2].entries, det);
            let h3 = value_in(&rows[c + 3].entries, det);
            let slope = h2 * h2 - v1 * v1;
            // h² through nodes c+1, c+2, its root clamped into the cell (to node c
            // when h² does not grow away from the edge).
            let (mut q0, mut qs) = (v1 * v1 - slope, slope);
            if slope <= 0.0 || q0 > 0.0 {
                (q0, qs) = (0.0, v1 * v1);
            }
            let apply = slope > 0.0 && square_root_edge(v1 * v1, h2 * h2, h3 * h3);
            out.push(Edge {
                det,
                lin0: 0.0,
                lin1: v1,
                q0,
                qs,
                apply,
            });
        } else if v0 > 0.0 && v1 == 0.0 {
            let hm = if c > 0 {
                value_in(&rows[c - 1].entries, det)
            } else {
                0.0
            };
            let hmm = if c > 1 {
                value_in(&rows[c - 2].entries, det)
            } else {
                0.0
            };
            let drop = hm * hm - v0 * v0;
            let (q0, mut qs) = (v0 * v0, -drop);
            if drop <= 0.0 || q0 + qs > 0.0 {
                qs = -v0 * v0;
            }
            let apply = drop > 0.0 && c > 1 && square_root_edge(v0 * v0, hm * hm, hmm * hmm);
            out.push(Edge {
                det,
                lin0: v0,
                lin1: 0.0,
                q0,
                qs,
                apply,
            });
        }
    }
    out
}

/// Scratch arrays of the deposits: per node (`g`, `gn`, `hat`) and per fine cell
/// (`cells`), all zero between tiles; per usable pixel of the tile (`slopes`,
/// `coords`), overwritten by each tile.
#[derive(Debug, Default)]
struct TileScratch {
    normals: Scratch,
    direct: DirectRow,
    g: Vec<f64>,
    gn: Vec<f64>,
    hat: Vec<f64>,
    cells: Vec<u32>,
    /// The usable pixels' direct slopes `(a, b)`, raster order.
    slopes: Vec<(f64, f64)>,
    /// Their node coordinates `x` and area factors `w`.
    coords: Vec<(f64, f64)>,
}

/// Sums of one tile.
#[derive(Debug)]
struct IsoPartial {
    sums: Vec<f64>,
    defect: Vec<f64>,
    counts: Vec<u32>,
    usable: u64,
    lost_tir: f64,
    lost_down: f64,
}

/// The node coordinate `x = θn/δ` of slopes `(a, b)`.
fn node_coordinate(a: f64, b: f64, inv_delta: f64) -> f64 {
    (a * a + b * b).sqrt().atan() * inv_delta
}

impl TopoModel {
    /// The input checks of [`TopoModel::run`].
    fn check_run(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
    ) -> Result<(), TopoError> {
        if maps.is_empty() {
            return Err(TopoError::Empty("height map"));
        }
        if theta_i.is_empty() {
            return Err(TopoError::Empty("incidence angle"));
        }
        if cones.is_empty() {
            return Err(TopoError::Empty("detector"));
        }
        for &t in theta_i {
            if !(t.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&t)) {
                return Err(TopoError::Incidence(t));
            }
        }
        if let Some(j) = cones.iter().position(|c| c.half_angle() <= 0.0) {
            return Err(TopoError::PointDetector(j));
        }
        for (i, map) in maps.iter().enumerate() {
            self.check_map(i, map)?;
        }
        Ok(())
    }

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
        if self.absorption().is_some() {
            return Err(TopoError::Unsupported(
                "the isotropic average does not include binder absorption (its weight is integrated around each ring without the path factor); use the plain topographic model",
            ));
        }
        self.check_run(maps, theta_i, cones)?;
        let opts = self.options();
        let n = opts.n;
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
        let mut apertures: Vec<f64> = Vec::new();
        for c in cones {
            if !apertures.contains(&c.half_angle()) {
                apertures.push(c.half_angle());
            }
        }
        let ndet = cones.len() + apertures.len();
        let margin = 0.6 * alpha_min;
        let mut incs = Vec::with_capacity(theta_i.len());
        for &t in theta_i {
            let mut all = cones.to_vec();
            for &a in &apertures {
                all.push(Cone::in_plane(-t, a).map_err(TopoError::Detector)?);
            }
            let k1 = refraction::into_coating(&detector::incident_direction(t), n);
            let ct = -k1.z;
            let scale = all
                .iter()
                .map(|c| match opts.weighting {
                    Weighting::Physical => 1.0 / ct,
                    Weighting::PaperPrinted => {
                        let cz = c.axis().z;
                        let sin2 = (1.0 - cz * cz).max(0.0);
                        (1.0 - sin2 / (n * n)).sqrt() / cz
                    }
                })
                .collect();
            let amps = fresnel::amplitudes_air_to_coating(t, n);
            incs.push(IsoInc {
                st: k1.x,
                ct,
                entry: fresnel::air_to_coating(t, n),
                entry_t: (amps[2], amps[3]),
                k_in: *detector::incident_direction(t),
                axes: all.iter().map(Axis::new).collect(),
                index: ConeIndex::with_margin(&all, margin, index::COARSE),
                scale,
                cones: all,
            });
        }
        let gl = GaussLegendre::new(GL_POINTS.try_into().expect("non-zero"))
            .as_node_weight_pairs()
            .to_vec();
        let setup = IsoSetup {
            options: opts,
            incs,
            kappa: (1.0 - 1.0 / (n * n)).max(0.0).sqrt(),
            max_step: 0.95 * alpha_min,
            gl,
            inv_delta: 1.0 / delta,
        };
        let ninc = theta_i.len();
        // Nodes 0..=kmax cover θ up to π/2 with the neighbours the deposits use.
        let kmax = (std::f64::consts::FRAC_PI_2 * setup.inv_delta).ceil() as usize + 4;
        let mut rows: Vec<Vec<Row>> = (0..ninc).map(|_| Vec::new()).collect();
        let mut computed: Vec<bool> = Vec::new();
        let mut cells: Vec<Vec<CellInfo>> = (0..ninc).map(|_| Vec::new()).collect();
        let mut cells_done: Vec<bool> = Vec::new();
        let mut defects: Vec<Vec<Vec<Run>>> = (0..ninc).map(|_| Vec::new()).collect();
        let mut defects_done: Vec<bool> = Vec::new();
        let mut nodes = 0usize;

        let jobs: Vec<(usize, Rect)> = maps
            .iter()
            .enumerate()
            .flat_map(|(i, m)| self.tiles(m).into_iter().map(move |r| (i, r)))
            .collect();
        let total_tiles = jobs.len() as u64;
        let h = opts.window / 2;
        let physical = opts.weighting == Weighting::Physical;

        let nslots = ninc * ndet;
        let mut stats = TileStats::new(nslots);
        let mut defect = vec![0.0; nslots];
        let mut rays = vec![0u64; nslots];
        let (mut lost_tir, mut lost_down, mut usable) = (0.0, 0.0, 0u64);
        // The ordered reduction of a batch's tile sums, run while the next batch's
        // deposits are made (`rayon::join`); returns the tiles reduced so far.
        let mut reduce = |partials: Vec<IsoPartial>| {
            for p in partials {
                stats.add(&p.sums[..nslots]);
                usable += p.usable;
                lost_tir += p.lost_tir;
                lost_down += p.lost_down;
                for s in 0..nslots {
                    defect[s] += p.defect[s];
                    rays[s] += u64::from(p.counts[s]);
                }
            }
            stats.tiles
        };
        let mut missing: Vec<usize> = Vec::new();
        let mut pending = Vec::new();
        for batch in jobs.chunks(BATCH) {
            // 1. Deposits of the batch's tiles (and the previous batch's reduction).
            let done = std::mem::take(&mut pending);
            let (reduced, deposits): (u64, Vec<TileDeposit>) = rayon::join(
                || reduce(done),
                || {
                    batch
                        .par_iter()
                        .map_init(TileScratch::default, |ts, &(mi, rect)| {
                            deposit_tile(maps[mi], rect, h, physical, setup.inv_delta, kmax, ts)
                        })
                        .collect()
                },
            );
            progress(reduced, total_tiles);
            // 2. The table nodes they need that are not computed yet, computed in
            // parallel (each node's value does not depend on when it is computed).
            missing.clear();
            let mut need = |k: usize, computed: &mut Vec<bool>| {
                if k >= computed.len() {
                    computed.resize(k + 1, false);
                }
                if !computed[k] {
                    computed[k] = true;
                    missing.push(k);
                }
            };
            for d in &deposits {
                for &(k, _, _) in &d.nodes {
                    need(k as usize, &mut computed);
                }
                for &(k, _) in &d.odd {
                    let k = k as usize;
                    need(k - 1, &mut computed);
                    need(k, &mut computed);
                    need(k + 1, &mut computed);
                }
                for &(c, _) in &d.cells {
                    let c = c as usize;
                    for k in c.saturating_sub(2)..=c + 3 {
                        need(k, &mut computed);
                    }
                }
            }
            if !missing.is_empty() {
                let table_jobs: Vec<(usize, usize)> = missing
                    .iter()
                    .flat_map(|&k| (0..ninc).map(move |ii| (ii, k)))
                    .collect();
                let fresh: Vec<NodeResponse> = table_jobs
                    .par_iter()
                    .map_init(RingScratch::default, |sc, &(ii, k)| {
                        setup.response(ii, k as f64 * delta, sc)
                    })
                    .collect();
                nodes += fresh.len();
                for r in &mut rows {
                    if r.len() < computed.len() {
                        r.resize_with(computed.len(), NodeResponse::default);
                    }
                }
                for (&(ii, k), resp) in table_jobs.iter().zip(fresh) {
                    rows[ii][k] = resp;
                }
            }
            // 3. What the contraction needs per cell and odd node, once each: the new
            // cells and odd nodes, then their information, one incidence per task.
            let (mut new_cells, mut new_odd) = (Vec::new(), Vec::new());
            for d in &deposits {
                for &(c, _) in &d.cells {
                    let c = c as usize;
                    if c >= cells_done.len() {
                        cells_done.resize(c + 1, false);
                    }
                    if !cells_done[c] {
                        cells_done[c] = true;
                        new_cells.push(c);
                    }
                }
                for &(k, _) in &d.odd {
                    let k = k as usize;
                    if k >= defects_done.len() {
                        defects_done.resize(k + 1, false);
                    }
                    if !defects_done[k] {
                        defects_done[k] = true;
                        new_odd.push(k);
                    }
                }
            }
            (cells.par_iter_mut().zip(&mut defects))
                .zip(&rows)
                .for_each(|((cells, defects), rows)| {
                    cells.resize_with(cells_done.len(), CellInfo::default);
                    defects.resize_with(defects_done.len(), Vec::new);
                    for &c in &new_cells {
                        cells[c] = cell_info(rows, c);
                    }
                    for &k in &new_odd {
                        defects[k] = odd_defect(rows, k);
                    }
                });
            // 4. Contraction with the table (reduced with the next batch's deposits, or
            // after the last batch).
            pending = deposits
                .par_iter()
                .map(|d| {
                    let tile = ContractTile {
                        d,
                        rows: &rows,
                        cells: &cells,
                        defects: &defects,
                        ndet,
                        lanes: (),
                    };
                    match pulp::Arch::new() {
                        #[cfg(target_arch = "x86_64")]
                        pulp::Arch::V4(v4) => pulp::Simd::vectorize(v4, tile.with(v4)),
                        arch => arch.dispatch(tile.with(Portable)),
                    }
                })
                .collect();
        }
        progress(reduce(pending), total_tiles);

        let pixels: u64 = maps.iter().map(|m| m.len() as u64).sum();
        if usable == 0 {
            return Err(TopoError::NoUsablePixels {
                window: opts.window,
                valid: maps.iter().map(|m| m.valid_count()).sum(),
                pixels: pixels as usize,
            });
        }
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
                let rho = stats.sum[s] * inv_n + if seen_cc { cc } else { 0.0 };
                let se = se_factor
                    .filter(|_| rays[s] > 0)
                    .map(|f| (f * stats.m2[s]).sqrt() * inv_n);
                (rho, se, seen_cc)
            };
            for (j, cone) in cones.iter().enumerate() {
                let (rho, se, seen_cc) = value(j);
                let a = apertures
                    .iter()
                    .position(|&a| a == cone.half_angle())
                    .unwrap_or(0);
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
                    clearcoat_seen: seen_cc,
                });
                interpolation_error.push(defect[s] * inv_n);
            }
        }
        Ok(IsotropicResult {
            points,
            interpolation_error,
            maps: maps.len(),
            pixels,
            usable_pixels: usable,
            rings_traced: usable * ninc as u64,
            rings_lost_tir: lost_tir,
            rings_lost_down: lost_down,
            tiles: total_tiles,
            block_um: self.block_um(),
            node_spacing: delta,
            warnings: crate::model::tile_warnings(total_tiles),
            nodes,
        })
    }
}

/// The deposits of one tile's usable pixels (raster order): for a pixel at node
/// coordinate `x = θn/δ` in fine cell `c = ⌊x⌋` with `t = x − c` and area factor `w`:
/// `w(1 − t)`, `w t` on nodes `c`, `c + 1` (and the same without `w` for the lost
/// fractions); `w · (1 − |1 − 2t'|)` on the odd node `2C + 1` of its coarse cell
/// `C = ⌊x/2⌋`, `t' = x/2 − C` (the shape of the difference between the fine and the
/// coarse interpolation); one pixel in cell `c`.
///
/// The pixels only add (no test of whether a node was touched before: a branch per
/// node that the processor could not predict); the touched nodes and cells are then
/// read off the pixel counts per cell, between the least and greatest cell of the
/// tile: node `k` is touched when cell `k` or `k − 1` holds a pixel, odd node `k`
/// when cell `k` or `k − 1` does (`⌊x/2⌋ = ⌊c/2⌋`, so a pixel's odd node is `c | 1`).
fn deposit_tile(
    map: &HeightMap,
    rect: Rect,
    h: usize,
    physical: bool,
    inv_delta: f64,
    kmax: usize,
    ts: &mut TileScratch,
) -> TileDeposit {
    if ts.g.len() < kmax + 1 {
        ts.g.resize(kmax + 1, 0.0);
        ts.gn.resize(kmax + 1, 0.0);
        ts.hat.resize(kmax + 1, 0.0);
        ts.cells.resize(kmax + 1, 0);
    }
    let TileScratch {
        normals,
        direct,
        g,
        gn,
        hat,
        cells,
        slopes,
        coords,
    } = ts;
    let mut pixels = Vec::with_capacity((rect.r1 - rect.r0) * (rect.c1 - rect.c0));
    let mut direct = direct.tile(map, h, rect);
    // The usable pixels' slopes first, then their node coordinates and area factors
    // in a loop of independent pixels (so that the processor overlaps their `atan`s),
    // then the deposits in raster order.
    slopes.clear();
    tile_usable(map, h, rect, normals, |row, col| {
        slopes.push(direct.slopes(row, col));
    });
    coords.clear();
    coords.extend(slopes.iter().map(|&(a, b)| {
        let w = if physical {
            (1.0 + a * a + b * b).sqrt()
        } else {
            1.0
        };
        (node_coordinate(a, b, inv_delta), w)
    }));
    // The least and greatest cell of the tile's pixels.
    let (mut lo, mut hi) = (usize::MAX, 0);
    for &(x, w) in coords.iter() {
        let c = x as usize;
        let t = x - c as f64;
        for (k, f) in [(c, 1.0 - t), (c + 1, t)] {
            g[k] += w * f;
            gn[k] += f;
        }
        cells[c] += 1;
        pixels.push((c as u32, t, w));
        let x2 = 0.5 * x;
        let cc = x2 as usize;
        let t2 = x2 - cc as f64;
        hat[2 * cc + 1] += w * (1.0 - (1.0 - 2.0 * t2).abs());
        (lo, hi) = (lo.min(c), hi.max(c));
    }
    let usable = coords.len() as u64;
    let mut d = TileDeposit {
        usable,
        nodes: Vec::new(),
        odd: Vec::new(),
        cells: Vec::new(),
        pixel_t: Vec::new(),
        pixel_w: Vec::new(),
    };
    if usable == 0 {
        return d;
    }
    let held = |c: usize, cells: &[u32]| c >= lo && c <= hi && cells[c] > 0;
    for k in lo..=hi + 1 {
        if held(k, cells) || (k > 0 && held(k - 1, cells)) {
            d.nodes.push((k as u32, g[k], gn[k]));
        }
        (g[k], gn[k]) = (0.0, 0.0);
    }
    for k in (lo | 1..=hi | 1).step_by(2) {
        if held(k, cells) || held(k - 1, cells) {
            d.odd.push((k as u32, hat[k]));
        }
        hat[k] = 0.0;
    }
    // Pixels grouped by cell (stable: raster order within a cell), cells ascending: a
    // counting sort, each cell's count turned into its first slot, the pixels placed
    // in the order they came.
    let mut first = 0u32;
    for (c, slot) in (lo..).zip(&mut cells[lo..=hi]) {
        let count = *slot;
        if count > 0 {
            d.cells.push((c as u32, count));
            *slot = first;
            first += count;
        }
    }
    let (mut pixel_t, mut pixel_w) = (vec![0.0; pixels.len()], vec![0.0; pixels.len()]);
    for &(c, t, w) in &pixels {
        let slot = &mut cells[c as usize];
        (pixel_t[*slot as usize], pixel_w[*slot as usize]) = (t, w);
        *slot += 1;
    }
    (d.pixel_t, d.pixel_w) = (pixel_t, pixel_w);
    cells[lo..=hi].fill(0);
    d
}

/// One tile's contraction ([`contract_tile`]), handed to [`pulp::Arch::dispatch`] (or
/// to [`pulp::x86::V4`] directly, which then adds a run of eight consecutive detectors
/// in one masked instruction: `lanes`).
struct ContractTile<'a, L> {
    d: &'a TileDeposit,
    rows: &'a [Vec<Row>],
    cells: &'a [Vec<CellInfo>],
    defects: &'a [Vec<Vec<Run>>],
    ndet: usize,
    lanes: L,
}

impl<'a> ContractTile<'a, ()> {
    /// The same contraction with `lanes`.
    fn with<L: Lanes>(self, lanes: L) -> ContractTile<'a, L> {
        ContractTile {
            d: self.d,
            rows: self.rows,
            cells: self.cells,
            defects: self.defects,
            ndet: self.ndet,
            lanes,
        }
    }
}

impl<L: Lanes> pulp::WithSimd for ContractTile<'_, L> {
    type Output = IsoPartial;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> IsoPartial {
        contract_tile(
            self.d,
            self.rows,
            self.cells,
            self.defects,
            self.ndet,
            self.lanes,
        )
    }
}

/// Contracts one tile's deposits with the table rows (`rows[ii][k]`): per detector the
/// same products and sums, in the same order, as one entry at a time; the rows, odd-node
/// defects and lit detectors go a run of consecutive detectors at a time ([`Run`]),
/// into sums that reach [`LANES`] past the last detector.
#[inline(always)]
fn contract_tile<L: Lanes>(
    d: &TileDeposit,
    rows: &[Vec<Row>],
    cells: &[Vec<CellInfo>],
    defects: &[Vec<Vec<Run>>],
    ndet: usize,
    lanes: L,
) -> IsoPartial {
    let ninc = rows.len();
    let mut p = IsoPartial {
        sums: vec![0.0; ninc * ndet + LANES],
        defect: vec![0.0; ninc * ndet + LANES],
        counts: vec![0; ninc * ndet + LANES],
        usable: d.usable,
        lost_tir: 0.0,
        lost_down: 0.0,
    };
    // The edge corrections of one cell's pixels.
    let mut dh: Vec<f64> = Vec::new();
    // The eight sums from detector `j` of a slice that reaches `LANES` past the last.
    fn eight<T>(v: &mut [T], j: u32) -> &mut [T; LANES] {
        let j = j as usize;
        (&mut v[j..j + LANES]).try_into().expect("LANES elements")
    }
    for (ii, table) in rows.iter().enumerate() {
        let base = ii * ndet;
        let sums = &mut p.sums[base..base + ndet + LANES];
        for &(k, g, gn) in &d.nodes {
            let row = &table[k as usize];
            for r in &row.runs {
                lanes.add_scaled(eight(sums, r.start), &r.v, g, r.len as usize);
            }
            p.lost_tir += gn * row.tir;
            p.lost_down += gn * row.down;
        }
        let defect = &mut p.defect[base..base + ndet + LANES];
        for &(k, hat) in &d.odd {
            for r in &defects[ii][k as usize] {
                lanes.add_scaled(eight(defect, r.start), &r.v, hat, r.len as usize);
            }
        }
        // Per fine cell (pixels sorted by cell): pixels whose interpolated response is
        // non-zero, and the edge cells, where the edge-aware interpolation replaces the
        // linear one and the size of that correction is the error estimate.
        let counts = &mut p.counts[base..base + ndet + LANES];
        let mut start = 0;
        for &(c, nc) in &d.cells {
            let info = &cells[ii][c as usize];
            let cell = start..start + nc as usize;
            let (ts, ws) = (&d.pixel_t[cell.clone()], &d.pixel_w[cell]);
            start += nc as usize;
            for &(first, count) in &info.lit {
                lanes.add_count(eight(counts, first), nc, count as usize);
            }
            for e in &info.edges {
                // The corrections in a loop of independent pixels (vectorised), then
                // their sums in raster order, in registers.
                dh.clear();
                dh.extend(ts.iter().zip(ws).map(|(&t, &w)| w * e.correction(t)));
                let det = e.det as usize;
                let (mut s, mut f) = (sums[det], defect[det]);
                for &dh in dh.iter() {
                    if e.apply {
                        s += dh;
                    }
                    f += dh.abs();
                }
                (sums[det], defect[det]) = (s, f);
            }
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs hold consecutive detectors only, at most `LANES` of them, every entry once
    /// and in order, with zeros past their length.
    #[test]
    fn runs_cut_rows_at_gaps_and_at_eight() {
        let dets = [3, 4, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 40];
        let entries: Vec<(u32, f64)> = dets.iter().map(|&d| (d, f64::from(d) + 0.5)).collect();
        let runs = runs_of(&entries);
        let shape: Vec<(u32, u32)> = runs.iter().map(|r| (r.start, r.len)).collect();
        assert_eq!(shape, [(3, 2), (6, 8), (14, 3), (40, 1)]);
        let back: Vec<(u32, f64)> = runs
            .iter()
            .flat_map(|r| (0..r.len).map(move |l| (r.start + l, r.v[l as usize])))
            .collect();
        assert_eq!(back, entries);
        assert!(
            runs.iter()
                .all(|r| r.v[r.len as usize..].iter().all(|&v| v == 0.0))
        );
    }

    fn setup_for<'a>(options: &'a TopoOptions, theta_i: f64, cones: &[Cone]) -> IsoSetup<'a> {
        let n = options.n;
        let k1 = refraction::into_coating(&detector::incident_direction(theta_i), n);
        let alpha_min = cones
            .iter()
            .map(Cone::half_angle)
            .fold(f64::INFINITY, f64::min);
        IsoSetup {
            options,
            incs: vec![IsoInc {
                st: k1.x,
                ct: -k1.z,
                entry: fresnel::air_to_coating(theta_i, n),
                entry_t: {
                    let a = fresnel::amplitudes_air_to_coating(theta_i, n);
                    (a[2], a[3])
                },
                k_in: *detector::incident_direction(theta_i),
                axes: cones.iter().map(Axis::new).collect(),
                index: ConeIndex::with_margin(cones, 0.6 * alpha_min, index::COARSE),
                scale: vec![1.0; cones.len()],
                cones: cones.to_vec(),
            }],
            kappa: (1.0 - 1.0 / (n * n)).sqrt(),
            max_step: 0.95 * alpha_min,
            gl: GaussLegendre::new(GL_POINTS.try_into().unwrap())
                .as_node_weight_pairs()
                .to_vec(),
            inv_delta: 1.0,
        }
    }

    /// The azimuth rule (8 points on panels ≤ π/8) against 32 points on panels of π/64
    /// over whole escaping arcs and parts of them, including arcs that end at the
    /// horizon: the two agree to 1e-12.
    #[test]
    fn azimuth_rule_is_exact_to_rounding() {
        let options = TopoOptions::default();
        let cones = [Cone::in_plane(0.0, 0.1).unwrap()];
        let setup = setup_for(&options, 0.0, &cones);
        let mut fine_setup = setup_for(&options, 0.0, &cones);
        fine_setup.gl = GaussLegendre::new(32.try_into().unwrap())
            .as_node_weight_pairs()
            .to_vec();
        let mut checked = 0;
        for ti in [0.0f64, 0.5, 1.0, 1.3] {
            let st = ti.sin() / options.n;
            let inc = setup_for(&options, ti, &cones).incs.remove(0);
            assert!((inc.st - st).abs() < 1e-15);
            for theta in [0.01f64, 0.1, 0.3, 0.6, 0.9] {
                let ring = Ring::new(options.n, inc.st, inc.ct, theta);
                let arc = match ring.arc(setup.kappa) {
                    Arc::None => continue,
                    Arc::Full => (0.0, TAU, true),
                    Arc::Range(lo, hi) => (lo, hi, false),
                };
                for (fa, fb) in [(0.0, 1.0), (0.0, 0.3), (0.45, 0.55), (0.9, 1.0)] {
                    let (u, w) = (arc.0 + fa * (arc.1 - arc.0), arc.0 + fb * (arc.1 - arc.0));
                    let got = setup.integrate(&ring, &inc, arc, u, w);
                    let panels = ((w - u) / (PI / 64.0)).ceil() as usize;
                    let step = (w - u) / panels as f64;
                    let want: f64 = (0..panels)
                        .map(|p| {
                            let a = u + p as f64 * step;
                            fine_setup.integrate(&ring, &inc, arc, a, a + step)
                        })
                        .sum();
                    assert!(
                        (got - want).abs() <= 1e-12 * want.abs(),
                        "θi {ti} θ {theta} [{fa}, {fb}]: {got} vs {want}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 50, "{checked}");
    }

    /// The analytic azimuth derivative of the exit direction against central
    /// differences.
    #[test]
    fn ring_derivative_matches_finite_differences() {
        for (ti, theta) in [(0.3f64, 0.05f64), (0.9, 0.2), (0.0, 0.1), (1.2, 0.02)] {
            let st = ti.sin() / 1.5;
            let ring = Ring::new(1.5, st, (1.0 - st * st).sqrt(), theta);
            for k in 0..12 {
                let phi = 0.1 + 0.5 * f64::from(k);
                let p = ring.at(phi);
                if p.o[2] < 0.05 {
                    continue;
                }
                let e = 1e-6;
                let (a, b) = (ring.at(phi + e), ring.at(phi - e));
                for c in 0..3 {
                    let fd = (a.o[c] - b.o[c]) / (2.0 * e);
                    assert!((fd - p.d[c]).abs() < 1e-7, "{ti} {theta} {phi} {c}");
                }
            }
        }
    }

    /// The closed-form lost fractions against counting a fine azimuth grid.
    #[test]
    fn lost_fractions_match_counting() {
        let n: f64 = 1.5;
        let kappa = (1.0 - 1.0 / (n * n)).sqrt();
        for (ti, theta) in [(1.2f64, 0.4f64), (0.5, 0.5), (1.4, 0.1), (0.8, 0.9)] {
            let st = ti.sin() / n;
            let ring = Ring::new(n, st, (1.0 - st * st).sqrt(), theta);
            let m = 200_000;
            let (mut down, mut tir) = (0usize, 0usize);
            for i in 0..m {
                let p = ring.at((i as f64 + 0.5) / m as f64 * TAU);
                let s2 = p.o[0] * p.o[0] + p.o[1] * p.o[1];
                if p.k2z <= 0.0 || p.gamma <= 0.0 {
                    down += 1;
                } else if s2 >= 1.0 {
                    tir += 1;
                }
            }
            let d = ring.fraction_below(0.0);
            let t = ring.fraction_below(kappa) - d;
            assert!(
                (down as f64 / m as f64 - d).abs() < 1e-4,
                "down {ti} {theta}"
            );
            assert!((tir as f64 / m as f64 - t).abs() < 1e-4, "tir {ti} {theta}");
        }
    }
}
