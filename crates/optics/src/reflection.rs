//! Mirror reflection by a flake, the internal half vector and the obliquity factor
//! (paper eqs. 1 and 2), and the two solid-angle Jacobians of physics.md §2.
//!
//! Conventions: `k1` is the unit propagation direction inside the coating toward the
//! flake (`k1.z < 0`), `k2` the reflected direction, `m` the flake's unit normal on its
//! lit side (`m.z > 0` for a flake lit from above). Angles in radians.

use crate::{UnitVec3, Vec3};

/// Mirror reflection `k2 = k1 − 2 (k1·m) m` (paper eq. 1).
#[must_use]
pub fn reflect(k1: &UnitVec3, m: &UnitVec3) -> UnitVec3 {
    let d = k1.dot(m);
    UnitVec3::new_unchecked(k1.into_inner() - 2.0 * d * m.into_inner())
}

/// The flake normal that reflects `k1` into `k2`: `m = (k2 − k1)/|k2 − k1|` (eq. 1
/// inverted), or `None` when `k2 = k1` (grazing, no unique normal).
#[must_use]
pub fn half_vector(k1: &UnitVec3, k2: &UnitVec3) -> Option<UnitVec3> {
    let h: Vec3 = k2.into_inner() - k1.into_inner();
    UnitVec3::try_new(h, 1e-300)
}

/// Obliquity `γ = −k1·m`: the cosine of the local incidence angle on the flake, the
/// fraction of the flake area seen by the beam inside the coating (eq. 2).
/// Negative when the beam meets the back of the flake.
#[must_use]
pub fn obliquity(k1: &UnitVec3, m: &UnitVec3) -> f64 {
    -k1.dot(m)
}

/// Obliquity from the two ray directions, `γ = sqrt((1 − k1·k2)/2)`: the corrected
/// eq. 2. (The printed equation has `k'·k'`, identically 1, and a wrong denominator.)
#[must_use]
pub fn obliquity_from_rays(k1: &UnitVec3, k2: &UnitVec3) -> f64 {
    (0.5 * (1.0 - k1.dot(k2))).max(0.0).sqrt()
}

/// Jacobian of mirror reflection at fixed `k1`: `dΩ(k2) = 4 γ dΩ(m)`.
#[must_use]
pub fn reflection_jacobian(gamma: f64) -> f64 {
    4.0 * gamma
}

/// Jacobian of refraction out of the coating: `dΩ(k_out) = n² (cos θ2 / cos θo) dΩ(k2)`,
/// with `cos θ2 = k2.z` inside and `cos θo = k_out.z` outside.
#[must_use]
pub fn refraction_out_jacobian(n: f64, cos_theta2: f64, cos_theta_o: f64) -> f64 {
    n * n * cos_theta2 / cos_theta_o
}
