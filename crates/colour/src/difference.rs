//! Colour differences between two CIELAB colours: ΔE*ab (CIE 1976), ΔE*94 (CIE 116-1995)
//! and ΔE00 (CIEDE2000, CIE 142-2001, as written out by Sharma, Wu and Dalal 2005).
//!
//! Conventions: inputs are CIELAB of the same illuminant and observer; differences are
//! in CIELAB units. ΔE*94 is not symmetric: its weights use the chroma of the first
//! argument, the **reference** (standard); the other two are symmetric. Hue angles
//! inside the formulas are handled in degrees, as the published formulas are written.
//!
//! **Range.** For any two finite CIELAB colours the differences are finite numbers (or
//! `+∞` where the difference itself exceeds the largest double), never NaN and never a
//! spurious 0: the few steps that square or raise a chroma to the 7th power (which
//! overflow above `|x| ≈ 1e154` and `C ≈ 1e44`) are taken in scaled form there, and only
//! there, so results in the ordinary range are bit for bit those of the formulas as
//! published. Colours from spectra ([`crate::TristimulusWeights::lab`]) reach
//! `L* ≈ 1.4e104`, `|a*|, |b*|` of the same order.

use crate::lab::Lab;

/// CIE 1976 colour difference `ΔE*ab = √(ΔL*² + Δa*² + Δb*²)`.
#[must_use]
pub fn delta_e_ab(reference: &Lab, sample: &Lab) -> f64 {
    let (dl, da, db) = (
        sample.l - reference.l,
        sample.a - reference.a,
        sample.b - reference.b,
    );
    norm3(dl, da, db)
}

/// `√(x² + y² + z²)`, scaled by the largest magnitude when the squares would overflow or
/// underflow (module docs, "Range").
fn norm3(x: f64, y: f64, z: f64) -> f64 {
    let s = x * x + y * y + z * z;
    if s.is_finite() && s >= f64::MIN_POSITIVE {
        return s.sqrt();
    }
    let m = x.abs().max(y.abs()).max(z.abs());
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    let (x, y, z) = (x / m, y / m, z / m);
    m * (x * x + y * y + z * z).sqrt()
}

/// Parametric factors and constants of ΔE*94.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cie94 {
    /// Lightness parametric factor `kL`.
    pub k_l: f64,
    /// Chroma parametric factor `kC`.
    pub k_c: f64,
    /// Hue parametric factor `kH`.
    pub k_h: f64,
    /// Chroma weighting constant `K1` in `SC = 1 + K1 C*ref`.
    pub k1: f64,
    /// Hue weighting constant `K2` in `SH = 1 + K2 C*ref`.
    pub k2: f64,
}

impl Cie94 {
    /// The CIE 116-1995 reference conditions ("graphic arts"): `kL = kC = kH = 1`,
    /// `K1 = 0.045`, `K2 = 0.015`. The default.
    pub const GRAPHIC_ARTS: Self = Self {
        k_l: 1.0,
        k_c: 1.0,
        k_h: 1.0,
        k1: 0.045,
        k2: 0.015,
    };
    /// The textiles variant: `kL = 2`, `kC = kH = 1`, `K1 = 0.048`, `K2 = 0.014`.
    pub const TEXTILES: Self = Self {
        k_l: 2.0,
        k_c: 1.0,
        k_h: 1.0,
        k1: 0.048,
        k2: 0.014,
    };
}

impl Default for Cie94 {
    fn default() -> Self {
        Self::GRAPHIC_ARTS
    }
}

/// CIE 1994 colour difference ΔE*94 of `sample` from `reference` with the constants
/// `params` ([`Cie94::GRAPHIC_ARTS`] by default):
/// `√((ΔL*/(kL SL))² + (ΔC*/(kC SC))² + (ΔH*/(kH SH))²)`, `SL = 1`,
/// `SC = 1 + K1 C*ref`, `SH = 1 + K2 C*ref`, `ΔH*² = Δa*² + Δb*² − ΔC*²`.
#[must_use]
pub fn delta_e_94(reference: &Lab, sample: &Lab, params: Cie94) -> f64 {
    let c_ref = reference.chroma();
    let dl = sample.l - reference.l;
    let dc = sample.chroma() - c_ref;
    let (da, db) = (sample.a - reference.a, sample.b - reference.b);
    let sc = 1.0 + params.k1 * c_ref;
    let sh = 1.0 + params.k2 * c_ref;
    let tl = dl / params.k_l;
    let tc = dc / (params.k_c * sc);
    // ΔH*² can come out a rounding error below zero when the hue difference vanishes.
    let dh2 = da * da + db * db - dc * dc;
    // `(kH SH)²` overflows for C*ab above about 1e154, where dividing by it would
    // drop the hue term to a spurious 0: then the scaled path below.
    let sh2 = (params.k_h * sh).powi(2);
    if dh2.is_finite() && sh2.is_finite() {
        let th2 = if dh2 < 0.0 { 0.0 } else { dh2 } / sh2;
        let s = tl * tl + tc * tc + th2;
        if s.is_finite() {
            return s.sqrt();
        }
    }
    // The squares overflow (module docs, "Range"): ΔH* from the differences scaled by
    // the largest of them, then the three terms as a scaled norm.
    let m = da.abs().max(db.abs()).max(dc.abs());
    let dh = if m == 0.0 || !m.is_finite() {
        m
    } else {
        let (ua, ub, uc) = (da / m, db / m, dc / m);
        m * (ua * ua + ub * ub - uc * uc).max(0.0).sqrt()
    };
    norm3(tl, tc, dh / (params.k_h * sh))
}

/// Parametric factors of CIEDE2000 (`kL = kC = kH = 1` are the reference conditions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ciede2000 {
    /// Lightness parametric factor `kL`.
    pub k_l: f64,
    /// Chroma parametric factor `kC`.
    pub k_c: f64,
    /// Hue parametric factor `kH`.
    pub k_h: f64,
}

impl Default for Ciede2000 {
    fn default() -> Self {
        Self {
            k_l: 1.0,
            k_c: 1.0,
            k_h: 1.0,
        }
    }
}

/// CIEDE2000 colour difference ΔE00 with the reference parametric factors.
#[must_use]
pub fn delta_e_2000(reference: &Lab, sample: &Lab) -> f64 {
    delta_e_2000_with(reference, sample, Ciede2000::default())
}

/// CIEDE2000 colour difference ΔE00 with parametric factors `k`, following eqs. (1)–(17)
/// of Sharma, Wu and Dalal (2005). Where the two hues are exactly opposite
/// (`|h'1 − h'2| = 180°`), the mean hue is `(h'1 + h'2)/2`, the branch their test data
/// use; a difference within 1e-9° of 180° counts as exactly 180° so that rounding in
/// `atan2` does not decide the branch.
#[must_use]
pub fn delta_e_2000_with(reference: &Lab, sample: &Lab, k: Ciede2000) -> f64 {
    let (l1, a1, b1) = (reference.l, reference.a, reference.b);
    let (l2, a2, b2) = (sample.l, sample.a, sample.b);
    let c_mean = 0.5 * a1.hypot(b1) + 0.5 * a2.hypot(b2);
    let g = 0.5 * (1.0 - chroma_weight(c_mean));
    let a1p = (1.0 + g) * a1;
    let a2p = (1.0 + g) * a2;
    let c1p = a1p.hypot(b1);
    let c2p = a2p.hypot(b2);
    let h1p = hue_deg(a1p, b1);
    let h2p = hue_deg(a2p, b2);

    let dlp = l2 - l1;
    let dcp = c2p - c1p;
    // Zero when either chroma is; √(C'1 C'2) in factors where the product overflows.
    let product = c1p * c2p;
    let root = if product.is_finite() {
        product.sqrt()
    } else {
        c1p.sqrt() * c2p.sqrt()
    };
    let dhp = if product == 0.0 {
        0.0
    } else {
        let d = h2p - h1p;
        if d > 180.0 {
            d - 360.0
        } else if d < -180.0 {
            d + 360.0
        } else {
            d
        }
    };
    let dhp_big = 2.0 * root * (0.5 * dhp).to_radians().sin();

    let lp_mean = 0.5 * l1 + 0.5 * l2;
    let cp_mean = 0.5 * c1p + 0.5 * c2p;
    let hp_mean = if product == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= 180.0 + 1e-9 {
        0.5 * (h1p + h2p)
    } else if h1p + h2p < 360.0 {
        0.5 * (h1p + h2p + 360.0)
    } else {
        0.5 * (h1p + h2p - 360.0)
    };
    let cos_deg = |x: f64| x.to_radians().cos();
    let t = 1.0 - 0.17 * cos_deg(hp_mean - 30.0)
        + 0.24 * cos_deg(2.0 * hp_mean)
        + 0.32 * cos_deg(3.0 * hp_mean + 6.0)
        - 0.20 * cos_deg(4.0 * hp_mean - 63.0);
    let d_theta = 30.0 * (-((hp_mean - 275.0) / 25.0).powi(2)).exp();
    let r_c = 2.0 * chroma_weight(cp_mean);
    let l50 = (lp_mean - 50.0).powi(2);
    let s_l = if l50.is_finite() {
        1.0 + 0.015 * l50 / (20.0 + l50).sqrt()
    } else {
        // (L̄ − 50)² / √(20 + (L̄ − 50)²) = |L̄ − 50| to the last digit there.
        1.0 + 0.015 * (lp_mean - 50.0).abs()
    };
    let s_c = 1.0 + 0.045 * cp_mean;
    let s_h = 1.0 + 0.015 * cp_mean * t;
    let r_t = -(2.0 * d_theta).to_radians().sin() * r_c;

    let tl = dlp / (k.k_l * s_l);
    let tc = dcp / (k.k_c * s_c);
    let th = dhp_big / (k.k_h * s_h);
    // In units of m (1, or the largest term where the squares overflow). Rounding can
    // leave the sum a hair below zero; NaN is never turned into 0.
    let root = |m: f64| {
        let (tl, tc, th) = (tl / m, tc / m, th / m);
        let sum = tl * tl + tc * tc + th * th + r_t * tc * th;
        m * if sum < 0.0 { 0.0 } else { sum.sqrt() }
    };
    let d = root(1.0);
    let m = tl.abs().max(tc.abs()).max(th.abs());
    if d.is_finite() || !m.is_finite() {
        d
    } else {
        root(m)
    }
}

/// `√(C⁷/(C⁷ + 25⁷))` of CIEDE2000's G and R_C, as `√(1/(1 + (25/C)⁷))` where `C⁷`
/// overflows (module docs, "Range").
fn chroma_weight(c: f64) -> f64 {
    const POW25_7: f64 = 6_103_515_625.0; // 25⁷
    let c7 = c.powi(7);
    if c7.is_finite() {
        (c7 / (c7 + POW25_7)).sqrt()
    } else {
        (1.0 / (1.0 + (25.0 / c).powi(7))).sqrt()
    }
}

/// Hue angle in degrees in `[0, 360)`, 0 when `a = b = 0` (Sharma et al. eq. 4).
fn hue_deg(a: f64, b: f64) -> f64 {
    crate::lab::hue_angle(a, b).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lab(l: f64, a: f64, b: f64) -> Lab {
        Lab { l, a, b }
    }

    #[test]
    fn cie94_closed_forms() {
        // Pure lightness difference: ΔE94 = |ΔL|/kL.
        let r = lab(50.0, 20.0, -10.0);
        let s = lab(53.0, 20.0, -10.0);
        assert!((delta_e_94(&r, &s, Cie94::GRAPHIC_ARTS) - 3.0).abs() < 1e-12);
        assert!((delta_e_94(&r, &s, Cie94::TEXTILES) - 1.5).abs() < 1e-12);
        // Pure chroma difference along the hue direction: ΔE94 = ΔC/(1 + K1 C_ref).
        let r = lab(50.0, 30.0, 40.0); // C = 50
        let s = lab(50.0, 33.0, 44.0); // C = 55, same hue
        let want = 5.0 / (1.0 + 0.045 * 50.0);
        assert!((delta_e_94(&r, &s, Cie94::GRAPHIC_ARTS) - want).abs() < 1e-12);
        // Pure hue difference at equal chroma: ΔH = ΔE*ab, divided by 1 + K2 C_ref.
        let (c, h1, h2) = (40.0f64, 0.3f64, 0.35f64);
        let r = lab(60.0, c * h1.cos(), c * h1.sin());
        let s = lab(60.0, c * h2.cos(), c * h2.sin());
        let want = delta_e_ab(&r, &s) / (1.0 + 0.015 * c);
        assert!((delta_e_94(&r, &s, Cie94::GRAPHIC_ARTS) - want).abs() < 1e-12);
    }

    #[test]
    fn ciede2000_is_zero_for_equal_colours_and_scales_with_k_l() {
        let c = lab(52.0, 10.0, -30.0);
        assert_eq!(delta_e_2000(&c, &c), 0.0);
        // Pure lightness difference: ΔE00 = |ΔL|/(kL SL), SL at the mean lightness 65:
        // SL = 1 + 0.015·225/√245.
        let (r, s) = (lab(50.0, 5.0, 5.0), lab(80.0, 5.0, 5.0));
        let s_l = 1.0 + 0.015 * 225.0 / 245f64.sqrt();
        assert!((delta_e_2000(&r, &s) - 30.0 / s_l).abs() < 1e-12);
        let k = Ciede2000 {
            k_l: 2.0,
            ..Ciede2000::default()
        };
        assert!((delta_e_2000_with(&r, &s, k) - 15.0 / s_l).abs() < 1e-12);
    }
}
