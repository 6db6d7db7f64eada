//! What a detector cone collects (physics.md §4).
//!
//! Conventions: a detector is a [`Cone`] of half-angle `α` about its axis `r_j`. It
//! collects `ρ_j = ∫_cone f(θi, r) cos θr dΩr`, a fraction of the incident beam power.
//! The paper's constant-integrand approximation is `ρ_j ≈ f(r_j) cos θj ΔΩ` with
//! `ΔΩ = 2π(1 − cos α)`.
//!
//! The exact integral uses one of two rules, chosen by the width of the flake light:
//!
//! * **About the detector axis** (distributions that are wide compared with the
//!   aperture): angle `β ∈ [0, α]` from the axis by Gauss–Kronrod, azimuth `ψ` about
//!   the axis by the trapezoid rule (spectrally accurate for a periodic integrand). A
//!   light rule (Kronrod 7 × 16 points) is tried first and kept when its error estimate
//!   is below 1e-6 of the value; otherwise Kronrod 15 × 48 points is used. The error
//!   estimate is the difference between the rule used and its embedded coarser rules
//!   (Gauss in `β`, half the points in `ψ`): a bound on the coarse rules' error, so the
//!   reported error is conservative.
//! * **About the specular direction** (narrow distributions): the flake light is a peak
//!   around the specular direction `p` (the exit direction of a flat flake) whose width,
//!   in exit directions, is the distribution's narrowest feature
//!   ([`Orientation::narrowest_feature`](flakescatter_stats::Orientation::narrowest_feature))
//!   times at least `2 sqrt(n² − sin²θi)` (reflection doubles a tilt, refraction out
//!   stretches it by `n cos θt` across the plane of incidence and by
//!   `n cos θt / cos θi` in it). When that width is below [`NARROW_FRACTION`] of `α`
//!   the nodes of the axis rule would miss the peak, so the cone is integrated in polar
//!   coordinates `(β′, ψ′)` about `p` instead. The cone's edge along each `ψ′` is
//!   found in closed form (`r·r_j = cos α` is `A cos β′ + B sin β′ = cos α`); when `p`
//!   lies outside the cone, `ψ′` runs over the directions that meet it,
//!   `|ψ′ − ψ_j| ≤ asin(sin α / sin d)` (`d` the angle from `p` to the axis), through
//!   `ψ′ = ψ_j + h sin t` to remove the square-root ends. `β′` is integrated by adaptive
//!   Gauss–Kronrod 15 with break points on a geometric ladder from the peak's width and,
//!   for a table, at the images of the bin edges (found by bisection); `ψ′` likewise.
//!   The error estimate adds the outer Kronrod–Gauss differences and the integrated
//!   inner ones. Cones farther from `p` than the image of the distribution's support
//!   ([`Orientation::support_end`](flakescatter_stats::Orientation::support_end), where
//!   `p2` is exactly zero in `f64`) plus `α` collect exactly nothing from the flakes.
//!
//! Directions below the horizon contribute nothing, also to the projected solid angle.
//!
//! The axis rule evaluates all its nodes of one cone in one call of
//! [`DistributionModel::brdf_batch`] (the vectorised point BRDF, equal to
//! [`DistributionModel::brdf`] to 1e-12 relative), then sums them in the order of the
//! scalar rule; the specular-centred rule's adaptive panels call the scalar path.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use flakescatter_optics::Vec3;
use flakescatter_optics::detector::{Cone, orthonormal_frame};

use crate::ModelError;
use crate::model::{DistributionModel, Incidence};
use crate::quad::{QuadValue, adaptive, adaptive_nested, gk7_nodes, gk15_nodes};

/// How a detector's cone is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ConeMethod {
    /// The exact cone integral (GK15 × 48-point trapezoid, with an error estimate).
    #[default]
    Exact,
    /// The paper's constant-integrand approximation `f(r_j) cos θj ΔΩ`.
    ConstantIntegrand,
}

/// Relative error estimate up to which the light cone rule is accepted.
pub const LIGHT_RULE_TOLERANCE: f64 = 1e-6;

/// A distribution is integrated about the specular direction when the narrowest width
/// of its flake light in exit directions is below this fraction of the aperture `α`
/// (module docs).
pub const NARROW_FRACTION: f64 = 0.5;

/// Relative tolerance of the inner (`β′`) integrals of the specular-centred rule.
const PEAK_INNER_REL: f64 = 1e-11;
/// Relative tolerance of the outer (`ψ′`) integral of the specular-centred rule.
const PEAK_OUTER_REL: f64 = 1e-9;
/// Absolute tolerance of the specular-centred rule, as a fraction of the beam: values
/// below it (far tails of a narrow peak) are resolved only to it.
const PEAK_ABS: f64 = 1e-15;
/// Panel budgets of the specular-centred rule.
const PEAK_INNER_PANELS: usize = 300;
const PEAK_OUTER_PANELS: usize = 200;
/// Azimuths at which the rim of the distribution's support is traced to bound its image.
const RIM_POINTS: usize = 64;

/// What one detector collects at one incidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Collected {
    /// BRDF averaged over the cone, `ρ / ∫_cone cos θr dΩ` (sr⁻¹); the point BRDF for a
    /// point detector (`α = 0`). Includes the clear coat when it is on and seen.
    pub brdf: f64,
    /// Fraction of the incident beam power collected, `ρ`; `None` for a point detector.
    pub reflectance: Option<f64>,
    /// Collected power per steradian of aperture, `ρ / ΔΩ` (the cone average of
    /// `BRDF × cos θr`), or `f cos θr` for a point detector: the quantity the paper's
    /// figures normalise to the specular direction.
    pub power_per_sr: f64,
    /// Absolute error estimate of `reflectance` (of `brdf` for a point detector);
    /// 0 for the constant-integrand approximation, whose error is not estimated.
    pub error: f64,
    /// Whether the clear coat's specular reflection was added.
    pub clearcoat_seen: bool,
}

impl Collected {
    /// What a point detector reads: the point BRDF `f` (sr⁻¹) at an exit direction of
    /// height `z = cos θr`.
    #[must_use]
    pub fn point(f: f64, z: f64) -> Self {
        Self {
            brdf: f,
            reflectance: None,
            power_per_sr: f * z,
            error: 0.0,
            clearcoat_seen: false,
        }
    }
}

impl DistributionModel {
    /// What the detector `cone` collects at incidence `inc`.
    #[must_use]
    pub fn collect(&self, inc: &Incidence, cone: &Cone, method: ConeMethod) -> Collected {
        let axis = cone.axis().into_inner();
        let alpha = cone.half_angle();
        if alpha == 0.0 {
            let mut f = self.brdf(inc, &axis);
            if self.base().is_some() {
                f += self.base_brdf(inc, &axis);
            }
            return Collected::point(f, axis.z);
        }
        let solid = cone.solid_angle();
        let (mut rho, proj, mut error) = match method {
            ConeMethod::ConstantIntegrand => {
                let f = self.brdf(inc, &axis);
                (f * axis.z * solid, axis.z.max(0.0) * solid, 0.0)
            }
            ConeMethod::Exact => self.cone_integral(inc, cone),
        };
        if self.base().is_some() {
            let (b, e) = self.base_cone(inc, cone, method);
            rho += b;
            error += e;
        }
        let clearcoat_seen = self.options().clearcoat && cone.contains(&inc.specular);
        if clearcoat_seen {
            rho += inc.clearcoat;
        }
        Collected {
            brdf: if proj > 0.0 { rho / proj } else { 0.0 },
            reflectance: Some(rho),
            power_per_sr: rho / solid,
            error,
            clearcoat_seen,
        }
    }

    /// What the cone collects of the base term alone (physics.md §13), as a fraction of
    /// the incident beam, with its quadrature error estimate: the same axis rule as the
    /// flakes' light (Kronrod 15 × 48, the base's light is smooth) or the
    /// constant-integrand approximation. `(0, 0)` without a base; for a point detector
    /// (half-angle 0) the point BRDF times `cos θr` (power per steradian).
    #[must_use]
    pub fn base_cone(&self, inc: &Incidence, cone: &Cone, method: ConeMethod) -> (f64, f64) {
        if self.base().is_none() {
            return (0.0, 0.0);
        }
        if cone.half_angle() == 0.0 {
            let axis = cone.axis().into_inner();
            return (self.base_brdf(inc, &axis) * axis.z, 0.0);
        }
        if method == ConeMethod::ConstantIntegrand {
            let axis = cone.axis().into_inner();
            return (
                self.base_brdf(inc, &axis) * axis.z * cone.solid_angle(),
                0.0,
            );
        }
        let points = |dirs: &[Vec3], out: &mut Vec<f64>| {
            out.clear();
            out.extend(dirs.iter().map(|r| self.base_brdf(inc, r)));
        };
        let (rho, _, err) =
            self.cone_rule_of(cone, &gk15_nodes(0.0, cone.half_angle()), 48, Some(&points));
        (rho, err)
    }

    /// `(∫ f cos θr dΩ, ∫ max(cos θr, 0) dΩ, error of the first)` over the cone, by the
    /// rule the module docs describe.
    fn cone_integral(&self, inc: &Incidence, cone: &Cone) -> (f64, f64, f64) {
        self.cone_integral_of(
            inc,
            cone,
            |dirs: &[Vec3], out: &mut Vec<f64>| self.brdf_batch(inc, dirs, out),
            |p: &Vec3, o: &Vec3| self.brdf_about(inc, p, o),
        )
    }

    /// As [`DistributionModel::cone_integral`] for any integrand value: `points(dirs,
    /// out)` puts in `out` the BRDF at each exit direction of `dirs` (a batch, so that
    /// the point BRDF can be evaluated a vector at a time,
    /// [`DistributionModel::brdf_batch`]), `about(p, o)` the same at `p + o` with the
    /// offset's digits kept (the specular-centred rule). Errors are in
    /// [`QuadValue::distance`], tolerances relative to [`QuadValue::size`].
    pub(crate) fn cone_integral_of<V: QuadValue>(
        &self,
        inc: &Incidence,
        cone: &Cone,
        points: impl Fn(&[Vec3], &mut Vec<V>),
        about: impl Fn(&Vec3, &Vec3) -> V,
    ) -> (V, f64, f64) {
        if self.is_narrow(inc, cone.half_angle()) {
            let proj = self
                .cone_rule_of(
                    cone,
                    &gk15_nodes(0.0, cone.half_angle()),
                    48,
                    None::<&fn(&[Vec3], &mut Vec<f64>)>,
                )
                .1;
            let (rho, err) = self.specular_rule_of(inc, cone, about);
            return (rho, proj, err);
        }
        self.axis_rule_of(cone, &points)
    }

    /// The axis-centred rule. First a light rule, Kronrod 7 in `β` × 16-point trapezoid
    /// in `ψ` (error from the embedded Gauss 3 and 8-point rules); when its error
    /// estimate exceeds [`LIGHT_RULE_TOLERANCE`] of the value, the full Kronrod 15 × 48
    /// rule is used.
    #[cfg(test)]
    fn axis_rule(&self, inc: &Incidence, cone: &Cone) -> (f64, f64, f64) {
        self.axis_rule_of(cone, &|dirs: &[Vec3], out: &mut Vec<f64>| {
            self.brdf_batch(inc, dirs, out);
        })
    }

    /// [`DistributionModel::axis_rule`] for the integrand `point` (see
    /// [`DistributionModel::cone_integral_of`]).
    fn axis_rule_of<V: QuadValue>(
        &self,
        cone: &Cone,
        points: &impl Fn(&[Vec3], &mut Vec<V>),
    ) -> (V, f64, f64) {
        let light = self.cone_rule_of(cone, &gk7_nodes(0.0, cone.half_angle()), 16, Some(points));
        if light.2 <= LIGHT_RULE_TOLERANCE * light.0.size() {
            return light;
        }
        self.cone_rule_of(cone, &gk15_nodes(0.0, cone.half_angle()), 48, Some(points))
    }

    /// The narrowest angular width of the flake light in exit directions at this
    /// incidence, radians: the distribution's narrowest feature times
    /// `2 sqrt(n² − sin²θi)` (module docs).
    #[must_use]
    pub fn exit_feature(&self, inc: &Incidence) -> f64 {
        let n = self.index();
        let si = inc.theta_i.sin();
        2.0 * (n * n - si * si).max(0.0).sqrt() * self.orientation().narrowest_feature()
    }

    /// Whether a cone of half-angle `alpha` (radians) is integrated about the specular
    /// direction at this incidence: the flake light is narrower than
    /// [`NARROW_FRACTION`]` · alpha` (module docs).
    #[must_use]
    pub fn is_narrow(&self, inc: &Incidence, alpha: f64) -> bool {
        self.exit_feature(inc) < NARROW_FRACTION * alpha
    }

    /// Refuses the constant-integrand approximation where it cannot hold: it takes the
    /// BRDF at the axis as constant over the cone, which a distribution narrower than
    /// the aperture ([`DistributionModel::is_narrow`]) contradicts (its value would be
    /// off by orders of magnitude, above 1 in a cone that sees the peak and 0 beside
    /// it).
    ///
    /// # Errors
    /// [`ModelError::ConstantIntegrandTooNarrow`] for such a cone with
    /// [`ConeMethod::ConstantIntegrand`].
    pub fn check_method(
        &self,
        inc: &Incidence,
        alpha: f64,
        method: ConeMethod,
    ) -> Result<(), ModelError> {
        if method == ConeMethod::ConstantIntegrand && alpha > 0.0 && self.is_narrow(inc, alpha) {
            return Err(ModelError::ConstantIntegrandTooNarrow {
                feature: self.exit_feature(inc),
                aperture: alpha,
            });
        }
        Ok(())
    }

    /// Angular radius about the specular direction of the exit directions that carry
    /// flake light, radians: the largest angle from `p` of the rays from normals on the
    /// rim `θn = support_end`, with a margin for the sampling of the rim; `π` when a rim
    /// ray is lost (the image is then not bounded by the rim's).
    fn light_reach(&self, inc: &Incidence) -> f64 {
        let theta_c = self.orientation().support_end();
        if theta_c >= FRAC_PI_2 {
            return PI;
        }
        let p = inc.specular.into_inner();
        let (st, ct) = theta_c.sin_cos();
        let mut reach: f64 = 0.0;
        for k in 0..RIM_POINTS {
            let (sp, cp) = (2.0 * PI * k as f64 / RIM_POINTS as f64).sin_cos();
            let m = flakescatter_optics::UnitVec3::new_normalize(Vec3::new(st * cp, st * sp, ct));
            let Some((_, out)) = self.ray_weight(inc, &m) else {
                return PI;
            };
            reach = reach.max(out.cross(&p).norm().atan2(out.dot(&p)));
        }
        // Chords between rim samples bulge by at most (π/RIM_POINTS)²/2 of the radius;
        // 10 % covers that with room, plus a floor for rounding.
        (1.1 * reach + 1e-12).min(PI)
    }

    /// The specular-centred rule (module docs): `(∫_cone f cos θr dΩ, error estimate)`.
    #[cfg(test)]
    fn specular_rule(&self, inc: &Incidence, cone: &Cone) -> (f64, f64) {
        self.specular_rule_of(inc, cone, |p: &Vec3, o: &Vec3| self.brdf_about(inc, p, o))
    }

    /// [`DistributionModel::specular_rule`] for the integrand `about` (see
    /// [`DistributionModel::cone_integral_of`]).
    fn specular_rule_of<V: QuadValue>(
        &self,
        inc: &Incidence,
        cone: &Cone,
        about: impl Fn(&Vec3, &Vec3) -> V,
    ) -> (V, f64) {
        let alpha = cone.half_angle();
        let axis = cone.axis().into_inner();
        let p = inc.specular.into_inner();
        let d = axis.cross(&p).norm().atan2(axis.dot(&p));
        if d >= alpha + self.light_reach(inc) {
            return (V::zero(), 0.0);
        }
        // Frame about p: u in the plane of incidence, v = y; ψ′ from u toward v.
        let (si, ci) = inc.theta_i.sin_cos();
        let u = Vec3::new(ci, 0.0, -si);
        let v = Vec3::new(0.0, 1.0, 0.0);
        let (ap, au, av) = (axis.dot(&p), axis.dot(&u), axis.dot(&v));
        let ca = alpha.cos();
        // cos d − cos α and R² − cos² α below, without cancellation when p lies near the
        // cone's edge (acos of a number near 1 would lose half the digits there).
        let amc = -2.0 * (0.5 * (d + alpha)).sin() * (0.5 * (d - alpha)).sin();
        let apc = ap + ca;
        let feature = self.exit_feature(inc).max(1e-300);
        let edges: Vec<f64> = self
            .orientation()
            .bin_edges()
            .map(|e| e.iter().copied().filter(|&x| x > 0.0).collect())
            .unwrap_or_default();
        // ∫ f cos θr sin β′ dβ′ along ψ′, with its error.
        let radial = |psi: f64| -> (V, f64) {
            let (sp, cp) = psi.sin_cos();
            let side = u * cp + v * sp;
            // The edge: A cos β′ + B sin β′ = cos α with A = p·r_j, B = side·r_j, i.e.
            // β′ = δ ± η, δ = atan2(B, A), tan η = sqrt(A² + B² − cos²α)/cos α.
            let b = au * cp + av * sp;
            let disc = b * b + amc * apc;
            if disc <= 0.0 {
                return (V::zero(), 0.0);
            }
            let delta = b.atan2(ap);
            let eta = disc.sqrt().atan2(ca);
            let (lo, hi) = ((delta - eta).max(0.0), (delta + eta).min(PI));
            if hi <= lo {
                return (V::zero(), 0.0);
            }
            // Offset of r(β′) from p, kept exact: r − p = −2 sin²(β′/2) p + sin β′ side.
            let offset = |beta: f64| {
                let sh = (0.5 * beta).sin();
                p * (-2.0 * sh * sh) + side * beta.sin()
            };
            let mut breaks = Vec::new();
            let mut x = feature / 8.0;
            while lo + x < hi {
                breaks.push(lo + x);
                x *= 2.0;
            }
            if !edges.is_empty() {
                self.edge_images(inc, &p, &offset, lo, hi, &edges, &mut breaks);
            }
            adaptive(
                |beta: f64| {
                    let o = offset(beta);
                    about(&p, &o).times((p.z + o.z).max(0.0)).times(beta.sin())
                },
                lo,
                hi,
                &breaks,
                PEAK_ABS * 1e-2,
                PEAK_INNER_REL,
                PEAK_INNER_PANELS,
            )
        };
        // Mirror symmetry y → −y for an axis in the plane of incidence: ψ′ → −ψ′, the
        // value there being `mirrored` (for a Mueller matrix, only in a basis the mirror
        // keeps: not at the pole with an azimuth off the axes).
        let in_plane = axis.y == 0.0 && (!V::BASIS_DEPENDENT || cone.mirror_keeps_basis());
        let (value, error) = if amc > 0.0 {
            // p inside the cone: every ψ′ meets the edge once.
            let quarter: Vec<f64> = (1..8).map(|k| f64::from(k) * FRAC_PI_4).collect();
            if in_plane {
                let (x, e) = adaptive_nested(
                    radial,
                    0.0,
                    PI,
                    &quarter,
                    PEAK_ABS,
                    PEAK_OUTER_REL,
                    PEAK_OUTER_PANELS,
                );
                (x.plus(x.mirrored()), 2.0 * e)
            } else {
                adaptive_nested(
                    radial,
                    0.0,
                    2.0 * PI,
                    &quarter,
                    PEAK_ABS,
                    PEAK_OUTER_REL,
                    PEAK_OUTER_PANELS,
                )
            }
        } else {
            // p outside: the directions ψ′ = ψ_j + h sin t, |t| ≤ π/2, meet the cone.
            // sin h = sin α / sin d, with cos h from sin²d − sin²α = sin(d − α) sin(d + α).
            let h = alpha
                .sin()
                .atan2(((d - alpha).sin() * (d + alpha).sin()).max(0.0).sqrt());
            let psi_j = av.atan2(au);
            let g = |t: f64| {
                let (st, ct) = t.sin_cos();
                let (x, e) = radial(psi_j + h * st);
                (x.times(h).times(ct), e * h * ct)
            };
            if in_plane {
                let (x, e) = adaptive_nested(
                    g,
                    0.0,
                    FRAC_PI_2,
                    &[],
                    PEAK_ABS,
                    PEAK_OUTER_REL,
                    PEAK_OUTER_PANELS,
                );
                (x.plus(x.mirrored()), 2.0 * e)
            } else {
                adaptive_nested(
                    g,
                    -FRAC_PI_2,
                    FRAC_PI_2,
                    &[0.0],
                    PEAK_ABS,
                    PEAK_OUTER_REL,
                    PEAK_OUTER_PANELS,
                )
            }
        };
        (value, error)
    }

    /// Adds to `breaks` the points `β′ ∈ (lo, hi)` along the ray `p + offset(β′)` where
    /// the flake normal's polar angle crosses a bin edge: a scan of 32 uniform and the
    /// geometric points, then bisection of every sign change.
    #[allow(clippy::too_many_arguments)]
    fn edge_images(
        &self,
        inc: &Incidence,
        p: &Vec3,
        offset: &dyn Fn(f64) -> Vec3,
        lo: f64,
        hi: f64,
        edges: &[f64],
        breaks: &mut Vec<f64>,
    ) {
        let theta = |beta: f64| {
            self.normal_polar_angle(inc, p, &offset(beta))
                .unwrap_or(FRAC_PI_2)
        };
        let mut scan: Vec<f64> = (0..=32)
            .map(|k| lo + (hi - lo) * f64::from(k) / 32.0)
            .collect();
        scan.extend(breaks.iter().copied());
        scan.sort_by(f64::total_cmp);
        let values: Vec<f64> = scan.iter().map(|&b| theta(b)).collect();
        for w in 0..scan.len() - 1 {
            let (t0, t1) = (values[w], values[w + 1]);
            for &e in edges {
                if (t0 < e) == (t1 < e) {
                    continue;
                }
                let (mut a, mut b) = (scan[w], scan[w + 1]);
                for _ in 0..100 {
                    let m = 0.5 * (a + b);
                    if m <= a || m >= b {
                        break;
                    }
                    if (theta(m) < e) == (t0 < e) {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                breaks.push(0.5 * (a + b));
            }
        }
    }

    /// One product rule: `nodes` (Kronrod nodes with Kronrod and Gauss weights) in `β`,
    /// `n_psi`-point trapezoid in `ψ`. In-plane detectors use the mirror symmetry
    /// `y → −y` of the problem (isotropic flakes, incidence in the xz-plane): only
    /// `ψ ∈ [0, π]` is evaluated, with the frame chosen so that `ψ → −ψ` is that mirror,
    /// and the value at the mirror image is [`QuadValue::mirrored`].
    /// Without an integrand (`points == None`) only the projected solid angle is
    /// computed.
    fn cone_rule_of<V: QuadValue, F: Fn(&[Vec3], &mut Vec<V>)>(
        &self,
        cone: &Cone,
        nodes: &[(f64, f64, f64)],
        n_psi: usize,
        points: Option<&F>,
    ) -> (V, f64, f64) {
        let axis = cone.axis().into_inner();
        let in_plane = axis.y == 0.0 && (!V::BASIS_DEPENDENT || cone.mirror_keeps_basis());
        let (u, v) = if in_plane {
            // u in the plane of incidence, v = axis × u = ±y.
            let u = Vec3::new(axis.z, 0.0, -axis.x);
            (u, axis.cross(&u))
        } else {
            let (u, v) = orthonormal_frame(cone.axis());
            (u.into_inner(), v.into_inner())
        };
        let trig = psi_trig(n_psi);
        // Every node's exit direction above the horizon, ring by ring, evaluated in one
        // batch: `ring_end[i]` ends ring i in `dirs` (with its sin β), `slot` says which
        // ψ node each direction is. The buffers are reused from call to call on each
        // thread (a curve evaluates thousands of cones), and so are the `sin β`, `cos β`
        // of the nodes while the cones keep one aperture.
        // Taken out of the cell for the call (a nested call would find it empty and
        // allocate), put back after.
        let mut scratch = RULE_SCRATCH.with_borrow_mut(std::mem::take);
        let RuleScratch {
            key,
            beta_trig,
            psi,
            psi_w,
            dirs,
            slot,
            ring_end,
        } = &mut scratch;
        // (sin ψ, cos ψ, weight in units of dψ, even) for the ψ nodes evaluated.
        psi.clear();
        psi.extend((0..n_psi).filter_map(|j| {
            let (sp, cp) = trig[j];
            let even = j % 2 == 0;
            if !in_plane || j == 0 || 2 * j == n_psi {
                Some((sp, cp, 1.0, even))
            } else if 2 * j < n_psi {
                Some((sp, cp, 2.0, even))
            } else {
                None
            }
        }));
        let this_key = (nodes.len(), nodes.last().map_or(0, |n| n.0.to_bits()));
        if *key != Some(this_key) || beta_trig.len() != nodes.len() {
            beta_trig.clear();
            beta_trig.extend(nodes.iter().map(|&(beta, _, _)| beta.sin_cos()));
            *key = Some(this_key);
        }
        dirs.clear();
        slot.clear();
        ring_end.clear();
        // u cos ψ + v sin ψ once per ψ node (the same expression, so the same bits).
        psi_w.clear();
        psi_w.extend(psi.iter().map(|&(sp, cp, _, _)| u * cp + v * sp));
        for &(sb, cb) in beta_trig.iter() {
            let along = axis * cb;
            // Every ψ node written in place, the next one over it unless it is above the
            // horizon (no branch per node: nearly all are above it).
            let base = dirs.len();
            dirs.resize(base + psi_w.len(), Vec3::zeros());
            slot.resize(base + psi_w.len(), 0);
            let (ring_dirs, ring_slots) = (&mut dirs[base..], &mut slot[base..]);
            let mut n = 0;
            for (k, &w) in psi_w.iter().enumerate() {
                let r: Vec3 = along + w * sb;
                ring_dirs[n] = r;
                ring_slots[n] = k;
                n += usize::from(r.z > 0.0);
            }
            dirs.truncate(base + n);
            slot.truncate(base + n);
            ring_end.push((dirs.len(), sb));
        }
        let result = V::with_values(|values| {
            if let Some(points) = points {
                points(dirs, values);
            }
            self.sum_rule(nodes, n_psi, psi, dirs, slot, ring_end, values)
        });
        RULE_SCRATCH.with_borrow_mut(|s| *s = scratch);
        result
    }

    /// The sums of [`DistributionModel::cone_rule_of`] over the evaluated nodes.
    #[allow(clippy::too_many_arguments)]
    fn sum_rule<V: QuadValue>(
        &self,
        nodes: &[(f64, f64, f64)],
        n_psi: usize,
        psi: &[(f64, f64, f64, bool)],
        dirs: &[Vec3],
        slot: &[usize],
        ring_end: &[(usize, f64)],
        values: &[V],
    ) -> (V, f64, f64) {
        let dpsi = 2.0 * PI / n_psi as f64;
        let (mut k_rho, mut g_rho, mut half_rho, mut proj) = (V::zero(), V::zero(), V::zero(), 0.0);
        let mut start = 0;
        for (&(_, wk, wg), &(end, sb)) in nodes.iter().zip(ring_end) {
            let (mut ring, mut ring_half, mut ring_proj) = (V::zero(), V::zero(), 0.0);
            let (slots, ring_dirs) = (&slot[start..end], &dirs[start..end]);
            let mut node = |k: usize, rz: f64, value: Option<V>| {
                let (_, _, w, even) = psi[k];
                if let Some(value) = value {
                    // Weight 2: this node and its mirror image y → −y.
                    let g = if w == 2.0 {
                        value.plus(value.mirrored())
                    } else {
                        value
                    }
                    .times(rz);
                    ring = ring.plus(g);
                    if even {
                        ring_half = ring_half.plus(g);
                    }
                }
                ring_proj += w * rz;
            };
            if let Some(ring_values) = values.get(start..end) {
                for ((&k, d), &value) in slots.iter().zip(ring_dirs).zip(ring_values) {
                    node(k, d.z, Some(value));
                }
            } else {
                // No integrand (or not for every node): the nodes that have a value
                // still count, and every node counts in the projected solid angle.
                for (i, (&k, d)) in slots.iter().zip(ring_dirs).enumerate() {
                    node(k, d.z, values.get(start + i).copied());
                }
            }
            start = end;
            let s = sb * dpsi;
            k_rho = k_rho.plus(ring.times(wk).times(s));
            g_rho = g_rho.plus(ring.times(wg).times(s));
            half_rho = half_rho.plus(ring_half.times(wk).times(2.0).times(s));
            proj += wk * ring_proj * s;
        }
        let error = k_rho.distance(&g_rho) + k_rho.distance(&half_rho);
        (k_rho, proj, error)
    }
}

/// Per-thread buffers of [`DistributionModel::cone_rule_of`]: the `(sin β, cos β)` of
/// the last β nodes (keyed by their number and the last node's bits), the ψ nodes, the exit
/// directions, their ψ slots and the ring ends.
#[derive(Default)]
struct RuleScratch {
    key: Option<(usize, u64)>,
    beta_trig: Vec<(f64, f64)>,
    /// `(sin ψ, cos ψ, weight in units of dψ, even)` of the ψ nodes evaluated.
    psi: Vec<(f64, f64, f64, bool)>,
    /// `u cos ψ + v sin ψ` of those nodes.
    psi_w: Vec<Vec3>,
    dirs: Vec<Vec3>,
    slot: Vec<usize>,
    ring_end: Vec<(usize, f64)>,
}

thread_local! {
    static RULE_SCRATCH: std::cell::RefCell<RuleScratch> =
        std::cell::RefCell::new(RuleScratch::default());
}

/// `(sin ψ_j, cos ψ_j)`, `ψ_j = 2πj/n`, for the trapezoid rules in `ψ` of the axis rule
/// (16 and 48 points), computed once per process; other `n` are computed per call.
fn psi_trig(n: usize) -> std::borrow::Cow<'static, [(f64, f64)]> {
    use std::sync::OnceLock;
    fn table(n: usize) -> Vec<(f64, f64)> {
        (0..n)
            .map(|j| (2.0 * PI * j as f64 / n as f64).sin_cos())
            .collect()
    }
    static T16: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    static T48: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    match n {
        16 => T16.get_or_init(|| table(16)).as_slice().into(),
        48 => T48.get_or_init(|| table(48)).as_slice().into(),
        _ => table(n).into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ModelOptions;
    use flakescatter_optics::UnitVec3;
    use flakescatter_stats::{GaussianWidth, Orientation};

    fn model(hwhm_deg: f64) -> DistributionModel {
        let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
        DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap()
    }

    /// Cones of 1.5° at in-plane offsets −10°…10° from specular, in the plane of
    /// incidence and 2° out of it.
    fn cones(theta_i_deg: f64) -> Vec<Cone> {
        let mut v = Vec::new();
        for k in -40..=40 {
            let ts = f64::to_radians(-theta_i_deg + 0.25 * f64::from(k));
            for phi in [0.0f64, 2f64.to_radians()] {
                let axis = Vec3::new(-ts.sin(), phi.sin(), ts.cos());
                v.push(Cone::new(UnitVec3::new_normalize(axis), 1.5f64.to_radians()).unwrap());
            }
        }
        v
    }

    #[test]
    fn the_two_exact_rules_agree_where_both_resolve_the_light() {
        // Two quadratures of the same integrand on different coordinates (about the axis,
        // about specular): from widths where the switch happens (0.2°–0.3°, flake light
        // 0.5°–0.75° wide against the switch at α/2 = 0.75°) to wide ones, they agree far
        // below either error estimate, so the switch leaves no step in a curve.
        for hwhm in [0.2, 0.3, 1.0, 3.0] {
            let m = model(hwhm);
            for ti in [0.0, 30.0, 60.0, 75.0] {
                let inc = m.incidence(f64::to_radians(ti)).unwrap();
                for c in cones(ti) {
                    let (a, _, a_err) = m.axis_rule(&inc, &c);
                    let (s, s_err) = m.specular_rule(&inc, &c);
                    let tol = 1e-8 * s.abs() + 1e-14;
                    assert!(
                        (a - s).abs() < tol,
                        "hwhm {hwhm}° θi {ti}° {:?}: axis {a} ± {a_err}, specular {s} ± {s_err}",
                        c.axis()
                    );
                }
            }
        }
    }

    #[test]
    fn cone_sums_of_the_batch_brdf_equal_those_of_the_scalar_brdf() {
        // The axis rule evaluates its nodes with `brdf_batch`; the same rule over the
        // scalar `brdf` (the reference path) gives the same integral, projected solid
        // angle and error estimate to 1e-12 relative, for wide and narrow Gaussians and a
        // table, perfect and complex flakes, each transmission mode, in and out of the
        // plane of incidence and for cones reaching below the horizon.
        use flakescatter_optics::flake::FlakeReflectance;
        use flakescatter_optics::polarization::Transmission;
        let orientations = [
            Orientation::gaussian(GaussianWidth::Hwhm(1f64.to_radians())).unwrap(),
            Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap(),
            Orientation::gaussian(GaussianWidth::Hwhm(25f64.to_radians())).unwrap(),
            Orientation::tabulated(vec![0.0, 0.05, 0.1, 0.3, 0.6], vec![0.4, 0.3, 0.2, 0.1])
                .unwrap(),
        ];
        let flakes = [
            FlakeReflectance::PerfectConductor,
            FlakeReflectance::complex(1.2, 7.0).unwrap(),
        ];
        let transmissions = [
            Transmission::ExactUnpolarized,
            Transmission::S,
            Transmission::Paper,
        ];
        let mut checked = 0;
        for o in &orientations {
            for flake in &flakes {
                for &transmission in &transmissions {
                    let options = ModelOptions {
                        flake: flake.clone(),
                        transmission,
                        ..ModelOptions::default()
                    };
                    let m = DistributionModel::new(o.clone(), 1.5, options).unwrap();
                    for ti in [0.0, 45.0, 80.0] {
                        let inc = m.incidence(f64::to_radians(ti)).unwrap();
                        let scalar = |dirs: &[Vec3], out: &mut Vec<f64>| {
                            out.clear();
                            out.extend(dirs.iter().map(|r| m.brdf(&inc, r)));
                        };
                        for ts in [-85.0, -60.0, -45.0, -20.0, 0.0, 30.0, 88.0] {
                            for (phi, alpha) in [(0.0, 1.5f64), (7.0, 1.5), (0.0, 6.0)] {
                                let (t, p) = (f64::to_radians(ts), f64::to_radians(phi));
                                let axis =
                                    Vec3::new(-t.sin() * p.cos(), p.sin(), t.cos() * p.cos());
                                let cone =
                                    Cone::new(UnitVec3::new_normalize(axis), alpha.to_radians())
                                        .unwrap();
                                let b = m.axis_rule(&inc, &cone);
                                let s = m.axis_rule_of(&cone, &scalar);
                                for (got, want) in [(b.0, s.0), (b.1, s.1)] {
                                    assert!(
                                        (got - want).abs() <= 1e-12 * want.abs(),
                                        "θi {ti}° θs {ts}° φ {phi}°: {got} vs {want}"
                                    );
                                }
                                // The error estimate is a difference of such sums.
                                assert!((b.2 - s.2).abs() <= 1e-12 * s.0.abs() + 1e-300);
                                checked += usize::from(s.0 > 0.0);
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 300, "{checked}");
    }

    #[test]
    fn the_axis_rule_misses_narrow_light_and_says_so() {
        // Below the switch the axis rule's nodes straddle the peak: at hwhm 0.03° it is
        // off by tens of per cent somewhere near specular, and its error estimate is of
        // the order of the value (so it is not silently wrong, just useless); the
        // specular-centred rule is used there.
        let m = model(0.03);
        let inc = m.incidence(0.5).unwrap();
        assert!(m.is_narrow(&inc, 1.5f64.to_radians()));
        let mut worst: f64 = 0.0;
        for c in cones(0.5f64.to_degrees()) {
            let (a, _, a_err) = m.axis_rule(&inc, &c);
            let (s, _) = m.specular_rule(&inc, &c);
            if s > 1e-6 {
                let rel = (a - s).abs() / s;
                worst = worst.max(rel);
                assert!(a_err >= 0.1 * (a - s).abs(), "{a} ± {a_err} vs {s}");
            }
        }
        assert!(worst > 0.1, "{worst}");
    }

    #[test]
    fn cones_beyond_the_image_of_the_support_collect_exactly_nothing() {
        // hwhm 0.01°: p2 is exactly 0 beyond 38.7 s = 0.33° of tilt, whose image lies
        // within a few degrees of specular; a cone 20° away collects 0 with error 0, and
        // so does the Monte Carlo tracer.
        let m = model(0.01);
        let inc = m.incidence(0.5).unwrap();
        let far = Cone::in_plane(-0.5 + 20f64.to_radians(), 1.5f64.to_radians()).unwrap();
        let got = m.collect(&inc, &far, ConeMethod::Exact);
        assert_eq!((got.reflectance, got.error), (Some(0.0), 0.0));
        let mc = crate::monte_carlo(&m, &inc, &[far], 100_000, 3).unwrap();
        assert_eq!(mc[0].hits, 0);
        assert!(m.light_reach(&inc) < 5f64.to_radians());
    }
}
