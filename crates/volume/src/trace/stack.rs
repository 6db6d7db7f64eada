//! Interference (thin-film) flakes in the volume model (physics.md §10, §13): a flake
//! face that reflects a share `R` and transmits a share `T` of the light, the rest
//! `A = 1 − R − T` absorbed in its layers.
//!
//! # Faces
//! A free stack flake (no core) has the binder on both sides. Its top face (outward
//! normal `m`) sees the stack's layers in the order given (from the incidence side); its
//! bottom face sees them reversed ([`FilmStack::reversed`]). For a lossless stack the
//! two faces have the same `R` and `T`; with absorbing layers `R` differs between the
//! faces (`T` does not). A flake on an opaque core is not handled here: the light it
//! transmits goes into the core, which absorbs it, so it reflects like a metal flake
//! (`R` of the stack on the core, the rest `absorbed_flakes`) and both of its faces
//! carry the same layers.
//!
//! # The split (one path per ray)
//! At a hit the ray's channel weights `(w_s, w_p)` give the reflected power
//! `a_R = w_s R_s + w_p R_p`, the transmitted power `a_T = w_s T_s + w_p T_p`, and the
//! absorbed power `w_s (1 − R_s − T_s) + w_p (1 − R_p − T_p)`, which is tallied at
//! once. One uniform draw `u` of the ray's generator picks reflection when
//! `u (a_R + a_T) < a_R`, else transmission. The chosen branch carries the channel
//! weights `w_c R_c (a_R + a_T)/a_R` (reflection) or `w_c T_c (a_R + a_T)/a_T`
//! (transmission), so that the expected weight of each channel after the hit is
//! `w_c (R_c + T_c)`, the exact share (unbiased), and every ray keeps its total weight
//! (absorbed + carried = `w_s + w_p` to rounding): the energy balance sums to 1 as for
//! metal flakes. Metal flakes draw nothing here, so their rays' random numbers are
//! unchanged.
//!
//! # The transmitted ray
//! A free flake has the same medium on both sides, so the transmitted ray keeps its
//! direction. It goes on along the incident line from the hit point, crosses the
//! flake's geometric thickness `t` (a path `t / cos ι` inside it) and leaves through the
//! other face (or through the rim, near the edge), where the incident line leaves the
//! solid cylinder: **lateral shift 0** with respect to the incident line. A real stack
//! of total thickness `d` refracts the light inside and shifts it by
//! `d sin ι (1 − cos ι/(n_j cos ι_j))` in a layer of index `n_j`, less than `d` (below
//! 1 µm for the pigments of §13, against flake diameters of 5–30 µm); that shift is
//! neglected, as the stack's phase is already in `R` and `T`.

use flakescatter_optics::flake::FlakeReflectance;

/// The two faces of a free stack flake.
#[derive(Debug, Clone)]
pub(super) struct StackFaces {
    /// The top face (outward normal `m`): the stack as given.
    top: FlakeReflectance,
    /// The bottom face (outward normal `−m`): the stack reversed.
    bottom: FlakeReflectance,
}

/// What a hit on a stack face does to a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Split {
    /// Power absorbed in the layers (for `absorbed_flakes`).
    pub(super) absorbed: f64,
    /// The s weight carried on.
    pub(super) ws: f64,
    /// The p weight carried on.
    pub(super) wp: f64,
    /// Whether the ray goes through the flake (`false`: it is reflected).
    pub(super) transmitted: bool,
}

impl StackFaces {
    /// The faces of `flake` when it is a free stack (no core); `None` for every flake
    /// that transmits nothing out of itself (metals, the perfect conductor, a stack on a
    /// core), which the ray rules treat as today.
    pub(super) fn of(flake: &FlakeReflectance) -> Option<Self> {
        match flake {
            FlakeReflectance::Stack(f) if f.core().is_none() => {
                let bottom =
                    FlakeReflectance::stack(f.stack().reversed(), f.wavelength_nm(), None).ok()?;
                Some(Self {
                    top: flake.clone(),
                    bottom,
                })
            }
            _ => None,
        }
    }

    /// The split of a ray with channel weights `(ws, wp)` meeting the top
    /// (`top = true`) or bottom face at local incidence cosine `cos_iota` in a binder of
    /// index `n`, with `u` a uniform draw in `[0, 1)` (module docs).
    pub(super) fn split(
        &self,
        top: bool,
        cos_iota: f64,
        n: f64,
        ws: f64,
        wp: f64,
        u: f64,
    ) -> Split {
        let face = if top { &self.top } else { &self.bottom };
        let (rs, rp) = face.power(cos_iota, n);
        let (ts, tp) = face.transmitted(cos_iota, n);
        let absorbed = ws * (1.0 - rs - ts) + wp * (1.0 - rp - tp);
        let a_r = ws * rs + wp * rp;
        let a_t = ws * ts + wp * tp;
        let s = a_r + a_t;
        if s.is_nan() || s <= 0.0 {
            return Split {
                absorbed: ws + wp,
                ws: 0.0,
                wp: 0.0,
                transmitted: false,
            };
        }
        if u * s < a_r {
            let f = s / a_r;
            Split {
                absorbed,
                ws: ws * rs * f,
                wp: wp * rp * f,
                transmitted: false,
            }
        } else {
            let f = s / a_t;
            Split {
                absorbed,
                ws: ws * ts * f,
                wp: wp * tp * f,
                transmitted: true,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! The split's expectation per channel is `w (R + T)` and every branch keeps the
    //! ray's weight: checked by averaging the two branches with their probabilities.

    use flakescatter_optics::flake::FlakeReflectance;
    use flakescatter_optics::nalgebra::Complex;
    use flakescatter_optics::thinfilm::{FilmStack, Layer};

    use super::StackFaces;

    fn absorbing_asymmetric() -> FlakeReflectance {
        let stack = FilmStack::new(vec![
            Layer::new(Complex::new(2.6, 0.3), 80.0).unwrap(),
            Layer::new(Complex::new(1.6, 0.0), 300.0).unwrap(),
        ])
        .unwrap();
        FlakeReflectance::stack(stack, 550.0, None).unwrap()
    }

    #[test]
    fn the_split_is_unbiased_and_keeps_the_weight() {
        let flake = absorbing_asymmetric();
        let faces = StackFaces::of(&flake).unwrap();
        let (ws, wp) = (0.3, 0.55);
        for top in [true, false] {
            for c in [1.0, 0.8, 0.3, 0.05] {
                let face = if top {
                    flake.clone()
                } else {
                    FlakeReflectance::stack(
                        match &flake {
                            FlakeReflectance::Stack(f) => f.stack().reversed(),
                            _ => unreachable!(),
                        },
                        550.0,
                        None,
                    )
                    .unwrap()
                };
                let (rs, rp) = face.power(c, 1.5);
                let (ts, tp) = face.transmitted(c, 1.5);
                let p_r = (ws * rs + wp * rp) / (ws * (rs + ts) + wp * (rp + tp));
                let r = faces.split(top, c, 1.5, ws, wp, 0.0);
                let t = faces.split(top, c, 1.5, ws, wp, 1.0 - 1e-16);
                assert!(!r.transmitted && t.transmitted);
                let es = p_r * r.ws + (1.0 - p_r) * t.ws;
                let ep = p_r * r.wp + (1.0 - p_r) * t.wp;
                assert!((es - ws * (rs + ts)).abs() < 1e-15);
                assert!((ep - wp * (rp + tp)).abs() < 1e-15);
                for b in [r, t] {
                    assert!((b.absorbed + b.ws + b.wp - (ws + wp)).abs() < 1e-15);
                }
            }
        }
        // The absorbing asymmetric stack reflects differently from its two sides.
        let top = faces.split(true, 1.0, 1.5, 0.5, 0.5, 0.0);
        let bottom = faces.split(false, 1.0, 1.5, 0.5, 0.5, 0.0);
        assert!((top.absorbed - bottom.absorbed).abs() > 1e-3);
    }

    #[test]
    fn metals_and_cored_stacks_have_no_faces_here() {
        assert!(StackFaces::of(&FlakeReflectance::PerfectConductor).is_none());
        assert!(StackFaces::of(&FlakeReflectance::aluminium_550nm()).is_none());
        let stack =
            FilmStack::new(vec![Layer::new(Complex::new(2.6, 0.0), 80.0).unwrap()]).unwrap();
        let cored = FlakeReflectance::stack(stack, 550.0, Some(Complex::new(0.96, 6.69))).unwrap();
        assert!(StackFaces::of(&cored).is_none());
    }
}
