//! Source, specular and detector directions, and detector cones (physics.md §1).
//!
//! Conventions: angles in radians. The source lies on the `−x` side, so the incident
//! propagation direction is `k_in = (sin θi, 0, −cos θi)` and the specular direction is
//! `(sin θi, 0, cos θi)`. In the plane of incidence a detector is given by the signed
//! angle `θs` (the paper's convention): `θs = −θi` is specular, `θs > 0` lies on the
//! source side, and the axis is `r(θs) = (−sin θs, 0, cos θs)`. Out of plane a detector
//! is `(θr, φr)`: `r = (sin θr cos φr, sin θr sin φr, cos θr)` with `φr = 0` the specular
//! half-plane. The aspecular angle (ASTM E2194 style) is measured from the specular
//! direction, positive toward the normal: in plane `θs = −θi + aspecular`.
//!
//! A detector is a cone of half-angle `α` about its axis `r` (`r.z > 0`, pointing from
//! the sample to the detector); a ray `k_out` enters when the angle between them is
//! below `α` (paper eq. 15), i.e. `k_out·r > cos α`.

use std::f64::consts::{FRAC_PI_2, PI};

use crate::{OpticsError, UnitVec3, Vec3};

/// Incident propagation direction for incidence angle `theta_i`: `(sin θi, 0, −cos θi)`.
#[must_use]
pub fn incident_direction(theta_i: f64) -> UnitVec3 {
    UnitVec3::new_unchecked(Vec3::new(theta_i.sin(), 0.0, -theta_i.cos()))
}

/// Specular direction for incidence angle `theta_i`: `(sin θi, 0, cos θi)`.
#[must_use]
pub fn specular_direction(theta_i: f64) -> UnitVec3 {
    UnitVec3::new_unchecked(Vec3::new(theta_i.sin(), 0.0, theta_i.cos()))
}

/// Detector axis for the signed in-plane angle `theta_s`: `(−sin θs, 0, cos θs)`.
#[must_use]
pub fn in_plane_direction(theta_s: f64) -> UnitVec3 {
    UnitVec3::new_unchecked(Vec3::new(-theta_s.sin(), 0.0, theta_s.cos()))
}

/// Signed in-plane angle of a direction, `θs = atan2(−r.x, r.z)`; the `y` component is
/// ignored (the direction is projected onto the plane of incidence).
#[must_use]
pub fn in_plane_angle(r: &UnitVec3) -> f64 {
    (-r.x).atan2(r.z)
}

/// Detector axis for polar angle `theta_r` and azimuth `phi_r` (`φr = 0` is the
/// specular half-plane).
#[must_use]
pub fn out_of_plane_direction(theta_r: f64, phi_r: f64) -> UnitVec3 {
    let (s, c) = theta_r.sin_cos();
    UnitVec3::new_unchecked(Vec3::new(s * phi_r.cos(), s * phi_r.sin(), c))
}

/// Polar angle and azimuth `(θr, φr)` of a direction, `φr ∈ (−π, π]`.
#[must_use]
pub fn polar_azimuth(r: &UnitVec3) -> (f64, f64) {
    let theta = r.z.clamp(-1.0, 1.0).acos();
    let phi = if r.x == 0.0 && r.y == 0.0 {
        0.0
    } else {
        r.y.atan2(r.x)
    };
    (theta, phi)
}

/// `(θr, φr)` of the in-plane detector `θs`: `(|θs|, 0)` for `θs ≤ 0`, `(θs, π)` for
/// `θs > 0`.
#[must_use]
pub fn in_plane_to_polar(theta_s: f64) -> (f64, f64) {
    if theta_s <= 0.0 {
        (-theta_s, 0.0)
    } else {
        (theta_s, PI)
    }
}

/// In-plane detector angle for an aspecular angle at incidence `theta_i`:
/// `θs = −θi + aspecular`.
#[must_use]
pub fn aspecular_to_theta_s(theta_i: f64, aspecular: f64) -> f64 {
    -theta_i + aspecular
}

/// Aspecular angle of the in-plane detector `theta_s` at incidence `theta_i`:
/// `aspecular = θs + θi`.
#[must_use]
pub fn theta_s_to_aspecular(theta_i: f64, theta_s: f64) -> f64 {
    theta_s + theta_i
}

/// Two unit vectors `(u, v)` completing `axis` to a right-handed orthonormal frame
/// `(u, v, axis)`. Used to parametrise directions about a detector axis.
#[must_use]
pub fn orthonormal_frame(axis: &UnitVec3) -> (UnitVec3, UnitVec3) {
    // Pick the world axis least aligned with `axis` to avoid cancellation.
    let a = axis.into_inner();
    let helper = if a.x.abs() < 0.6 {
        Vec3::x()
    } else if a.y.abs() < 0.6 {
        Vec3::y()
    } else {
        Vec3::z()
    };
    let u = UnitVec3::new_normalize(helper - a * a.dot(&helper));
    let v = UnitVec3::new_unchecked(a.cross(&u));
    (u, v)
}

/// A conical detector: axis `r` (`r.z > 0`), half-angle `α ∈ [0, π/2)`, and the `s`
/// vector of the polarisation basis of its axis ([`Cone::basis_s`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    axis: UnitVec3,
    half_angle: f64,
    cos_half_angle: f64,
    basis_s: Vec3,
}

impl Cone {
    /// A cone about `axis` with half-angle `half_angle` (radians).
    ///
    /// # Errors
    /// [`OpticsError::AngleOutOfRange`] when the axis is not above the surface
    /// (`r.z ≤ 0`) or the half-angle is not in `[0, π/2)`.
    pub fn new(axis: UnitVec3, half_angle: f64) -> Result<Self, OpticsError> {
        if !(half_angle.is_finite() && (0.0..FRAC_PI_2).contains(&half_angle)) {
            return Err(OpticsError::AngleOutOfRange {
                name: "aperture half-angle",
                value: half_angle,
                expected: "[0, pi/2)",
            });
        }
        if axis.z.is_nan() || axis.z <= 0.0 {
            let (theta, _) = polar_azimuth(&axis);
            return Err(OpticsError::AngleOutOfRange {
                name: "detector polar angle",
                value: theta,
                expected: "[0, pi/2)",
            });
        }
        Ok(Self {
            axis,
            half_angle,
            cos_half_angle: half_angle.cos(),
            basis_s: crate::jones::s_vector(&axis),
        })
    }

    /// The in-plane detector at signed angle `theta_s ∈ (−π/2, π/2)`.
    ///
    /// # Errors
    /// As [`Cone::new`].
    pub fn in_plane(theta_s: f64, half_angle: f64) -> Result<Self, OpticsError> {
        if !(theta_s.is_finite() && theta_s.abs() < FRAC_PI_2) {
            return Err(OpticsError::AngleOutOfRange {
                name: "theta_s",
                value: theta_s,
                expected: "(-pi/2, pi/2)",
            });
        }
        Self::new(in_plane_direction(theta_s), half_angle)
    }

    /// The out-of-plane detector at `(θr, φr)`, `θr ∈ [0, π/2)`.
    ///
    /// # Errors
    /// As [`Cone::new`].
    pub fn out_of_plane(theta_r: f64, phi_r: f64, half_angle: f64) -> Result<Self, OpticsError> {
        if !(theta_r.is_finite() && (0.0..FRAC_PI_2).contains(&theta_r) && phi_r.is_finite()) {
            return Err(OpticsError::AngleOutOfRange {
                name: "theta_r",
                value: theta_r,
                expected: "[0, pi/2) with a finite phi_r",
            });
        }
        let mut cone = Self::new(out_of_plane_direction(theta_r, phi_r), half_angle)?;
        let a = cone.axis;
        if a.x == 0.0 && a.y == 0.0 {
            // At the pole the axis has lost φr; its basis is the limit θr → 0 at this φr.
            cone.basis_s = Vec3::new(-phi_r.sin(), phi_r.cos(), 0.0);
        }
        Ok(cone)
    }

    /// The `s` vector of the polarisation basis in which everything this detector
    /// collects is given (SCATMECH's, [`crate::jones`]): `(z × r)/|z × r|` of the axis
    /// `r`, which for an out-of-plane detector `(θr, φr)` is `(−sin φr, cos φr, 0)`.
    /// **At the pole** (`θr = 0`, where `z × r` vanishes) it is the limit `θr → 0` at
    /// fixed `φr`, the same `(−sin φr, cos φr, 0)`, so a detector's Mueller matrix is
    /// continuous in `θr` at every azimuth; a cone built from its axis alone
    /// ([`Cone::new`], [`Cone::in_plane`]) has no azimuth there and takes `s = y`, the
    /// limit along `φr = 0` (and, as a Mueller matrix, along `φr = 180°`).
    #[must_use]
    pub fn basis_s(&self) -> &Vec3 {
        &self.basis_s
    }

    /// Whether the mirror `y → −y` maps this detector's axis and polarisation basis onto
    /// themselves (up to the sign of `s`): the axis in the plane of incidence and `s`
    /// along `±y` or within the xz-plane. Integrals of Mueller matrices over the cone
    /// may then use the mirror symmetry of the problem.
    #[must_use]
    pub fn mirror_keeps_basis(&self) -> bool {
        self.axis.y == 0.0 && (self.basis_s.x == 0.0 || self.basis_s.y == 0.0)
    }

    /// Unit axis from the sample toward the detector.
    #[must_use]
    pub fn axis(&self) -> &UnitVec3 {
        &self.axis
    }

    /// Half-angle `α`, radians.
    #[must_use]
    pub fn half_angle(&self) -> f64 {
        self.half_angle
    }

    /// `cos α`.
    #[must_use]
    pub fn cos_half_angle(&self) -> f64 {
        self.cos_half_angle
    }

    /// Whether the direction `k` enters the detector: angle to the axis below `α`
    /// (paper eq. 15). A point detector (`α = 0`) contains nothing.
    #[must_use]
    pub fn contains(&self, k: &UnitVec3) -> bool {
        k.dot(&self.axis) > self.cos_half_angle
    }

    /// Solid angle of the cone, `ΔΩ = 2π (1 − cos α)` (sr).
    #[must_use]
    pub fn solid_angle(&self) -> f64 {
        // 2π(1 − cos α) = 4π sin²(α/2), without cancellation for small α.
        let s = (0.5 * self.half_angle).sin();
        4.0 * PI * s * s
    }

    /// Projected solid angle `∫_cone cos θr dΩ = cos θj · π sin²α` (sr), exact while
    /// the whole cone lies above the horizon (`θj + α ≤ π/2`); derivation:
    /// `∫ r·z dΩ = z·∫ r dΩ` and `∫_cap r dΩ = axis · 2π ∫_0^α cos β sin β dβ`.
    #[must_use]
    pub fn projected_solid_angle(&self) -> f64 {
        let s = self.half_angle.sin();
        self.axis.z * PI * s * s
    }
}

/// The distinct half-angles of `cones` (radians), in order of first appearance.
#[must_use]
pub fn distinct_apertures(cones: &[Cone]) -> Vec<f64> {
    let mut apertures: Vec<f64> = Vec::new();
    for c in cones {
        if !apertures.contains(&c.half_angle()) {
            apertures.push(c.half_angle());
        }
    }
    apertures
}

/// The detectors of a run that reports values relative to specular: `cones`, then for
/// each incidence of `theta_i` (radians, in order) one in-plane specular cone
/// (`θs = −θi`) per aperture of `apertures` ([`distinct_apertures`]), in order.
///
/// # Errors
/// As [`Cone::in_plane`].
pub fn with_specular_cones(
    cones: &[Cone],
    theta_i: &[f64],
    apertures: &[f64],
) -> Result<Vec<Cone>, OpticsError> {
    let mut all = cones.to_vec();
    for &t in theta_i {
        for &a in apertures {
            all.push(Cone::in_plane(-t, a)?);
        }
    }
    Ok(all)
}
