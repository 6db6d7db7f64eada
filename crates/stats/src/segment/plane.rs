//! Exact least-squares planes from running sums, shared by the split and merge stages.
//!
//! Contract: [`Sums`] accumulates `(x, y, z)` points (µm, relative to a fixed origin)
//! and can be added; [`Sums::plane`] gives the least-squares plane `z = a x + b y + c`
//! (paper eq. 5) with its residual sum of squares, or `None` for fewer than 3 points or
//! collinear ones. Nothing here looks at the map.

use nalgebra::{Unit, Vector3};

use crate::flake::UnitVec3;

/// Sums over points `(x, y, z)` for an exact least-squares plane (coordinates relative
/// to a fixed origin).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Sums {
    pub(super) n: f64,
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) z: f64,
    pub(super) xx: f64,
    pub(super) xy: f64,
    pub(super) yy: f64,
    pub(super) xz: f64,
    pub(super) yz: f64,
    pub(super) zz: f64,
}

#[derive(Debug, Clone, Copy)]
pub(super) struct Plane {
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) c: f64,
    /// Residual sum of squares.
    pub(super) sse: f64,
    /// `(Sxx + Syy) / det` of the centred normal equations, 1/µm².
    pub(super) se_factor: f64,
}

impl Sums {
    pub(super) fn add(&mut self, p: [f64; 3]) {
        let [x, y, z] = p;
        self.n += 1.0;
        self.x += x;
        self.y += y;
        self.z += z;
        self.xx += x * x;
        self.xy += x * y;
        self.yy += y * y;
        self.xz += x * z;
        self.yz += y * z;
        self.zz += z * z;
    }

    pub(super) fn plus(&self, o: &Self) -> Self {
        Self {
            n: self.n + o.n,
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
            xx: self.xx + o.xx,
            xy: self.xy + o.xy,
            yy: self.yy + o.yy,
            xz: self.xz + o.xz,
            yz: self.yz + o.yz,
            zz: self.zz + o.zz,
        }
    }

    /// Sum of squared residuals of these points about the plane `p`.
    pub(super) fn sse_about(&self, p: &Plane) -> f64 {
        let (a, b, c) = (p.a, p.b, p.c);
        (self.zz - 2.0 * (a * self.xz + b * self.yz + c * self.z)
            + a * a * self.xx
            + 2.0 * a * b * self.xy
            + b * b * self.yy
            + 2.0 * c * (a * self.x + b * self.y)
            + c * c * self.n)
            .max(0.0)
    }

    /// Least-squares plane `z = a x + b y + c`; `None` if fewer than 3 points or the
    /// points are collinear.
    pub(super) fn plane(&self) -> Option<Plane> {
        let n = self.n;
        if n < 3.0 {
            return None;
        }
        let (mx, my, mz) = (self.x / n, self.y / n, self.z / n);
        let sxx = self.xx - n * mx * mx;
        let syy = self.yy - n * my * my;
        let sxy = self.xy - n * mx * my;
        let sxz = self.xz - n * mx * mz;
        let syz = self.yz - n * my * mz;
        let szz = self.zz - n * mz * mz;
        let det = sxx * syy - sxy * sxy;
        if det.is_nan() || det <= 1e-9 * (sxx * syy).max(f64::MIN_POSITIVE) {
            return None;
        }
        let a = (sxz * syy - syz * sxy) / det;
        let b = (syz * sxx - sxz * sxy) / det;
        let c = mz - a * mx - b * my;
        let sse = (szz - a * sxz - b * syz).max(0.0);
        Some(Plane {
            a,
            b,
            c,
            sse,
            se_factor: (sxx + syy) / det,
        })
    }
}

/// Sums of the points `pts[k]` with `keep(k)`.
pub(super) fn fit_sums(pts: &[[f64; 3]], keep: impl Fn(usize) -> bool) -> Sums {
    let mut s = Sums::default();
    for (k, p) in pts.iter().enumerate() {
        if keep(k) {
            s.add(*p);
        }
    }
    s
}

/// Unit normal `(−a, −b, 1)/|…|` of the plane `z = a x + b y + c`.
pub(super) fn normal_of(p: &Plane) -> UnitVec3 {
    Unit::new_normalize(Vector3::new(-p.a, -p.b, 1.0))
}
