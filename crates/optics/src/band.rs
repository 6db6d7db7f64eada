//! A flake seen through a colour channel's band of wavelengths
//! ([`crate::flake::FlakeReflectance::Band`], physics.md §12.7 "Channels with a band").
//!
//! A camera or a colour channel integrates over a band of wavelengths, and light of
//! different wavelengths adds in power. A band flake is the weighted mean of its members
//! (the same flake at the band's wavelengths, weights `w_j ≥ 0` summing to 1) in every
//! quantity a model takes of a flake that is linear in the light's power: the
//! reflectances `R_s`, `R_p`, the cross product `x = r_s r_p*` (all that the first row
//! of a path's Mueller matrix depends on, [`crate::jones::RayPath::first_row`]) and the
//! transmittances `T_s`, `T_p`. Its amplitudes are the equivalent amplitudes of those
//! means (as a pile's, [`crate::flake`]): exact for every unpolarised, `s` and `p`
//! result; a band depolarises partly, so the other rows of a Mueller matrix built from
//! them are not the band's. By Cauchy–Schwarz `|mean x|² ≤ mean R_s · mean R_p` for
//! non-negative weights, so the means are those of a physical (partially polarising)
//! reflector.
//!
//! Numerics: the means are tabulated at [`BAND_NODES`] local cosines `cos ι ∈ [0, 1]`
//! (uniform) in the medium the band was built for and read linearly; in another medium
//! they are summed over the members directly.

use std::sync::Arc;

use nalgebra::Complex;

use crate::OpticsError;
use crate::flake::FlakeReflectance;

/// Local-cosine nodes of a band's tables.
pub const BAND_NODES: usize = 2049;

/// The quantities of one flake at one local cosine that a band averages.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Linear {
    pub(crate) rs: f64,
    pub(crate) rp: f64,
    pub(crate) x: Complex<f64>,
    pub(crate) ts: f64,
    pub(crate) tp: f64,
}

impl Linear {
    fn add(&mut self, w: f64, o: &Self) {
        self.rs += w * o.rs;
        self.rp += w * o.rp;
        self.x += o.x * w;
        self.ts += w * o.ts;
        self.tp += w * o.tp;
    }

    fn lerp(a: &Self, b: &Self, f: f64) -> Self {
        let l = |u: f64, v: f64| u + f * (v - u);
        Self {
            rs: l(a.rs, b.rs),
            rp: l(a.rp, b.rp),
            x: Complex::new(l(a.x.re, b.x.re), l(a.x.im, b.x.im)),
            ts: l(a.ts, b.ts),
            tp: l(a.tp, b.tp),
        }
    }
}

/// A flake averaged over a band of wavelengths (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct FlakeBand {
    /// `(w_j, flake at λ_j)`, weights ≥ 0 summing to 1.
    members: Vec<(f64, FlakeReflectance)>,
    /// The medium the tables are for.
    n_medium: f64,
    /// The means at `BAND_NODES` uniform cosines.
    table: Vec<Linear>,
}

impl FlakeBand {
    /// The members `(weight, flake)`.
    #[must_use]
    pub fn members(&self) -> &[(f64, FlakeReflectance)] {
        &self.members
    }

    /// The index of the medium the tables were built for.
    #[must_use]
    pub fn n_medium(&self) -> f64 {
        self.n_medium
    }

    /// The means at `cos_iota` in a medium of index `n_medium`.
    pub(crate) fn at(&self, cos_iota: f64, n_medium: f64) -> Linear {
        if n_medium != self.n_medium {
            return mean_of(&self.members, cos_iota, n_medium);
        }
        let last = BAND_NODES - 1;
        let t = cos_iota.clamp(0.0, 1.0) * last as f64;
        let i = (t.floor() as usize).min(last - 1);
        Linear::lerp(&self.table[i], &self.table[i + 1], t - i as f64)
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
    pub fn band(
        members: Vec<(f64, FlakeReflectance)>,
        n_medium: f64,
    ) -> Result<Self, OpticsError> {
        let bad = |why: String| Err(OpticsError::InvalidBand(why));
        if members.is_empty() {
            return bad("no wavelength in the band".into());
        }
        if !(n_medium.is_finite() && n_medium >= 1.0) {
            return bad(format!("medium index {n_medium}: expected a finite index >= 1"));
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
        let table = (0..BAND_NODES)
            .map(|i| mean_of(&members, i as f64 / (BAND_NODES - 1) as f64, n_medium))
            .collect();
        Ok(Self::Band(Arc::new(FlakeBand {
            members,
            n_medium,
            table,
        })))
    }
}
