//! Reflectance of a flake surface seen from inside the coating.
//!
//! Conventions: `cos_iota` is the cosine of the local incidence angle `ι` on the flake
//! (`cos ι = γ`, the obliquity of [`crate::reflection::obliquity`]); `n_medium` is the
//! real index of the coating around the flake. A complex flake index `N = n + i k`
//! (aluminium at 550 nm is about `0.96 + 6.69i`) is used relative to the medium,
//! `N/n_medium`, in the exact Fresnel amplitudes for an absorbing medium:
//! `rs = (cos ι − w)/(cos ι + w)`, `rp = (N² cos ι − w)/(N² cos ι + w)`,
//! `w = sqrt(N² − sin² ι)` (principal branch). The paper's assumption is a perfect
//! conductor, `|r|² = 1` for both polarisations.
//!
//! An interference flake ([`FlakeReflectance::Stack`], physics.md §13) is a thin-film
//! stack at one wavelength, in the medium around it (`n_medium` is the ambient on its
//! incidence side and, for a free flake, below it) or on an opaque core. Its amplitudes
//! are the stack's `(r_s, r_p)` in the same convention; the power it transmits
//! (`T = 1 − R − A`) leaves the flake downward and is not part of this reflectance (each
//! model states where it goes).
//!
//! A pile of `N` such free flakes ([`FlakeReflectance::Pile`], physics.md §12.8) sends
//! part of that light back up: its powers are Stokes' pile of plates
//! ([`crate::pile`]), `s` and `p` piled separately. A flake seen through a band of
//! wavelengths ([`FlakeReflectance::Band`], [`crate::band`]) is the power-weighted mean
//! of the same flake at each.

use std::sync::Arc;

use nalgebra::Complex;

use crate::OpticsError;
use crate::band::{BandTable, Linear};
use crate::pile::Plate;
use crate::thinfilm::{FilmStack, Response, solve_unchecked};

/// The most flakes a pile may have ([`FlakeReflectance::pile`]).
pub const MAX_PILE: u32 = 1000;

/// A thin-film flake at one wavelength: its layers (from the side light arrives on),
/// the wavelength, and an opaque core under the layers (`None`: a free flake, the
/// medium around it on both sides). Built, and checked, by [`FlakeReflectance::stack`].
#[derive(Debug, Clone, PartialEq)]
pub struct StackFlake {
    stack: FilmStack,
    wavelength_nm: f64,
    core: Option<Complex<f64>>,
}

impl StackFlake {
    /// The layers.
    #[must_use]
    pub fn stack(&self) -> &FilmStack {
        &self.stack
    }

    /// Vacuum wavelength, nm (> 0, finite).
    #[must_use]
    pub fn wavelength_nm(&self) -> f64 {
        self.wavelength_nm
    }

    /// The core's complex index, or `None` for a free flake.
    #[must_use]
    pub fn core(&self) -> Option<Complex<f64>> {
        self.core
    }
}

/// How a flake reflects.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum FlakeReflectance {
    /// Perfect conductor: `Rs = Rp = 1` (the paper's assumption; the default).
    #[default]
    PerfectConductor,
    /// A metal of complex index `n + i k` relative to vacuum.
    Complex {
        /// Real part of the index.
        n: f64,
        /// Extinction coefficient (imaginary part), `≥ 0`.
        k: f64,
    },
    /// A thin-film (interference) flake at one wavelength.
    Stack(Arc<StackFlake>),
    /// A pile of `N ≥ 2` identical free thin-film flakes, parallel and stacked
    /// incoherently ([`crate::pile`]); built by [`FlakeReflectance::pile`].
    Pile(Arc<FlakePile>),
    /// A flake averaged over a band of wavelengths ([`crate::band`]); built by
    /// [`FlakeReflectance::band`].
    Band(Arc<FlakeBand>),
}

/// A pile of identical free thin-film flakes ([`FlakeReflectance::Pile`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FlakePile {
    /// One flake, seen from above.
    top: StackFlake,
    /// The same flake seen from below (its layers reversed).
    bottom: StackFlake,
    /// The number of flakes, `2..=MAX_PILE`.
    layers: u32,
}

impl FlakePile {
    /// One flake of the pile, seen from above.
    #[must_use]
    pub fn flake(&self) -> &StackFlake {
        &self.top
    }

    /// The number of flakes.
    #[must_use]
    pub fn layers(&self) -> u32 {
        self.layers
    }

    /// The pile's `s` and `p` plates and their cross products at `cos_iota` in a
    /// medium of index `n_medium`: `(s, p, x)`, `x` the sums `Σ a_s a_p*`.
    fn piled(&self, cos_iota: f64, n_medium: f64) -> (Plate, Plate, Plate) {
        let solve = |f: &StackFlake| {
            solve_unchecked(
                f.stack.layers(),
                n_medium,
                Complex::new(n_medium, 0.0),
                cos_iota.clamp(0.0, 1.0),
                f.wavelength_nm,
            )
        };
        let (up, down) = (solve(&self.top), solve(&self.bottom));
        let s = Plate::powers(up.r_s(), up.t_s(), down.r_s(), down.t_s());
        let p = Plate::powers(up.r_p(), up.t_p(), down.r_p(), down.t_p());
        let x = Plate {
            r: up.rs * up.rp.conj(),
            t: transmitted_cross(&up),
            r_back: down.rs * down.rp.conj(),
            t_back: transmitted_cross(&down),
        };
        let n = self.layers;
        (s.pile(n), p.pile(n), x.pile(n))
    }
}

/// `t_s t_p*` scaled to powers: `|·| = sqrt(T_s T_p)` with the phase of `t_s t_p*`
/// (the flux ratios are 1 for a free flake, the same medium on both sides, and 0 at
/// grazing incidence).
fn transmitted_cross(r: &Response) -> Complex<f64> {
    let x = r.ts * r.tp.conj();
    let norm = x.norm();
    if norm == 0.0 {
        return Complex::new(0.0, 0.0);
    }
    x * ((r.t_s() * r.t_p()).sqrt() / norm)
}

impl FlakeReflectance {
    /// A metal flake of complex index `n + i k`.
    ///
    /// # Errors
    /// [`OpticsError::InvalidComplexIndex`] unless `n > 0`, `k ≥ 0`, both finite.
    pub fn complex(n: f64, k: f64) -> Result<Self, OpticsError> {
        if n.is_finite() && k.is_finite() && n > 0.0 && k >= 0.0 {
            Ok(Self::Complex { n, k })
        } else {
            Err(OpticsError::InvalidComplexIndex { n, k })
        }
    }

    /// Aluminium at 550 nm, `0.96 + 6.69i` (physics.md §2).
    #[must_use]
    pub fn aluminium_550nm() -> Self {
        Self::Complex { n: 0.96, k: 6.69 }
    }

    /// Power reflectances `(Rs, Rp)` at local incidence cosine `cos_iota ∈ [0, 1]`
    /// inside a medium of real index `n_medium`.
    #[must_use]
    #[inline]
    pub fn power(&self, cos_iota: f64, n_medium: f64) -> (f64, f64) {
        match self {
            Self::PerfectConductor => (1.0, 1.0),
            Self::Complex { .. } | Self::Stack(_) => {
                let (rs, rp) = self.amplitudes(cos_iota, n_medium);
                (rs.norm_sqr(), rp.norm_sqr())
            }
            Self::Pile(f) => {
                let (s, p, _) = f.piled(cos_iota, n_medium);
                (s.r.re, p.r.re)
            }
            Self::Band(b) => {
                let m = b.at(cos_iota, n_medium);
                (m.rs, m.rp)
            }
        }
    }

    /// The quantities linear in the light's power that a band averages
    /// ([`crate::band`]): `R_s`, `R_p`, `x = r_s r_p*` (a pile's sum over its paths)
    /// and `T_s`, `T_p`.
    pub(crate) fn linear(&self, cos_iota: f64, n_medium: f64) -> Linear {
        match self {
            Self::Pile(f) => {
                let (s, p, x) = f.piled(cos_iota, n_medium);
                Linear {
                    rs: s.r.re,
                    rp: p.r.re,
                    x: x.r,
                    ts: s.t.re,
                    tp: p.t.re,
                }
            }
            Self::Band(b) => b.at(cos_iota, n_medium),
            _ => {
                let (rs, rp) = self.amplitudes(cos_iota, n_medium);
                let (ts, tp) = self.transmitted(cos_iota, n_medium);
                Linear {
                    rs: rs.norm_sqr(),
                    rp: rp.norm_sqr(),
                    x: rs * rp.conj(),
                    ts,
                    tp,
                }
            }
        }
    }

    /// `layers` of these flakes piled (physics.md §12.8): `self` for `layers == 1`, a
    /// [`FlakeReflectance::Pile`] for more.
    ///
    /// # Errors
    /// [`OpticsError::InvalidPile`] for `layers` outside `1..=MAX_PILE`, or more than
    /// one layer of a flake that transmits nothing (a metal, the perfect conductor, a
    /// stack on a core: its pile is the flake itself) or of a pile.
    pub fn pile(&self, layers: u32) -> Result<Self, OpticsError> {
        if !(1..=MAX_PILE).contains(&layers) {
            return Err(OpticsError::InvalidPile(format!(
                "{layers} flake layers: expected a whole number from 1 to {MAX_PILE}"
            )));
        }
        if layers == 1 {
            return Ok(self.clone());
        }
        match self {
            Self::Stack(f) if f.core.is_none() => Ok(Self::Pile(Arc::new(FlakePile {
                top: (**f).clone(),
                bottom: StackFlake {
                    stack: f.stack.reversed(),
                    ..(**f).clone()
                },
                layers,
            }))),
            Self::Band(_) => Err(OpticsError::InvalidPile(format!(
                "{layers} flake layers of a band of wavelengths: pile the flake at each wavelength, then average the piles over the band"
            ))),
            _ => Err(OpticsError::InvalidPile(format!(
                "{layers} flake layers of flakes that transmit nothing (a metal, or a stack on an opaque core): their pile is the top flake itself; piles are of free interference flakes"
            ))),
        }
    }

    /// A thin-film flake: `stack` at `wavelength_nm`, free (`core = None`) or on an
    /// opaque core of index `core`.
    ///
    /// # Errors
    /// [`OpticsError::InvalidComplexIndex`] for a bad core index,
    /// [`OpticsError::InvalidWavelength`] for a wavelength that is not finite and > 0.
    pub fn stack(
        stack: FilmStack,
        wavelength_nm: f64,
        core: Option<Complex<f64>>,
    ) -> Result<Self, OpticsError> {
        if !(wavelength_nm.is_finite() && wavelength_nm > 0.0) {
            return Err(OpticsError::InvalidWavelength(wavelength_nm));
        }
        if let Some(c) = core {
            Self::complex(c.re, c.im)?;
        }
        Ok(Self::Stack(Arc::new(StackFlake {
            stack,
            wavelength_nm,
            core,
        })))
    }

    /// Power transmittances `(Ts, Tp)` through the flake (into the medium below it, or
    /// absorbed by its core): 0 for a metal or perfect conductor.
    #[must_use]
    pub fn transmitted(&self, cos_iota: f64, n_medium: f64) -> (f64, f64) {
        match self {
            Self::PerfectConductor | Self::Complex { .. } => (0.0, 0.0),
            Self::Stack(f) => {
                let r = self.stack_response(f, cos_iota, n_medium);
                (r.t_s(), r.t_p())
            }
            Self::Pile(f) => {
                let (s, p, _) = f.piled(cos_iota, n_medium);
                (s.t.re, p.t.re)
            }
            Self::Band(b) => {
                let m = b.at(cos_iota, n_medium);
                (m.ts, m.tp)
            }
        }
    }

    fn stack_response(
        &self,
        f: &StackFlake,
        cos_iota: f64,
        n_medium: f64,
    ) -> crate::thinfilm::Response {
        let exit = f.core.unwrap_or(Complex::new(n_medium, 0.0));
        solve_unchecked(
            f.stack.layers(),
            n_medium,
            exit,
            cos_iota.clamp(0.0, 1.0),
            f.wavelength_nm,
        )
    }

    /// Amplitude reflection coefficients `(rs, rp)` at local incidence cosine
    /// `cos_iota ∈ [0, 1]` inside a medium of real index `n_medium`, in the convention
    /// of [`crate::jones`] (`p = k × s` for the incoming and the reflected wave, time
    /// dependence `exp(−iωt)`): `(−1, +1)` for the perfect conductor, the module-doc
    /// formulas for a complex index.
    ///
    /// A pile ([`FlakeReflectance::Pile`]) has no amplitudes (its paths add in power);
    /// it returns amplitudes with the pile's `R_s`, `R_p` and `Re Σ a_s a_p*` (and the
    /// sign of its imaginary part), which are all that the first row `(m00, m01)` of a
    /// path's Mueller matrix depends on ([`crate::jones::RayPath::first_row`]): exact
    /// for every unpolarised, `s` and `p` result. A pile depolarises partly, so the
    /// other rows of a full Mueller matrix built from them are not the pile's.
    #[must_use]
    #[inline]
    pub fn amplitudes(&self, cos_iota: f64, n_medium: f64) -> (Complex<f64>, Complex<f64>) {
        match self {
            Self::PerfectConductor => (Complex::new(-1.0, 0.0), Complex::new(1.0, 0.0)),
            &Self::Complex { n, k } => {
                let c = cos_iota.clamp(0.0, 1.0);
                let sin2 = 1.0 - c * c;
                let big_n = Complex::new(n, k) / n_medium;
                let n2 = big_n * big_n;
                let w = (n2 - Complex::new(sin2, 0.0)).sqrt();
                let cc = Complex::new(c, 0.0);
                let rs = (cc - w) / (cc + w);
                let rp = (n2 * cc - w) / (n2 * cc + w);
                (rs, rp)
            }
            Self::Stack(f) => {
                let r = self.stack_response(f, cos_iota, n_medium);
                (r.rs, r.rp)
            }
            Self::Pile(f) => {
                let (s, p, x) = f.piled(cos_iota, n_medium);
                equivalent_amplitudes(s.r.re, p.r.re, x.r)
            }
            Self::Band(b) => {
                let m = b.at(cos_iota, n_medium);
                equivalent_amplitudes(m.rs, m.rp, m.x)
            }
        }
    }

    /// Unpolarised reflectance `(Rs + Rp)/2`.
    #[must_use]
    pub fn average(&self, cos_iota: f64, n_medium: f64) -> f64 {
        let (rs, rp) = self.power(cos_iota, n_medium);
        0.5 * (rs + rp)
    }

    /// Whether this is the perfect conductor (reflectance 1 at every angle).
    #[must_use]
    pub fn is_perfect(&self) -> bool {
        matches!(self, Self::PerfectConductor)
    }
}

/// Amplitudes `(rs, rp)` with `|rs|² = Rs`, `|rp|² = Rp` and `rs rp*` of real part
/// `Re x` and imaginary part of the sign of `Im x`: `rs = √Rs`,
/// `rp = (Re x − i y)/√Rs`, `y = ±√(Rs Rp − (Re x)²)` (≥ 0 by Cauchy–Schwarz, to
/// rounding).
fn equivalent_amplitudes(rs: f64, rp: f64, x: Complex<f64>) -> (Complex<f64>, Complex<f64>) {
    let (rs, rp) = (rs.max(0.0), rp.max(0.0));
    if rs == 0.0 {
        return (Complex::new(0.0, 0.0), Complex::new(rp.sqrt(), 0.0));
    }
    let a = rs.sqrt();
    let y = (rs * rp - x.re * x.re).max(0.0).sqrt().copysign(x.im);
    (Complex::new(a, 0.0), Complex::new(x.re / a, -y / a))
}

/// A flake averaged over a band of wavelengths ([`FlakeReflectance::Band`],
/// [`crate::band`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FlakeBand {
    /// `(w_j, flake at λ_j)`, weights ≥ 0 summing to 1.
    members: Vec<(f64, FlakeReflectance)>,
    table: BandTable,
}

impl FlakeBand {
    /// The members `(weight, flake)`, weights normalised.
    #[must_use]
    pub fn members(&self) -> &[(f64, FlakeReflectance)] {
        &self.members
    }

    /// The index of the medium the tables were built for.
    #[must_use]
    pub fn n_medium(&self) -> f64 {
        self.table.n_medium()
    }

    /// The means at `cos_iota` in a medium of index `n_medium` (tabulated in the
    /// table's medium, summed over the members in another).
    fn at(&self, cos_iota: f64, n_medium: f64) -> Linear {
        if n_medium == self.table.n_medium() {
            self.table.at(cos_iota)
        } else {
            mean_of(&self.members, cos_iota, n_medium)
        }
    }
}

/// The weighted mean of the members' quantities at one cosine.
fn mean_of(members: &[(f64, FlakeReflectance)], cos_iota: f64, n_medium: f64) -> Linear {
    let mut sum = Linear::default();
    for (w, f) in members {
        sum.add(*w, &f.linear(cos_iota, n_medium));
    }
    sum
}

impl FlakeReflectance {
    /// A flake averaged over a band: `members` are `(weight, flake)` pairs (the flake at
    /// each wavelength of the band; weights ≥ 0, not all 0, normalised here), tabulated
    /// for the medium of index `n_medium` (module [`crate::band`]).
    ///
    /// # Errors
    /// [`OpticsError::InvalidBand`] for no member, a weight that is negative or not
    /// finite, weights summing to 0, a member that is itself a band, or an index that
    /// is not finite and ≥ 1.
    pub fn band(members: Vec<(f64, FlakeReflectance)>, n_medium: f64) -> Result<Self, OpticsError> {
        let bad = |why: String| Err(OpticsError::InvalidBand(why));
        if members.is_empty() {
            return bad("no wavelength in the band".into());
        }
        if !(n_medium.is_finite() && n_medium >= 1.0) {
            return bad(format!(
                "medium index {n_medium}: expected a finite index >= 1"
            ));
        }
        if let Some((w, _)) = members.iter().find(|(w, _)| !(w.is_finite() && *w >= 0.0)) {
            return bad(format!("weight {w}: expected a finite weight >= 0"));
        }
        if members.iter().any(|(_, f)| matches!(f, Self::Band(_))) {
            return bad("a band of bands".into());
        }
        let total: f64 = members.iter().map(|(w, _)| w).sum();
        if total <= 0.0 {
            return bad("the weights sum to 0".into());
        }
        let members: Vec<(f64, FlakeReflectance)> =
            members.into_iter().map(|(w, f)| (w / total, f)).collect();
        let table = BandTable::new(n_medium, |c| mean_of(&members, c, n_medium));
        Ok(Self::Band(Arc::new(FlakeBand { members, table })))
    }
}
