//! Refraction at the flat top surface of the clear coat (Snell's law).
//!
//! Conventions: the surface is the plane `z = 0` with normal `+z` pointing into the air;
//! the coating has real index `n ≥ 1` relative to air. Directions are unit propagation
//! vectors. Going in, `k_in.z < 0` and the refracted `k1.z < 0`; going out, the inside
//! ray `k2.z > 0` and the leaving ray `k_out.z > 0`. The tangential (x, y) component of
//! the direction scales by `1/n` going in and by `n` going out; angles are radians.

use crate::{UnitVec3, Vec3};

/// Polar angle inside the coating for an incidence angle `theta_i` in air:
/// `sin θi = n sin θt`. Defined for every `θi` when `n ≥ 1`.
#[must_use]
pub fn snell_inside(theta_i: f64, n: f64) -> f64 {
    (theta_i.sin() / n).asin()
}

/// Polar angle in air for a ray at `theta_inside` in the coating, or `None` when
/// `n sin θ ≥ 1` (total internal reflection).
#[must_use]
pub fn snell_outside(theta_inside: f64, n: f64) -> Option<f64> {
    let s = n * theta_inside.sin();
    if s.abs() < 1.0 { Some(s.asin()) } else { None }
}

/// Refract a downward air ray `k_in` (`k_in.z < 0`) into the coating.
///
/// Always succeeds for `n ≥ 1`. A ray with `k_in.z ≥ 0` does not meet the surface from
/// above; its `z` sign is ignored and the result still points down.
#[must_use]
pub fn into_coating(k_in: &UnitVec3, n: f64) -> UnitVec3 {
    let tx = k_in.x / n;
    let ty = k_in.y / n;
    // sqrt(1 − (k.x² + k.y²)/n²) = sqrt(n² − 1 + k.z²)/n for a unit k, without the
    // cancellation of the first form at grazing incidence.
    let tz = (n * n - 1.0 + k_in.z * k_in.z).max(0.0).sqrt() / n;
    UnitVec3::new_unchecked(Vec3::new(tx, ty, -tz))
}

/// Refract an upward inside ray `k2` (`k2.z > 0`) out into the air, or `None` when it
/// is totally internally reflected (`n² (k2.x² + k2.y²) ≥ 1`).
#[must_use]
pub fn out_of_coating(k2: &UnitVec3, n: f64) -> Option<UnitVec3> {
    let tx = k2.x * n;
    let ty = k2.y * n;
    let s2 = tx * tx + ty * ty;
    if s2 >= 1.0 {
        return None;
    }
    Some(UnitVec3::new_unchecked(Vec3::new(
        tx,
        ty,
        (1.0 - s2).sqrt(),
    )))
}

/// The inside direction `k2` that leaves the coating along the air direction `r`
/// (`r.z > 0`): the inverse of [`out_of_coating`] (physics.md §4 step 1),
/// `k2 = (r.x/n, r.y/n, sqrt(1 - (r.x² + r.y²)/n²))`.
#[must_use]
pub fn exit_to_inside(r: &UnitVec3, n: f64) -> UnitVec3 {
    let tx = r.x / n;
    let ty = r.y / n;
    // As in `into_coating`: exact for a unit r, and accurate near the horizon.
    let tz = (n * n - 1.0 + r.z * r.z).max(0.0).sqrt() / n;
    UnitVec3::new_unchecked(Vec3::new(tx, ty, tz))
}
