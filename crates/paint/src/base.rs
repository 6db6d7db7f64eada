//! The pigmented base coat under the clear coat: a Lambertian reflector of albedo `ρ`
//! seen through the flake layer's gaps and the coat's surface (physics.md §12.3).
//!
//! Conventions: radians, `n` the coat's index, cosines of air-side angles. Light that
//! enters the coat at `θi` (power fraction `T'(θi)`, the coat's
//! [`transmission_factor`](crate::coat::CoatSurface::transmission_factor) times `T_av`)
//! passes the flake layer through its gaps, a fraction `1 − c` of the area in any
//! direction (`c` the flakes' coverage; light that meets a flake on its way to or from the
//! base is not followed: the rule is stated in physics.md §12.3), is reflected
//! diffusely by the base, and leaves at `θo` with `T'(θo)/n²` of the inside radiance. The
//! coat's surface sends `r_i` of the diffuse light from inside back down (internal diffuse
//! reflectance, total internal reflection included), which returns to the base through
//! the gaps again; summing the geometric series,
//!
//! `f_base = (1 − c)² ρ T'(θi) T'(θo) / (π n² (1 − (1 − c)² ρ r_i))`.
//!
//! `r_i = 1 − (1 − r_e)/n²` with `r_e = ∫_0^1 R_av(μ) 2μ dμ` the external diffuse
//! reflectance (the identity follows from reciprocity; tests check it against the direct
//! integral from inside).

use flakescatter_numerics::quad::adaptive;
use flakescatter_optics::fresnel;

/// External diffuse reflectance `r_e = ∫_0^1 R_av(μ) 2μ dμ` of a flat air–coat surface
/// of index `n` (diffuse light from air), by adaptive Gauss–Kronrod to 1e-13.
#[must_use]
pub fn external_diffuse_reflectance(n: f64) -> f64 {
    let f = |mu: f64| {
        let ct = (1.0 - (1.0 - mu * mu) / (n * n)).max(0.0).sqrt();
        fresnel::power_from_cosines(mu, ct, n).r_av() * 2.0 * mu
    };
    adaptive(f, 0.0, 1.0, &[0.05, 0.2], 1e-15, 1e-13, 400).0
}

/// Internal diffuse reflectance `r_i = 1 − (1 − r_e)/n²` of the same surface for diffuse
/// light from inside (total internal reflection included).
#[must_use]
pub fn internal_diffuse_reflectance(n: f64) -> f64 {
    1.0 - (1.0 - external_diffuse_reflectance(n)) / (n * n)
}

/// The base term (module docs), sr⁻¹: `gap2 = (1 − c)²`, `albedo = ρ`, the two crossings'
/// power factors `t_in = T'(θi)`, `t_out = T'(θo)`, the index and `r_i`.
#[must_use]
#[inline]
pub fn base_brdf(gap2: f64, albedo: f64, t_in: f64, t_out: f64, n: f64, r_i: f64) -> f64 {
    let a = gap2 * albedo;
    a * t_in * t_out / (std::f64::consts::PI * n * n * (1.0 - a * r_i))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reciprocity identity against the direct integral from inside:
    /// `r_i = ∫_0^1 R_inside(μ') 2μ' dμ'`, with `R = 1` beyond the critical angle.
    #[test]
    fn internal_reflectance_identity() {
        for n in [1.0f64, 1.33, 1.5, 1.8] {
            let direct = adaptive(
                |mu_in: f64| {
                    let theta = mu_in.acos();
                    let r = fresnel::coating_to_air(theta, n).map_or(1.0, |p| p.r_av());
                    r * 2.0 * mu_in
                },
                0.0,
                1.0,
                &[(1.0 - 1.0 / (n * n)).max(0.0).sqrt()],
                1e-15,
                1e-13,
                400,
            )
            .0;
            let got = internal_diffuse_reflectance(n);
            assert!((got - direct).abs() < 1e-10, "n {n}: {got} vs {direct}");
        }
    }

    /// The closed form of the unpolarised external diffuse reflectance (Walsh 1926,
    /// written out by Stern 1964, Appl. Opt. 3, 111, for index ratio `m`):
    /// `r_e = 1/2 + (m−1)(3m+1)/(6(m+1)²) + m²(m²−1)²/(m²+1)³ ln((m−1)/(m+1))
    ///        − 2m³(m²+2m−1)/((m²+1)(m⁴−1)) + 8m⁴(m⁴+1)/((m²+1)(m⁴−1)²) ln m`;
    /// 0.091778 at m = 1.5 (so `r_i` = 0.596346, the familiar 0.596).
    #[test]
    fn diffuse_reflectances_against_the_closed_form() {
        let closed = |m: f64| {
            let (m2, m4) = (m * m, m.powi(4));
            0.5 + (m - 1.0) * (3.0 * m + 1.0) / (6.0 * (m + 1.0).powi(2))
                + m2 * (m2 - 1.0).powi(2) / (m2 + 1.0).powi(3) * ((m - 1.0) / (m + 1.0)).ln()
                - 2.0 * m.powi(3) * (m2 + 2.0 * m - 1.0) / ((m2 + 1.0) * (m4 - 1.0))
                + 8.0 * m4 * (m4 + 1.0) / ((m2 + 1.0) * (m4 - 1.0).powi(2)) * m.ln()
        };
        for n in [1.33, 1.5, 1.8, 2.2] {
            let got = external_diffuse_reflectance(n);
            assert!(
                (got - closed(n)).abs() < 1e-12,
                "n {n}: {got} vs {}",
                closed(n)
            );
        }
        assert!((internal_diffuse_reflectance(1.5) - 0.596_346).abs() < 1e-6);
        assert!(external_diffuse_reflectance(1.0) < 1e-20);
    }
}
