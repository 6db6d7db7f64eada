//! A Lambertian base of albedo `ρ` under a layer of transmitting flakes (physics.md §13,
//! "A base under transmitting flakes").
//!
//! The flake layer covers the plane (as §4 assumes); a free thin-film flake
//! ([`FlakeReflectance::Stack`] without a core) transmits `T(γ)` at local incidence
//! cosine `γ`, keeping the ray's direction (the binder on both sides). Conventions:
//! angles in radians; `θ` is a polar angle inside the binder measured from the coating
//! normal (down- or upward); unpolarised means of s and p at every crossing.
//!
//! * **Facet seen by a ray.** A ray at polar angle `θ` meets one facet whose normal `m`
//!   is distributed as `D(m) γ⁺ / ∫ D γ⁺ dΩm`, `γ = cos θ cos θm + sin θ sin θm cos φ'`
//!   the local cosine on the side the ray meets (§4's weight `D γ / cos θ`, normalised so
//!   that the weights sum to 1; §4's own sum is `1 + Λ(θ)`, the back-lit share, below
//!   1e-3 at n = 1.5 for widths under 15°). The layer's mean transmittance and
//!   reflectance seen from above and from below are
//!   `τ↓(θ) = E[T↓(γ)]`, `ρ̄↓(θ) = E[R↓(γ)]`, `τ↑(θ) = E[T↑(γ)]`, `ρ̄↑(θ) = E[R↑(γ)]`,
//!   `T↑`, `R↑` those of the reversed stack (the same as `T↓`, `R↓` for a symmetric or a
//!   lossless stack).
//! * **The cavity.** Light going up at `θ` above the flakes meets the top surface:
//!   `T_top(θ)` leaves, `1 − T_top(θ)` (all of it beyond the critical angle) goes back
//!   down and meets the flakes' tops: `τ↓(θ)` passes to the base, `ρ̄↓(θ)` is sent up
//!   again **at the same polar angle** (a flat flake's mirror image; the spread of about
//!   twice the tilts is not followed, stated), the rest is absorbed. Summed over the
//!   bounces, of the light going up at `θ`
//!   `E(θ) = T_top / (1 − (1 − T_top) ρ̄↓)` leaves (at `θ`) and
//!   `B(θ) = (1 − T_top) τ↓ / (1 − (1 − T_top) ρ̄↓)` reaches the base.
//! * **Point BRDF** of the base term, the beam entering with `T_top(θi)` (unpolarised
//!   Fresnel), passing the flakes at the inside angle `θt`, the base returning radiance
//!   `ρE/π`, the light passing the flakes upward at `θ2` and leaving with `E(θ2)`,
//!   radiance divided by `n²` on the way out (the refraction Jacobian of §2):
//!   `f_base(θi, r) = ρ T_top(θi) τ↓(θt) τ↑(θ2) E(θ2) / (π n² (1 − ρ r̄))`.
//! * **The loop.** Of the Lambertian light the base sends up, `r̄` comes back to it:
//!   `r̄ = ∫ [ρ̄↑(θ) + τ↑(θ) B(θ)] 2 cos θ sin θ dθ` (the undersides' reflection; the
//!   cavity's light passed down through the flakes). The base re-emits every return as
//!   Lambertian light, so the geometric series `1/(1 − ρ r̄)` is exact for that loop. The
//!   base light that leaves is `e = ∫ τ↑ E 2 cos θ sin θ dθ`; for a lossless stack
//!   `ρ̄ + τ = 1` at every facet and `E + B = 1`, so `e + r̄ = 1`: a white base returns
//!   all the light that reaches it.
//!
//! `τ` and `ρ̄` are tabulated on [`TABLE_NODES`] polar angles (a product rule of
//! Gauss–Kronrod 15 panels over the facet normals: the tilt axis split on the geometric
//! ladder of the distribution's narrowest feature and at a table's bin edges, the
//! azimuth over the lit arc in 2 panels) and read by cubic (Catmull–Rom) interpolation;
//! the stack's `T`, `R` are tabulated on [`GAMMA_NODES`] local cosines and read
//! linearly. The loop integrals are adaptive Gauss–Kronrod with a break at the critical
//! angle (1e-10 relative).

use std::f64::consts::{FRAC_PI_2, PI};

use flakescatter_optics::Vec3;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel;
use flakescatter_stats::Orientation;
use rayon::prelude::*;

use crate::ModelError;
use crate::quad::{adaptive, gk15_nodes};

/// Polar-angle nodes of the `τ`, `ρ̄` tables over `[0, π/2]`.
pub const TABLE_NODES: usize = 257;
/// Local-cosine nodes of the stack's `T`, `R` tables over `[0, 1]`.
pub const GAMMA_NODES: usize = 4097;
/// Azimuth panels over the lit arc of one tilt.
const PHI_PANELS: usize = 2;

/// Whether the base-to-base loop is summed (the model's physics) or cut after one pass
/// (for tests that check the series).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BaseLoop {
    /// `1/(1 − ρ r̄)`: every return to the base re-emitted (module docs).
    #[default]
    Included,
    /// One pass: light that comes back to the base is absorbed.
    Dropped,
}

/// The Lambertian base under the flakes with its precomputed tables (module docs).
#[derive(Debug, Clone)]
pub struct BaseUnder {
    albedo: f64,
    n: f64,
    tau_down: Vec<f64>,
    tau_up: Vec<f64>,
    refl_down: Vec<f64>,
    r_loop: f64,
    escape: f64,
    /// `ρ / (π n² (1 − ρ r̄))` (or without the loop's denominator).
    gain: f64,
}

/// Catmull–Rom cubic through uniform nodes over `[0, end]` (ends repeated).
fn lookup_cubic(table: &[f64], x: f64, end: f64) -> f64 {
    let last = table.len() - 1;
    let t = (x / end).clamp(0.0, 1.0) * last as f64;
    let i = (t.floor() as usize).min(last - 1);
    let f = t - i as f64;
    let p0 = table[i.saturating_sub(1)];
    let (p1, p2) = (table[i], table[i + 1]);
    let p3 = table[(i + 2).min(last)];
    let a = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3;
    let b = p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3;
    let c = -0.5 * p0 + 0.5 * p2;
    ((a * f + b) * f + c) * f + p1
}

/// Unpolarised transmittance of the top surface for light inside at polar angle with
/// cosine `c2` (0 beyond the critical angle).
fn top_inside(c2: f64, n: f64) -> f64 {
    let s2 = 1.0 - c2 * c2;
    let co2 = 1.0 - n * n * s2;
    if co2 <= 0.0 {
        return 0.0;
    }
    let p = fresnel::power_from_cosines(co2.sqrt(), c2, n);
    0.5 * (p.ts + p.tp)
}

/// Light going up at one polar angle between the flakes' tops and the top surface
/// (module docs, "the cavity"): the shares that leave and that go down through the flakes
/// to the base, summed over the bounces.
struct Cavity {
    out: f64,
    to_base: f64,
}

impl Cavity {
    /// For the top surface's transmittance `top`, the flakes' mean reflectance `refl` and
    /// transmittance `tau` seen from above, at that angle.
    fn at(top: f64, refl: f64, tau: f64) -> Self {
        let den = 1.0 - (1.0 - top) * refl;
        if den <= 0.0 {
            // Both mirrors perfect (grazing, total internal reflection): nothing leaves
            // or reaches the base.
            return Self {
                out: 0.0,
                to_base: 0.0,
            };
        }
        Self {
            out: top / den,
            to_base: (1.0 - top) * tau / den,
        }
    }
}

/// The facets a ray meets, as weights on the local-cosine grid: for each of the
/// [`TABLE_NODES`] polar angles `θ` of a ray, the normalised weights `w_k` such that
/// `E[g(γ)] = Σ_k w_k g(γ_k)` for any `g` tabulated on the [`GAMMA_NODES`] cosines
/// `γ_k` and read linearly (module docs): the quadrature over the facet normals (tilt
/// nodes × the lit azimuth arc, weight `D γ⁺`) with each node's weight split between the
/// two grid cosines around its `γ`. They depend on the orientation distribution alone —
/// not on the wavelength, the flakes or the coat's index — so the runs of a spectrum
/// share them.
#[derive(Debug, Clone)]
pub struct FacetWeights {
    /// Row-major `TABLE_NODES × GAMMA_NODES`, each row summing to 1 (or all 0).
    weights: Vec<f64>,
    /// Per row, the range of grid indices with a weight (the rest are 0).
    spans: Vec<(usize, usize)>,
}

impl FacetWeights {
    /// The weights for facet normals following `orientation`.
    #[must_use]
    pub fn new(orientation: &Orientation) -> Self {
        let tilts = tilt_nodes(orientation);
        let rows: Vec<(Vec<f64>, (usize, usize))> = (0..TABLE_NODES)
            .into_par_iter()
            .map(|i| {
                let theta = FRAC_PI_2 * i as f64 / (TABLE_NODES - 1) as f64;
                facet_row(theta, &tilts)
            })
            .collect();
        let mut weights = Vec::with_capacity(TABLE_NODES * GAMMA_NODES);
        let mut spans = Vec::with_capacity(TABLE_NODES);
        for (row, span) in rows {
            weights.extend(row);
            spans.push(span);
        }
        Self { weights, spans }
    }

    /// `E[g(γ)]` for a ray at table node `i`, `g` on the local-cosine grid.
    fn mean(&self, i: usize, g: &[f64]) -> f64 {
        let (lo, hi) = self.spans[i];
        let row = &self.weights[i * GAMMA_NODES..(i + 1) * GAMMA_NODES];
        row[lo..hi].iter().zip(&g[lo..hi]).map(|(w, v)| w * v).sum()
    }
}

/// One row of [`FacetWeights`]: a ray at polar angle `theta`, the tilt nodes `tilts`
/// (`θm`, weight × `p2 sin θm`).
fn facet_row(theta: f64, tilts: &[(f64, f64)]) -> (Vec<f64>, (usize, usize)) {
    let (s, c) = theta.sin_cos();
    let mut row = vec![0.0; GAMMA_NODES];
    let last = GAMMA_NODES - 1;
    let mut norm = 0.0;
    let (mut lo, mut hi) = (GAMMA_NODES, 0);
    for &(t, wt) in tilts {
        if wt == 0.0 {
            continue;
        }
        let (st, ct) = t.sin_cos();
        let (a, b) = (c * ct, s * st);
        // γ = a + b cos φ' ≥ 0 on φ' ∈ [0, φ_end].
        let phi_end = if b <= a { PI } else { (-a / b).acos() };
        let step = phi_end / PHI_PANELS as f64;
        for k in 0..PHI_PANELS {
            for (phi, wp, _) in gk15_nodes(k as f64 * step, (k + 1) as f64 * step) {
                let gamma = (a + b * phi.cos()).max(0.0);
                let w = wt * wp * gamma;
                norm += w;
                // The split of `lookup_linear` at γ.
                let x = gamma.clamp(0.0, 1.0) * last as f64;
                let j = (x.floor() as usize).min(last - 1);
                let f = x - j as f64;
                row[j] += w * (1.0 - f);
                row[j + 1] += w * f;
                lo = lo.min(j);
                hi = hi.max(j + 2);
            }
        }
    }
    if norm > 0.0 {
        for v in &mut row[lo..hi] {
            *v /= norm;
        }
        (row, (lo, hi))
    } else {
        (row, (0, 0))
    }
}

/// The tilt nodes of the facet quadrature: GK15 panels between the geometric ladder of
/// the distribution's narrowest feature and its bin edges, weights times `p2 sin θm`.
fn tilt_nodes(orientation: &Orientation) -> Vec<(f64, f64)> {
    let hi = orientation.max_theta().min(FRAC_PI_2);
    let mut breaks = crate::breaks::scale_breaks(
        hi,
        orientation.narrowest_feature(),
        orientation.bin_edges().unwrap_or(&[]),
    );
    breaks.push(0.0);
    breaks.push(hi);
    breaks.sort_by(f64::total_cmp);
    breaks.dedup();
    let mut nodes = Vec::new();
    for w in breaks.windows(2) {
        for (t, wk, _) in gk15_nodes(w[0], w[1]) {
            nodes.push((t, wk * orientation.p2(t) * t.sin()));
        }
    }
    nodes
}

impl BaseUnder {
    /// The base of albedo `albedo` under free stack flakes `flake` in a binder of index
    /// `n`, flake normals following `orientation`.
    ///
    /// # Errors
    /// [`ModelError::BaseAlbedo`] unless `0 ≤ albedo ≤ 1`;
    /// [`ModelError::BaseFlake`] unless `flake` is a stack without a core.
    pub fn new(
        albedo: f64,
        n: f64,
        flake: &FlakeReflectance,
        orientation: &Orientation,
        repeat: BaseLoop,
    ) -> Result<Self, ModelError> {
        Self::with_weights(albedo, n, flake, &FacetWeights::new(orientation), repeat)
    }

    /// As [`BaseUnder::new`] with the facet weights of the flakes' orientation
    /// distribution already computed (shared by the wavelengths of a spectrum).
    ///
    /// # Errors
    /// As [`BaseUnder::new`].
    pub fn with_weights(
        albedo: f64,
        n: f64,
        flake: &FlakeReflectance,
        weights: &FacetWeights,
        repeat: BaseLoop,
    ) -> Result<Self, ModelError> {
        if !(albedo.is_finite() && (0.0..=1.0).contains(&albedo)) {
            return Err(ModelError::BaseAlbedo(albedo));
        }
        let FlakeReflectance::Stack(stack) = flake else {
            return Err(ModelError::BaseFlake);
        };
        if stack.core().is_some() {
            return Err(ModelError::BaseFlake);
        }
        let under = FlakeReflectance::stack(stack.stack().reversed(), stack.wavelength_nm(), None)
            .map_err(ModelError::FlakeIndex)?;
        // The first node at γ = 1e-6 rather than 0: at grazing incidence (γ² below the
        // rounding of 1) the stack solver returns `R = 1, T = 0`, which is not the limit
        // where no layer separates the two binders (an empty stack passes everything);
        // for any stack the value at 1e-6 is the limit to ~1e-6.
        let gammas = |f: &dyn Fn(f64) -> f64| -> Vec<f64> {
            (0..GAMMA_NODES)
                .map(|i| f((i as f64 / (GAMMA_NODES - 1) as f64).max(1e-6)))
                .collect()
        };
        let mean = |t: (f64, f64)| 0.5 * (t.0 + t.1);
        let t_down = gammas(&|g| mean(flake.transmitted(g, n)));
        let t_up = gammas(&|g| mean(under.transmitted(g, n)));
        let r_up = gammas(&|g| under.average(g, n));
        let r_down = gammas(&|g| flake.average(g, n));
        let column =
            |g: &[f64]| -> Vec<f64> { (0..TABLE_NODES).map(|i| weights.mean(i, g)).collect() };
        let (tau_down, tau_up) = (column(&t_down), column(&t_up));
        let (refl_up, refl_down) = (column(&r_up), column(&r_down));
        // The loop's hemispherical integrals over the Lambertian light (module docs).
        let at = |t: &[f64], theta: f64| lookup_cubic(t, theta, FRAC_PI_2);
        let hemi = |g: &dyn Fn(f64) -> f64| {
            let critical = if n > 1.0 { (1.0 / n).asin() } else { FRAC_PI_2 };
            adaptive(
                |theta: f64| g(theta) * (2.0 * theta).sin(),
                0.0,
                FRAC_PI_2,
                &[critical],
                1e-300,
                1e-10,
                400,
            )
            .0
        };
        let cavity = |th: f64| {
            Cavity::at(
                top_inside(th.cos(), n),
                at(&refl_down, th),
                at(&tau_down, th),
            )
        };
        let r_loop = hemi(&|th| at(&refl_up, th) + at(&tau_up, th) * cavity(th).to_base);
        let escape = hemi(&|th| at(&tau_up, th) * cavity(th).out);
        let series = match repeat {
            BaseLoop::Included => 1.0 / (1.0 - albedo * r_loop),
            BaseLoop::Dropped => 1.0,
        };
        Ok(Self {
            albedo,
            n,
            tau_down,
            tau_up,
            refl_down,
            r_loop,
            escape,
            gain: albedo * series / (PI * n * n),
        })
    }

    /// The albedo `ρ`.
    #[must_use]
    pub fn albedo(&self) -> f64 {
        self.albedo
    }

    /// `τ↓(θ)`: the flakes' mean transmittance for light going down at polar angle
    /// `theta` (radians).
    #[must_use]
    pub fn tau_down(&self, theta: f64) -> f64 {
        lookup_cubic(&self.tau_down, theta, FRAC_PI_2)
    }

    /// `τ↑(θ)`: the same for light going up.
    #[must_use]
    pub fn tau_up(&self, theta: f64) -> f64 {
        lookup_cubic(&self.tau_up, theta, FRAC_PI_2)
    }

    /// `r̄`: the share of the base's Lambertian light that returns to it.
    #[must_use]
    pub fn return_fraction(&self) -> f64 {
        self.r_loop
    }

    /// `e`: the share of the base's Lambertian light that leaves the coating.
    #[must_use]
    pub fn escape_fraction(&self) -> f64 {
        self.escape
    }

    /// `ρ̄↓(θ)`: the flakes' mean reflectance for light going down at polar angle
    /// `theta` (radians).
    #[must_use]
    pub fn refl_down(&self, theta: f64) -> f64 {
        lookup_cubic(&self.refl_down, theta, FRAC_PI_2)
    }

    /// `T_top(θi) τ↓(θt)`: the share of the beam that reaches the base, for the incidence
    /// of inside cosine `cos_t` with the entry Fresnel powers `ts`, `tp`.
    #[must_use]
    pub fn reaching(&self, cos_t: f64, ts: f64, tp: f64) -> f64 {
        0.5 * (ts + tp) * self.tau_down(cos_t.clamp(-1.0, 1.0).acos())
    }

    /// `f_base` (sr⁻¹) at the exit direction `r` (air, unit) for a beam of which
    /// `reaching` gets to the base ([`BaseUnder::reaching`]); 0 for `r.z ≤ 0`.
    #[must_use]
    pub fn brdf(&self, reaching: f64, r: &Vec3) -> f64 {
        if r.z <= 0.0 || reaching == 0.0 {
            return 0.0;
        }
        let n = self.n;
        let c2 = (n * n - 1.0 + r.z * r.z).max(0.0).sqrt() / n;
        let theta = c2.min(1.0).acos();
        let out = Cavity::at(
            top_inside(c2, n),
            self.refl_down(theta),
            self.tau_down(theta),
        )
        .out;
        self.gain * reaching * self.tau_up(theta) * out
    }
}
