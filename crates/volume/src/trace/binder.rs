//! The binder's absorption along a path (physics.md §10, "Tinted binder"): Beer–Lambert
//! on every straight stretch the ray runs inside the binder.
//!
//! A ray's direction is a unit vector inside the film (the refracted entry direction,
//! renormalised after each flake reflection, mirrored at the top and the substrate,
//! cosine-law after a diffuse event), so a segment's parameter `τ` is its length in µm.
//! Over a stretch `ℓ` both channel weights are multiplied by `exp(−α ℓ)` and the power
//! taken, `(w_s + w_p)(1 − exp(−α ℓ))`, is tallied as `absorbed_binder`: the ray's
//! weight and the balance stay whole (to rounding). The weight is taken before the
//! event at the segment's end, so that event acts on what arrives.
//!
//! A ray that goes on through a free stack flake (module `stack`) runs its next segment
//! from the face it passed, first through the flake itself: that stretch is flake, not
//! binder, and is left out ([`chord`]). A ray passing through a flake by its rim under
//! the `ignore` rim rule is treated as in binder all along (that rule makes the flake
//! transparent).
//!
//! With `α = 0` none of this runs: a clear binder's rays are the same bits as before the
//! absorption existed.

use flakescatter_optics::Vec3;

use crate::grid::Next;
use crate::layer::Flake;

/// The length of the segment that ends at `next`: to the flake hit, or `tau_max` to the
/// top or the substrate; 0 for a segment not traced (`TooLong`, whose weight is cut off).
#[inline(always)]
pub(super) fn length(next: &Next, tau_max: f64) -> f64 {
    match next {
        Next::Flake(h) => h.tau,
        Next::Boundary => tau_max,
        Next::TooLong => 0.0,
    }
}

/// Multiplies the channel weights `(ws, wp)` by `exp(−α ℓ)` for a stretch of `len` µm
/// of binder of coefficient `alpha` (µm⁻¹; a negative `len`, a segment shorter than the
/// flake chord it starts with, counts as 0) and returns the power taken.
#[inline(always)]
pub(super) fn attenuate(alpha: f64, len: f64, ws: &mut f64, wp: &mut f64) -> f64 {
    let keep = (-alpha * len.max(0.0)).exp();
    let (s, p) = (*ws * keep, *wp * keep);
    let taken = (*ws - s) + (*wp - p);
    *ws = s;
    *wp = p;
    taken
}

/// The length of the line `pos + τ k` (unit `k`) inside the solid cylinder of `flake`,
/// from `pos` on one of its faces going into it, µm: the nearer of the opposite face
/// (`t / |k·m|`) and the side wall; 0 without absorption (`alpha = 0`, nothing
/// computed). `pos` may lie on an image of the flake shifted by whole tiles of side
/// `tile` (the nearest image is taken: a tile is wider than any flake).
#[inline(always)]
pub(super) fn chord(alpha: f64, flake: &Flake, pos: &Vec3, k: &Vec3, tile: f64) -> f64 {
    if alpha == 0.0 {
        return 0.0;
    }
    let m = flake.normal.into_inner();
    let mut d = pos - flake.centre;
    d.x -= tile * (d.x / tile).round();
    d.y -= tile * (d.y / tile).round();
    let km = k.dot(&m);
    let slab = if km == 0.0 {
        f64::INFINITY
    } else {
        flake.thickness_um / km.abs()
    };
    // The side wall: |a + s b| = r with a, b the parts of d, k across the axis.
    let a = d - d.dot(&m) * m;
    let b = k - km * m;
    let bb = b.dot(&b);
    if bb <= 0.0 {
        return slab;
    }
    let ab = a.dot(&b);
    let c = a.dot(&a) - flake.radius_um * flake.radius_um;
    let side = (-ab + (ab * ab - bb * c).max(0.0).sqrt()) / bb;
    slab.min(side.max(0.0))
}

#[cfg(test)]
mod tests {
    //! The chord against the geometry of a flat disc: straight down through the middle
    //! crosses the thickness; obliquely near the edge the side wall comes first.

    use flakescatter_optics::{UnitVec3, Vec3};

    use super::{attenuate, chord};
    use crate::layer::Flake;

    fn flat() -> Flake {
        Flake {
            centre: Vec3::new(5.0, 5.0, -3.0),
            normal: UnitVec3::new_normalize(Vec3::z()),
            radius_um: 2.0,
            thickness_um: 0.5,
        }
    }

    #[test]
    fn chords_of_a_flat_disc() {
        let f = flat();
        let top = Vec3::new(5.0, 5.0, -2.75);
        assert!((chord(1.0, &f, &top, &Vec3::new(0.0, 0.0, -1.0), 20.0) - 0.5).abs() < 1e-15);
        // 60° from the axis: t / cos 60° = 1 µm, the wall 2 µm away along x.
        let (s, c) = 60f64.to_radians().sin_cos();
        let k = Vec3::new(s, 0.0, -c);
        assert!((chord(1.0, &f, &top, &k, 20.0) - 1.0).abs() < 1e-12);
        // 0.5 µm from the wall in x: the wall at 0.5 / sin 60°.
        let near = Vec3::new(6.5, 5.0, -2.75);
        assert!((chord(1.0, &f, &near, &k, 20.0) - 0.5 / s).abs() < 1e-12);
        // The same point on the image one tile to the right.
        let image = Vec3::new(26.5, 5.0, -2.75);
        assert!((chord(1.0, &f, &image, &k, 20.0) - 0.5 / s).abs() < 1e-12);
    }

    #[test]
    fn attenuation_is_beer_lambert_and_keeps_the_weight() {
        let (mut ws, mut wp) = (0.3, 0.6);
        let taken = attenuate(0.2, 1.5, &mut ws, &mut wp);
        let keep = (-0.3f64).exp();
        assert!((ws - 0.3 * keep).abs() < 1e-16 && (wp - 0.6 * keep).abs() < 1e-16);
        assert!((taken + ws + wp - 0.9).abs() < 1e-15);
    }
}
