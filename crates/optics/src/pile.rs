//! A pile of identical, parallel, thin flakes stacked incoherently (Stokes' pile of
//! plates; physics.md §12.8).
//!
//! Flakes in a paint are microns apart, far more than the coherence length of daylight
//! over a camera channel, so the light bounced between two flakes adds in power, not in
//! amplitude; inside one flake (a thin-film stack, [`crate::thinfilm`]) the multiple
//! reflections stay coherent and are in its `r`, `t`.
//!
//! **Recursion.** A plate (or a pile) is described, for one polarisation, by its
//! reflectance `R` and transmittance `T` from above and `R'`, `T'` from below. Put pile
//! `A` on pile `B`. Light from above is reflected by `A` (`R_A`), or transmitted by `A`
//! (`T_A`), reflected by `B` (`R_B`), then either leaves up through `A` (`T'_A`) or is
//! reflected back down by `A`'s underside (`R'_A`) to meet `B` again, and so on; summing
//! the powers of all these paths (a geometric series in `R'_A R_B < 1`):
//!
//! `R_AB = R_A + T_A T'_A R_B / (1 − R'_A R_B)`, `T_AB = T_A T_B / (1 − R'_A R_B)`,
//!
//! and from below, by the same argument with the roles swapped,
//!
//! `R'_AB = R'_B + T'_B T_B R'_A / (1 − R_B R'_A)`, `T'_AB = T'_B T'_A / (1 − R_B R'_A)`.
//!
//! The composition is associative, so `N` plates are the plate composed with itself
//! `N − 1` times, done here by repeated squaring (`O(log N)` steps). An opaque plate
//! (`T = 0`) gives `R_N = R`; a lossless symmetric plate `R_N = N R / (1 + (N − 1) R)`.
//!
//! **Polarisation.** The plates are parallel, so the plane of incidence and the `(s, p)`
//! basis are the same at every bounce and each path's Jones matrix is diagonal: `s` and
//! `p` are piled separately (a pile of plates polarises, so averaging first would be
//! wrong). A path's `s` and `p` amplitudes stay coherent with each other, so the pile's
//! cross term `X = Σ_paths a_s a_p*` (the `m22`, `m23` elements of its Mueller matrix,
//! which the path factor through a tilted flake needs, physics.md §11) follows the same
//! recursion with the complex products `r_s r_p*`, `t_s t_p*` of each plate in place of
//! the powers: every path's `a_s a_p*` is the product of its events'. [`Plate`] holds
//! complex numbers so that one recursion serves both (powers have no imaginary part).

use nalgebra::Complex;

type C = Complex<f64>;

/// A plate or a pile for one polarisation (or, with complex values, the `s`–`p` cross
/// products): reflectance and transmittance from above and from below (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plate {
    /// Reflectance from above, `R` (or `Σ r_s r_p*`).
    pub r: C,
    /// Transmittance from above, `T`.
    pub t: C,
    /// Reflectance from below, `R'`.
    pub r_back: C,
    /// Transmittance from below, `T'`.
    pub t_back: C,
}

impl Plate {
    /// A plate of real powers: `r`, `t` from above and `r_back`, `t_back` from below.
    #[must_use]
    pub fn powers(r: f64, t: f64, r_back: f64, t_back: f64) -> Self {
        Self {
            r: C::new(r, 0.0),
            t: C::new(t, 0.0),
            r_back: C::new(r_back, 0.0),
            t_back: C::new(t_back, 0.0),
        }
    }

    /// `self` on top of `below` (module docs). Two faces that reflect everything
    /// (`R'_A R_B = 1`: flakes met at grazing incidence) transmit nothing, so nothing
    /// bounces between them: the series is taken as 0 there, where every term that
    /// uses it has a factor `T = 0`.
    #[must_use]
    pub fn on(&self, below: &Self) -> Self {
        let (a, b) = (self, below);
        let one = C::new(1.0, 0.0);
        // The bounces between A's underside and B's top: 1/(1 − R'_A R_B).
        let den = one - a.r_back * b.r;
        let g = if den == C::new(0.0, 0.0) {
            den
        } else {
            one / den
        };
        Self {
            r: a.r + a.t * a.t_back * b.r * g,
            t: a.t * b.t * g,
            r_back: b.r_back + b.t_back * b.t * a.r_back * g,
            t_back: b.t_back * a.t_back * g,
        }
    }

    /// `n ≥ 1` copies of `self` piled (`n = 0` is read as 1), by repeated squaring.
    #[must_use]
    pub fn pile(&self, n: u32) -> Self {
        let mut result = *self;
        let (mut base, mut k) = (*self, n.max(1) - 1);
        // result = self^(1 + k): multiply in base^(2^j) for each bit j of k. The
        // composition is associative and all factors are powers of one plate, so the
        // order does not matter.
        while k > 0 {
            if k & 1 == 1 {
                result = result.on(&base);
            }
            k >>= 1;
            if k > 0 {
                base = base.on(&base);
            }
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_plate_is_itself_and_two_is_the_series() {
        let p = Plate::powers(0.3, 0.6, 0.25, 0.6);
        assert_eq!(p.pile(1), p);
        // Two plates written out: R + T T' R / (1 − R' R).
        let two = p.pile(2);
        let r2 = 0.3 + 0.6 * 0.6 * 0.3 / (1.0 - 0.25 * 0.3);
        assert!((two.r.re - r2).abs() < 1e-15);
        // 5 = 4 + 1 and 3 + 2 give the same pile (associativity).
        let a = p.pile(4).on(&p);
        let b = p.pile(3).on(&p.pile(2));
        assert!((a.r - b.r).norm() < 1e-14 && (a.t - b.t).norm() < 1e-14);
        assert!((p.pile(5).r - a.r).norm() < 1e-14);
    }

    #[test]
    fn mirrors_at_grazing_incidence_stay_finite() {
        let p = Plate::powers(1.0, 0.0, 1.0, 0.0).pile(5);
        assert_eq!((p.r.re, p.t.re), (1.0, 0.0));
        let x = Plate {
            r: C::new(-1.0, 0.0),
            t: C::new(0.0, 0.0),
            r_back: C::new(-1.0, 0.0),
            t_back: C::new(0.0, 0.0),
        }
        .pile(3);
        assert_eq!(x.r, C::new(-1.0, 0.0));
    }

    #[test]
    fn an_opaque_plate_is_its_own_pile() {
        let p = Plate::powers(0.9, 0.0, 0.5, 0.0);
        assert_eq!(p.pile(7).r, p.r);
        assert_eq!(p.pile(7).t, C::new(0.0, 0.0));
    }
}
