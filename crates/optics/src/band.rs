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

use nalgebra::Complex;

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
    pub(crate) fn add(&mut self, w: f64, o: &Self) {
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

/// The means of a band tabulated at [`BAND_NODES`] uniform local cosines for one
/// medium (module docs).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BandTable {
    n_medium: f64,
    table: Vec<Linear>,
}

impl BandTable {
    /// The table of `mean(cos ι)` for the medium of index `n_medium`.
    pub(crate) fn new(n_medium: f64, mean: impl Fn(f64) -> Linear) -> Self {
        let table = (0..BAND_NODES)
            .map(|i| mean(i as f64 / (BAND_NODES - 1) as f64))
            .collect();
        Self { n_medium, table }
    }

    /// The medium's index.
    pub(crate) fn n_medium(&self) -> f64 {
        self.n_medium
    }

    /// The means at `cos_iota`, read linearly.
    pub(crate) fn at(&self, cos_iota: f64) -> Linear {
        let last = BAND_NODES - 1;
        let t = cos_iota.clamp(0.0, 1.0) * last as f64;
        let i = (t.floor() as usize).min(last - 1);
        Linear::lerp(&self.table[i], &self.table[i + 1], t - i as f64)
    }
}
