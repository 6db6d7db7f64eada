//! Flake measurements: plane fits (eq. 5), endpoint tilts (eq. 6), areas (eq. 7) and
//! conversions between normals and angles.
//!
//! Conventions (`physics.md` §1, §3):
//! * Lengths in **micrometres**, angles in **radians**, `z` the coating normal into the
//!   air; flake normals are unit vectors with `z > 0`.
//! * `θx` is the tilt of the flake's trace in the `xz`-plane, `tan θx = ∂z/∂x`, and
//!   likewise `tan θy = ∂z/∂y`; both are signed, in `(-π/2, π/2)`. A plane
//!   `z = a x + b y + c` has `a = tan θx`, `b = tan θy` and unit normal
//!   `(−a, −b, 1)/sqrt(1 + a² + b²)` (eq. 5).
//! * `θn ∈ [0, π/2)` is the polar angle of the normal, `tan² θn = tan² θx + tan² θy`
//!   (eq. 6); `φn ∈ [0, 2π)` its azimuth from `+x` toward `+y`. A flake rising toward
//!   `+x` (`θx > 0`) has its normal leaning toward `−x` (`φn = π`).

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{Unit, Vector3};
use thiserror::Error;

pub use flakescatter_numerics::UnitVec3;

/// Errors from flake measurements.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FlakeError {
    /// A plane fit needs at least three points.
    #[error("plane fit needs at least 3 points, got {0}")]
    TooFewPoints(usize),
    /// The points are collinear (or coincide) in the `xy`-plane: no unique plane.
    #[error("plane fit is degenerate: the {0} points are collinear in the xy-plane")]
    Collinear(usize),
    /// An input value is NaN or infinite.
    #[error("{what} = {value} must be finite")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// The two endpoints of a trace have the same lateral coordinate.
    #[error("degenerate endpoints: {axis}2 = {axis}1 = {value} µm, the trace has zero length")]
    DegenerateEndpoints {
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// The common coordinate, µm.
        value: f64,
    },
    /// A normal does not point into the upper hemisphere (`nz ≤ 0`) or has zero length.
    #[error("normal ({0}, {1}, {2}) must have nz > 0")]
    BadNormal(f64, f64, f64),
    /// A tilt angle is outside `(−π/2, π/2)`.
    #[error("tilt {what} = {value} rad must lie in (-π/2, π/2)")]
    BadTilt {
        /// `"theta_x"` or `"theta_y"`.
        what: &'static str,
        /// Its value, radians.
        value: f64,
    },
    /// An area is not positive.
    #[error("flake area {0} µm² must be finite and > 0")]
    BadArea(f64),
}

/// One flake: its unit normal, its true (not projected) area and optionally its centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flake {
    /// Unit normal, `z > 0`.
    pub normal: UnitVec3,
    /// Flake area, µm² (the area of the flake itself, not its projection on `xy`).
    pub area_um2: f64,
    /// Centre `(x, y)` in map coordinates, µm, when known.
    pub centre_um: Option<[f64; 2]>,
}

impl Flake {
    /// A flake from a normal and an area, checked (`nz > 0`, area finite and `> 0`).
    ///
    /// # Errors
    /// [`FlakeError::BadNormal`], [`FlakeError::BadArea`].
    pub fn new(normal: Vector3<f64>, area_um2: f64) -> Result<Self, FlakeError> {
        if !(area_um2.is_finite() && area_um2 > 0.0) {
            return Err(FlakeError::BadArea(area_um2));
        }
        Ok(Self {
            normal: checked_normal(normal)?,
            area_um2,
            centre_um: None,
        })
    }

    /// A flake from the endpoints of two perpendicular traces (eqs. 6, 7): `(x1, z1)`,
    /// `(x2, z2)` along a line of constant `y`, and `(y1, zy1)`, `(y2, zy2)` along a line of
    /// constant `x`, all µm. The area is [`endpoint_area`].
    ///
    /// # Errors
    /// As [`endpoint_tilts`].
    #[allow(clippy::too_many_arguments)]
    pub fn from_endpoints(
        x1: f64,
        z1: f64,
        x2: f64,
        z2: f64,
        y1: f64,
        zy1: f64,
        y2: f64,
        zy2: f64,
    ) -> Result<Self, FlakeError> {
        let (tx, ty) = endpoint_tilts(x1, z1, x2, z2, y1, zy1, y2, zy2)?;
        let area = endpoint_area(x2 - x1, y2 - y1, tx, ty);
        Ok(Self {
            normal: normal_from_tilts(tx, ty)?,
            area_um2: area,
            centre_um: None,
        })
    }

    /// Polar angle `θn` of the normal, radians.
    pub fn theta_n(&self) -> f64 {
        polar_from_normal(&self.normal).0
    }
}

fn checked_normal(n: Vector3<f64>) -> Result<UnitVec3, FlakeError> {
    let bad = || FlakeError::BadNormal(n.x, n.y, n.z);
    if !(n.x.is_finite() && n.y.is_finite() && n.z.is_finite()) || n.z <= 0.0 {
        return Err(bad());
    }
    Unit::try_new(n, 0.0).ok_or_else(bad)
}

fn finite(what: &'static str, value: f64) -> Result<f64, FlakeError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(FlakeError::NonFinite { what, value })
    }
}

/// Result of a least-squares plane fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFit {
    /// Slope `a = ∂z/∂x` (dimensionless).
    pub a: f64,
    /// Slope `b = ∂z/∂y` (dimensionless).
    pub b: f64,
    /// Height `c` at `x = y = 0`, µm.
    pub c: f64,
    /// Unit normal `(−a, −b, 1)/sqrt(1 + a² + b²)`.
    pub normal: UnitVec3,
    /// Root mean square of the height residuals `z − (a x + b y + c)`, µm
    /// (divided by the number of points).
    pub rms_um: f64,
}

/// Least-squares plane `z = a x + b y + c` through points `(x, y, z)` in µm (paper eq. 5),
/// minimising the vertical residuals. Solved on coordinates centred on the centroid.
///
/// # Errors
/// [`FlakeError::TooFewPoints`] for fewer than 3 points, [`FlakeError::NonFinite`] for a
/// NaN/infinite coordinate, [`FlakeError::Collinear`] when the `xy` positions do not
/// span a plane (relative determinant below 1e-12).
pub fn fit_plane(points: &[[f64; 3]]) -> Result<PlaneFit, FlakeError> {
    let n = points.len();
    if n < 3 {
        return Err(FlakeError::TooFewPoints(n));
    }
    for p in points {
        finite("x", p[0])?;
        finite("y", p[1])?;
        finite("z", p[2])?;
    }
    let nf = n as f64;
    let (mx, my, mz) = points.iter().fold((0.0, 0.0, 0.0), |(a, b, c), p| {
        (a + p[0] / nf, b + p[1] / nf, c + p[2] / nf)
    });
    let (mut sxx, mut syy, mut sxy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in points {
        let (x, y, z) = (p[0] - mx, p[1] - my, p[2] - mz);
        sxx += x * x;
        syy += y * y;
        sxy += x * y;
        sxz += x * z;
        syz += y * z;
    }
    let det = sxx * syy - sxy * sxy;
    if det.is_nan() || det <= 1e-12 * (sxx * syy).max(f64::MIN_POSITIVE) {
        return Err(FlakeError::Collinear(n));
    }
    let a = (sxz * syy - syz * sxy) / det;
    let b = (syz * sxx - sxz * sxy) / det;
    let c = mz - a * mx - b * my;
    let ss: f64 = points
        .iter()
        .map(|p| {
            let r = p[2] - (a * p[0] + b * p[1] + c);
            r * r
        })
        .sum();
    let normal = Unit::new_normalize(Vector3::new(-a, -b, 1.0));
    Ok(PlaneFit {
        a,
        b,
        c,
        normal,
        rms_um: (ss / nf).sqrt(),
    })
}

/// Signed tilts `(θx, θy)` in radians from the endpoints of two traces (paper eq. 6):
/// `tan θx = (z2 − z1)/(x2 − x1)` along a line of constant `y`,
/// `tan θy = (zy2 − zy1)/(y2 − y1)` along a line of constant `x`; all inputs µm.
/// The paper squares these (`tan² θn = tan² θx + tan² θy`); the signs are kept here so
/// the azimuth of the normal is known too.
///
/// # Errors
/// [`FlakeError::NonFinite`] for a NaN/infinite input,
/// [`FlakeError::DegenerateEndpoints`] if `x2 = x1` or `y2 = y1`.
#[allow(clippy::too_many_arguments)]
pub fn endpoint_tilts(
    x1: f64,
    z1: f64,
    x2: f64,
    z2: f64,
    y1: f64,
    zy1: f64,
    y2: f64,
    zy2: f64,
) -> Result<(f64, f64), FlakeError> {
    for (what, v) in [
        ("x1", x1),
        ("z1", z1),
        ("x2", x2),
        ("z2", z2),
        ("y1", y1),
        ("zy1", zy1),
        ("y2", y2),
        ("zy2", zy2),
    ] {
        finite(what, v)?;
    }
    if x2 == x1 {
        return Err(FlakeError::DegenerateEndpoints {
            axis: "x",
            value: x1,
        });
    }
    if y2 == y1 {
        return Err(FlakeError::DegenerateEndpoints {
            axis: "y",
            value: y1,
        });
    }
    Ok((
        ((z2 - z1) / (x2 - x1)).atan(),
        ((zy2 - zy1) / (y2 - y1)).atan(),
    ))
}

/// Flake area estimate of paper eq. 7, µm²: `|Δx| |Δy| / (cos θx cos θy)` for traces of
/// lateral lengths `Δx`, `Δy` (µm) and tilts `θx`, `θy` (radians).
///
/// This is the paper's estimate, used as a relative weight. The exact area of a plane
/// over the rectangle `Δx × Δy` is `|Δx Δy| sqrt(1 + tan² θx + tan² θy)`; eq. 7 is larger
/// by the factor `sqrt(1 + tan² θx tan² θy / (1 + tan² θx + tan² θy))`, under 0.01 % for
/// tilts below 6°.
pub fn endpoint_area(dx_um: f64, dy_um: f64, theta_x: f64, theta_y: f64) -> f64 {
    (dx_um * dy_um).abs() / (theta_x.cos() * theta_y.cos())
}

/// Unit normal of a plane with tilts `(θx, θy)` (radians): `∝ (−tan θx, −tan θy, 1)`.
///
/// # Errors
/// [`FlakeError::BadTilt`] unless both tilts are in `(−π/2, π/2)`.
pub fn normal_from_tilts(theta_x: f64, theta_y: f64) -> Result<UnitVec3, FlakeError> {
    for (what, value) in [("theta_x", theta_x), ("theta_y", theta_y)] {
        if value.is_nan() || value.abs() >= FRAC_PI_2 {
            return Err(FlakeError::BadTilt { what, value });
        }
    }
    Ok(Unit::new_normalize(Vector3::new(
        -theta_x.tan(),
        -theta_y.tan(),
        1.0,
    )))
}

/// Tilts `(θx, θy)` (radians) of a flake with unit normal `n` (`nz > 0`):
/// `θx = atan(−nx/nz)`, `θy = atan(−ny/nz)`.
///
/// # Errors
/// [`FlakeError::BadNormal`] if `nz ≤ 0` or a component is not finite.
pub fn tilts_from_normal(n: &Vector3<f64>) -> Result<(f64, f64), FlakeError> {
    let u = checked_normal(*n)?;
    Ok(((-u.x / u.z).atan(), (-u.y / u.z).atan()))
}

/// Polar angle `θn ∈ [0, π]` and azimuth `φn ∈ [0, 2π)` of a unit vector, radians
/// (`θn` via `atan2(sqrt(nx² + ny²), nz)`, accurate near 0).
pub fn polar_from_normal(n: &UnitVec3) -> (f64, f64) {
    let t = n.x.hypot(n.y).atan2(n.z);
    let mut phi = n.y.atan2(n.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    if phi >= 2.0 * PI {
        phi = 0.0;
    }
    (t, phi)
}

/// Unit normal with polar angle `θn` and azimuth `φn` (radians):
/// `(sin θn cos φn, sin θn sin φn, cos θn)`.
pub fn normal_from_polar(theta_n: f64, phi_n: f64) -> UnitVec3 {
    let (st, ct) = theta_n.sin_cos();
    let (sp, cp) = phi_n.sin_cos();
    Unit::new_normalize(Vector3::new(st * cp, st * sp, ct))
}

/// Tilts `(θx, θy)` from `(θn, φn)`, radians: `tan θx = −tan θn cos φn`,
/// `tan θy = −tan θn sin φn`.
///
/// # Errors
/// [`FlakeError::BadNormal`] if `θn ≥ π/2`.
pub fn tilts_from_polar(theta_n: f64, phi_n: f64) -> Result<(f64, f64), FlakeError> {
    tilts_from_normal(&normal_from_polar(theta_n, phi_n).into_inner())
}
