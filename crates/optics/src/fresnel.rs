//! Fresnel coefficients of the flat clear-coat surface (a lossless dielectric).
//!
//! Conventions: `n ≥ 1` is the coating index relative to air. Angles are radians from
//! the surface normal, `θi` on the air side and `θt` inside, related by Snell's law
//! `sin θi = n sin θt`. Amplitude coefficients use the Fresnel convention of Born & Wolf
//! (`rs`, `rp` as in physics.md §2):
//!
//! * `rs = (cos θi − n cos θt)/(cos θi + n cos θt)`, `rp = (n cos θi − cos θt)/(n cos θi + cos θt)`;
//! * `ts = 2 cos θi/(cos θi + n cos θt)`, `tp = 2 cos θi/(n cos θi + cos θt)`.
//!
//! Power coefficients: `Rs = rs²`, `Rp = rp²`, and the power transmittances are computed
//! from the transmitted amplitudes with the beam cross-section and index factor,
//! `Ts = (n cos θt / cos θi) ts²`, `Tp = (n cos θt / cos θi) tp²`, so that `R + T = 1`
//! is a property of the formulas, not a definition. The same power transmittance holds
//! for the reverse crossing at the Snell-related pair of angles (reciprocity).

use crate::refraction;

/// Power reflectance and transmittance for s and p polarisation at one crossing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FresnelPower {
    /// Power reflectance, s (TE) polarisation.
    pub rs: f64,
    /// Power reflectance, p (TM) polarisation.
    pub rp: f64,
    /// Power transmittance, s polarisation.
    pub ts: f64,
    /// Power transmittance, p polarisation.
    pub tp: f64,
}

impl FresnelPower {
    /// Unpolarised reflectance `R_av = (Rs + Rp)/2`.
    #[must_use]
    pub fn r_av(&self) -> f64 {
        0.5 * (self.rs + self.rp)
    }

    /// Unpolarised transmittance `T_av = (Ts + Tp)/2` (paper eq. 10).
    #[must_use]
    pub fn t_av(&self) -> f64 {
        0.5 * (self.ts + self.tp)
    }
}

/// Fresnel amplitude coefficients `(rs, rp, ts, tp)` for light in air meeting the
/// coating at `theta_i ∈ [0, π/2]`.
#[must_use]
pub fn amplitudes_air_to_coating(theta_i: f64, n: f64) -> [f64; 4] {
    let ci = theta_i.cos();
    let ct = refraction::snell_inside(theta_i, n).cos();
    amplitudes_from_cosines(ci, ct, n)
}

/// Amplitudes for the air-side cosine `ci` and inside cosine `ct` (Snell-related).
fn amplitudes_from_cosines(ci: f64, ct: f64, n: f64) -> [f64; 4] {
    let ds = ci + n * ct;
    let dp = n * ci + ct;
    [
        (ci - n * ct) / ds,
        (n * ci - ct) / dp,
        2.0 * ci / ds,
        2.0 * ci / dp,
    ]
}

/// Power coefficients for the Snell-related pair of cosines (`ci` air side, `ct`
/// inside). At grazing incidence (`ci = 0`) everything is reflected.
#[must_use]
pub fn power_from_cosines(ci: f64, ct: f64, n: f64) -> FresnelPower {
    if ci <= 0.0 {
        return FresnelPower {
            rs: 1.0,
            rp: 1.0,
            ts: 0.0,
            tp: 0.0,
        };
    }
    let [rs, rp, ts, tp] = amplitudes_from_cosines(ci, ct, n);
    let beam = n * ct / ci;
    FresnelPower {
        rs: rs * rs,
        rp: rp * rp,
        ts: beam * ts * ts,
        tp: beam * tp * tp,
    }
}

/// Power coefficients for light in air meeting the coating at `theta_i ∈ [0, π/2]`.
#[must_use]
pub fn air_to_coating(theta_i: f64, n: f64) -> FresnelPower {
    let ct = refraction::snell_inside(theta_i, n).cos();
    power_from_cosines(theta_i.cos(), ct, n)
}

/// Power coefficients for light inside the coating meeting the surface at
/// `theta_inside`, or `None` beyond the critical angle `asin(1/n)` (total internal
/// reflection). By reciprocity the transmittances equal those of
/// [`air_to_coating`] at the outside angle; the reflectances are those seen from inside.
#[must_use]
pub fn coating_to_air(theta_inside: f64, n: f64) -> Option<FresnelPower> {
    let theta_o = refraction::snell_outside(theta_inside, n)?;
    Some(power_from_cosines(theta_o.cos(), theta_inside.cos(), n))
}

/// The paper's printed eq. 10 for the average transmittance of the crossing at air
/// angle `theta_i` (coating angle `θt` from Snell's law):
///
/// `T_av = sin 2θi sin 2θt [1 + cos²(θi − θt)] / (2 sin²(θi + θt) cos²(θi − θt))`.
///
/// The printed form is 0/0 at normal incidence; there (`θi < 1e-8`) its limit
/// `4n/(n+1)²` is returned. Elsewhere it agrees with `(Ts + Tp)/2` to rounding.
#[must_use]
pub fn t_av_printed(theta_i: f64, n: f64) -> f64 {
    if theta_i.abs() < 1e-8 {
        return 4.0 * n / ((n + 1.0) * (n + 1.0));
    }
    let theta_t = refraction::snell_inside(theta_i, n);
    let sum = theta_i + theta_t;
    let diff = theta_i - theta_t;
    let c2 = diff.cos() * diff.cos();
    (2.0 * theta_i).sin() * (2.0 * theta_t).sin() * (1.0 + c2) / (2.0 * sum.sin() * sum.sin() * c2)
}
