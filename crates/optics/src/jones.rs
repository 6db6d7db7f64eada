//! Jones calculus of one ray through the coating: refraction in, reflection by a flake
//! in the flake's own plane of incidence, refraction out (physics.md §11).
//!
//! # Conventions (SCATMECH's, so that results compare element by element)
//! * Jones vectors are field components `(E_s, E_p)` in a right-handed basis
//!   `{s, p, k}` of the propagation direction `k`: `s = (z × k)/|z × k|` (horizontal,
//!   perpendicular to the plane that contains `k` and the coating normal `z`) and
//!   `p = k × s`. For a direction along `±z` exactly, `s = y` (a detector at the
//!   pole instead takes the basis of its azimuth, [`crate::detector::Cone::basis_s`]).
//!   For the incident
//!   direction `k_in = (sin θi, 0, −cos θi)` this gives `s = y`,
//!   `p = (cos θi, 0, sin θi)`; for an exit direction `(θr, φr)`,
//!   `s = (−sin φr, cos φr, 0)`, `p = (−cos θr cos φr, −cos θr sin φr, sin θr)`.
//! * Time dependence `exp(−iωt)`: an absorbing index is `n + ik` with `k ≥ 0`.
//! * A [`JonesMatrix`] `J` maps the incident field to the outgoing one,
//!   `E_out = J E_in`; `J[(a, b)]` with index 0 = s, 1 = p, row = outgoing basis,
//!   column = incident basis. (SCATMECH stores the same four numbers as
//!   `{pp, ss, ps, sp}` with `ps` = p→s.)
//! * At each interface the Fresnel amplitudes of physics.md §2 hold in the local basis
//!   `{s, p = k × s}` shared by the incoming and outgoing wave (`s` perpendicular to
//!   the local plane of incidence): `rs = (n1 c1 − n2 c2)/(n1 c1 + n2 c2)`,
//!   `rp = (n2 c1 − n1 c2)/(n2 c1 + n1 c2)`, `ts = 2 n1 c1/(n1 c1 + n2 c2)`,
//!   `tp = 2 n1 c1/(n2 c1 + n1 c2)`. A perfect conductor has `rs = −1`, `rp = +1`.
//! * The frame rotations between the planes of incidence (clear coat → flake → clear
//!   coat) are the dot products of the basis vectors: both bases of a direction are
//!   right-handed about it, so each rotation is `[[c, d], [−d, c]]`.
//!
//! [`RayPath::transfer`] gives the amplitude matrix of the whole path and the power
//! factor `(cos θt/cos θi)(cos θo/cos θ2)` that turns amplitudes into fractions of the
//! incident beam power (the beam cross-section and index changes at the two crossings).
//! Its Mueller matrix ([`Transfer::mueller`]) generalises the scalar Fresnel product of
//! [`crate::polarization::Transmission::path_factor`]: in the plane of incidence its
//! `m00` is `½(Ts Rs Ts' + Tp Rp Tp')` exactly.
//!
//! # Example
//! A flat perfect mirror under a coat of index 1.5 at 60° incidence: s and p do not
//! mix, and the unpolarised fraction leaving is `½(Ts² + Tp²)`:
//! ```
//! use flakescatter_optics::jones::{PathAmplitudes, RayPath, exit_amplitudes};
//! use flakescatter_optics::{Vec3, detector, fresnel, refraction};
//!
//! let (n, ti) = (1.5, 60f64.to_radians());
//! let k_in = detector::incident_direction(ti);
//! let k1 = refraction::into_coating(&k_in, n);
//! let k2 = Vec3::new(k1.x, k1.y, -k1.z);
//! let path = RayPath { k_in: k_in.into_inner(), k1: k1.into_inner(), m: Vec3::z(), k2, k_out: detector::specular_direction(ti).into_inner() };
//! let [_, _, ts, tp] = fresnel::amplitudes_air_to_coating(ti, n);
//! let amps = PathAmplitudes { entry: (ts, tp), flake: flakescatter_optics::flake::FlakeReflectance::PerfectConductor.amplitudes(1.0, n), exit: exit_amplitudes(ti.cos(), k2.z, n) };
//! let m = path.transfer(&amps).mueller();
//! let p = fresnel::air_to_coating(ti, n);
//! assert!((m.m00() - 0.5 * (p.ts * p.ts + p.tp * p.tp)).abs() < 1e-14);
//! assert!(m.get(0, 2).abs() < 1e-15);
//! ```

use nalgebra::{Complex, Matrix4};

use crate::Vec3;
use crate::mueller::Mueller;

/// A complex amplitude.
pub type C64 = Complex<f64>;

/// A 2 × 2 Jones matrix in the `(s, p)` bases of the module docs: row = outgoing
/// component, column = incident component.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JonesMatrix(pub [[C64; 2]; 2]);

impl JonesMatrix {
    /// The zero matrix (no light).
    pub const ZERO: Self = Self([[C64::new(0.0, 0.0); 2]; 2]);

    /// The diagonal matrix `diag(s, p)`: an interface in its own plane of incidence.
    #[must_use]
    pub fn diagonal(s: C64, p: C64) -> Self {
        let z = C64::new(0.0, 0.0);
        Self([[s, z], [z, p]])
    }

    /// Element `(row, column)`, 0 = s, 1 = p.
    #[must_use]
    pub fn get(&self, row: usize, col: usize) -> C64 {
        self.0[row][col]
    }

    /// The matrix product `self · other` (apply `other` first).
    #[must_use]
    pub fn mul(&self, other: &Self) -> Self {
        let a = &self.0;
        let b = &other.0;
        Self([
            [
                a[0][0] * b[0][0] + a[0][1] * b[1][0],
                a[0][0] * b[0][1] + a[0][1] * b[1][1],
            ],
            [
                a[1][0] * b[0][0] + a[1][1] * b[1][0],
                a[1][0] * b[0][1] + a[1][1] * b[1][1],
            ],
        ])
    }

    /// `k · self` for a real `k`.
    #[must_use]
    pub fn scale(&self, k: f64) -> Self {
        let a = &self.0;
        Self([[a[0][0] * k, a[0][1] * k], [a[1][0] * k, a[1][1] * k]])
    }

    /// `R · self` with the frame rotation `R = [[c, d], [−d, c]]` on the outgoing side
    /// ([`exit_frame`]).
    #[must_use]
    #[inline]
    pub fn rotate_out(&self, (c, d): (f64, f64)) -> Self {
        let a = &self.0;
        Self([
            [a[0][0] * c + a[1][0] * d, a[0][1] * c + a[1][1] * d],
            [a[1][0] * c - a[0][0] * d, a[1][1] * c - a[0][1] * d],
        ])
    }

    /// The Mueller matrix of this Jones matrix (Stokes convention of [`crate::mueller`]).
    #[must_use]
    pub fn mueller(&self) -> Mueller {
        Mueller::from_jones(self)
    }
}

/// The `s` basis vector of the direction `k` (module docs): `(z × k)/|z × k|`, or `y`
/// when `k` is along `±z`.
#[must_use]
#[inline]
pub fn s_vector(k: &Vec3) -> Vec3 {
    // |k| = 1, so x² + y² neither overflows nor underflows to a wrong zero here.
    let rho2 = k.x * k.x + k.y * k.y;
    if rho2 > 0.0 {
        let inv = 1.0 / rho2.sqrt();
        Vec3::new(-k.y * inv, k.x * inv, 0.0)
    } else {
        Vec3::y()
    }
}

/// The `(s, p)` basis of the direction `k` (module docs): `p = k × s`.
#[must_use]
pub fn sp_basis(k: &Vec3) -> (Vec3, Vec3) {
    let s = s_vector(k);
    (s, k.cross(&s))
}

/// The frame rotation `(c, d)` that re-expresses a field of direction `k`, given in the
/// basis `(s, p)` of [`sp_basis`], in the basis `(s', k × s')` with
/// `s' = (u − (u·k) k)/|u − (u·k) k|` the unit vector `reference = u` projected
/// perpendicular to `k`: `c = s'·s`, `d = s'·p`, the rotation `[[c, d], [−d, c]]`
/// ([`JonesMatrix::rotate_out`]). Used to give everything a detector cone collects in
/// the basis of its axis (`u` = the axis's `s`); `reference` must not be parallel to
/// `k`.
#[must_use]
#[inline]
pub fn exit_frame(k: &Vec3, reference: &Vec3) -> (f64, f64) {
    let (s, p) = sp_basis(k);
    let v = reference - k * reference.dot(k);
    let inv = 1.0 / v.norm();
    (v.dot(&s) * inv, v.dot(&p) * inv)
}

/// Amplitude transmission coefficients `(ts, tp)` of the crossing from the coating
/// (index `n`, inside cosine `cos_inside`) out into air (cosine `cos_outside`),
/// Snell-related: `ts = 2n c2/(n c2 + co)`, `tp = 2n c2/(c2 + n co)` (module docs with
/// `n1 = n`, `n2 = 1`).
#[must_use]
#[inline]
pub fn exit_amplitudes(cos_outside: f64, cos_inside: f64, n: f64) -> (f64, f64) {
    let a = 2.0 * n * cos_inside;
    (
        a / (n * cos_inside + cos_outside),
        a / (cos_inside + n * cos_outside),
    )
}

/// The exit amplitudes of an ideal, reflection-free crossing that transmits all the
/// power in both polarisations: `t = sqrt(n cos θ2 / cos θo)` (so that the power
/// transmittance `(cos θo / (n cos θ2)) |t|²` is 1). Used where the exit Fresnel loss
/// is switched off.
#[must_use]
#[inline]
pub fn lossless_exit_amplitude(cos_outside: f64, cos_inside: f64, n: f64) -> f64 {
    (n * cos_inside / cos_outside).sqrt()
}

/// The amplitude coefficients met along one ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathAmplitudes {
    /// Entry crossing, air → coating, `(ts, tp)` at `θi` (real for a lossless coat).
    pub entry: (f64, f64),
    /// Flake reflection `(rs, rp)` at the local angle (complex for a metal).
    pub flake: (C64, C64),
    /// Exit crossing, coating → air, `(ts, tp)` ([`exit_amplitudes`]).
    pub exit: (f64, f64),
}

/// The four directions of a ray through the coating (unit propagation vectors, frame of
/// physics.md §1) and the flake normal that links them (any positive multiple of it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayPath {
    /// Incident direction in air, `k_in.z < 0`.
    pub k_in: Vec3,
    /// Refracted into the coating, `k1.z < 0`.
    pub k1: Vec3,
    /// Flake normal on its lit side (`k2 = k1 − 2 (k1·m) m` for the unit normal), or
    /// any positive multiple of it (the internal half vector `k2 − k1`).
    pub m: Vec3,
    /// Reflected by the flake, `k2.z > 0`.
    pub k2: Vec3,
    /// Refracted out into air, `k_out.z > 0`.
    pub k_out: Vec3,
}

/// The amplitude matrix of a path with the factor that turns it into power.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transfer {
    /// Jones matrix of the path (amplitudes), incident basis of `k_in` to outgoing
    /// basis of `k_out`.
    pub jones: JonesMatrix,
    /// `(cos θt / cos θi)(cos θo / cos θ2)`: the outgoing power is this times
    /// `|J E|²` for a unit incident beam (module docs).
    pub power_scale: f64,
}

impl Transfer {
    /// The Mueller matrix of the path as a fraction of the incident beam power (no
    /// unit): `power_scale · M(J)`.
    #[must_use]
    pub fn mueller(&self) -> Mueller {
        self.jones.mueller() * self.power_scale
    }

    /// `(m00, m01)` of [`Transfer::mueller`], without the other 14 elements: the
    /// fraction of an unpolarised beam that leaves (`m00`), and what an s (`m00 + m01`)
    /// or p (`m00 − m01`) polarised beam gives with every polarisation detected.
    #[must_use]
    #[inline]
    pub fn first_row(&self) -> (f64, f64) {
        let j = &self.jones.0;
        let ss = j[0][0].norm_sqr();
        let sp = j[0][1].norm_sqr();
        let ps = j[1][0].norm_sqr();
        let pp = j[1][1].norm_sqr();
        let h = 0.5 * self.power_scale;
        // Column 0 is the s input, column 1 the p input.
        (h * (ss + sp + ps + pp), h * (ss + ps - sp - pp))
    }
}

impl RayPath {
    /// The Jones matrix of the path and its power factor (module docs).
    ///
    /// The local basis on the flake has `s_f = (k1 × m)/|k1 × m|` (so `m` may be any
    /// positive multiple of the unit normal); at normal local incidence (`k1 ∥ m`,
    /// where every basis gives the same result) the incident `s` is used. Zero `k_in.z`
    /// or `k2.z` make the power factor meaningless; callers pass rays that reach the
    /// flake and leave the coating.
    #[must_use]
    #[inline]
    pub fn transfer(&self, amps: &PathAmplitudes) -> Transfer {
        let ([a, b, g, d], k2) = self.rotations();
        let k = k2.sqrt();
        let (rs, rp) = amps.flake;
        let (ts, tp) = amps.entry;
        let (us, up) = amps.exit;
        // B = R2 · diag(rs, rp) · R1 with R = [[c, d], [−d, c]]:
        // a = c2 c1, b = d2 d1, g = c2 d1, d = d2 c1.
        let b00 = rs * a - rp * b;
        let b01 = rs * g + rp * d;
        let b10 = -(rs * d + rp * g);
        let b11 = rp * a - rs * b;
        let jones = JonesMatrix([
            [b00 * (k * us * ts), b01 * (k * us * tp)],
            [b10 * (k * up * ts), b11 * (k * up * tp)],
        ]);
        Transfer {
            jones,
            power_scale: self.power_scale(),
        }
    }

    /// [`Transfer::first_row`] of [`RayPath::transfer`], `(m00, m01)` of the path's
    /// Mueller matrix, in real arithmetic: with `Rs = |rs|²`, `Rp = |rp|²`,
    /// `X = Re(rs rp*)` and the rotation products of [`RayPath::transfer`],
    /// `|B00|² = Rs a² + Rp b² − 2X ab`, `|B11|² = Rp a² + Rs b² − 2X ab`,
    /// `|B01|² = Rs g² + Rp d² + 2X gd`, `|B10|² = Rs d² + Rp g² + 2X gd`. What the
    /// scalar models need.
    #[must_use]
    #[inline(always)]
    pub fn first_row(&self, amps: &PathAmplitudes) -> (f64, f64) {
        let ([a, b, g, d], k2) = self.rotations();
        let (rs, rp) = amps.flake;
        let (big_rs, big_rp) = (rs.norm_sqr(), rp.norm_sqr());
        let x2 = 2.0 * (rs.re * rp.re + rs.im * rp.im);
        let (ab, gd) = (x2 * a * b, x2 * g * d);
        let (aa, bb, gg, dd) = (a * a, b * b, g * g, d * d);
        let b00 = big_rs * aa + big_rp * bb - ab;
        let b11 = big_rp * aa + big_rs * bb - ab;
        let b01 = big_rs * gg + big_rp * dd + gd;
        let b10 = big_rs * dd + big_rp * gg + gd;
        let (ts, tp) = amps.entry;
        let (us, up) = amps.exit;
        let (ts2, tp2, us2, up2) = (ts * ts, tp * tp, us * us, up * up);
        // |J_ab|² = u_a² |B_ab|² t_b²; column 0 is the s input, column 1 the p input.
        let ss = us2 * ts2 * b00;
        let sp = us2 * tp2 * b01;
        let ps = up2 * ts2 * b10;
        let pp = up2 * tp2 * b11;
        let h = 0.5 * self.power_scale() * k2;
        (h * (ss + sp + ps + pp), h * (ss + ps - sp - pp))
    }

    /// `(cos θt / cos θi)(cos θo / cos θ2)`.
    #[inline]
    fn power_scale(&self) -> f64 {
        (self.k1.z * self.k_out.z) / (self.k_in.z * self.k2.z)
    }

    /// The products `[c2 c1, d2 d1, c2 d1, d2 c1]` of the two frame rotations (entry
    /// basis `(s0, p1)` to the flake's `(sf, k1 × sf)`, flake's outgoing `(sf, k2 × sf)`
    /// to the exit basis `(so, k2 × so)`, each `[[c, d], [−d, c]]`), built from the
    /// unnormalised vectors `z × k_in`, `z × k_out`, `k1 × m`, with the factor
    /// `K² = 1/(|z × k_in|² |z × k_out|² |k1 × m|⁴)` that normalises their squares.
    #[inline]
    fn rotations(&self) -> ([f64; 4], f64) {
        let (ki, k1, m, k2, ko) = (&self.k_in, &self.k1, &self.m, &self.k2, &self.k_out);
        // Horizontal s vectors z × k = (−k.y, k.x, 0) and their squared lengths
        // (y and 1 for a direction along ±z). Written out in scalars: this is the inner
        // loop of both models.
        let (mut s0x, mut s0y, mut rho_in2) = (-ki.y, ki.x, ki.x * ki.x + ki.y * ki.y);
        if rho_in2 == 0.0 {
            (s0x, s0y, rho_in2) = (0.0, 1.0, 1.0);
        }
        let (mut sox, mut soy, mut rho_out2) = (-ko.y, ko.x, ko.x * ko.x + ko.y * ko.y);
        if rho_out2 == 0.0 {
            (sox, soy, rho_out2) = (0.0, 1.0, 1.0);
        }
        // c = k1 × m (|c| = sin ι); s0 itself at normal local incidence.
        let (mut cx, mut cy, mut cz) = (
            k1.y * m.z - k1.z * m.y,
            k1.z * m.x - k1.x * m.z,
            k1.x * m.y - k1.y * m.x,
        );
        let mut c2n = cx * cx + cy * cy + cz * cz;
        if c2n == 0.0 {
            (cx, cy, cz, c2n) = (s0x, s0y, 0.0, rho_in2);
        }
        // p1 = k1 × s0 (|p1| = |s0|, s0 ⟂ k1) and k2 × c (|k2 × c| = |c|, c ⟂ k2).
        let (p1x, p1y, p1z) = (-k1.z * s0y, k1.z * s0x, k1.x * s0y - k1.y * s0x);
        let (qx, qy) = (k2.y * cz - k2.z * cy, k2.z * cx - k2.x * cz);
        let c1 = cx * s0x + cy * s0y;
        let d1 = cx * p1x + cy * p1y + cz * p1z;
        let c2 = sox * cx + soy * cy;
        let d2 = sox * qx + soy * qy;
        (
            [c2 * c1, d2 * d1, c2 * d1, d2 * c1],
            1.0 / (rho_in2 * rho_out2 * c2n * c2n),
        )
    }
}

/// The Jones matrix of the clear coat's specular reflection at the top surface,
/// `diag(rs, rp)` with the air → coating amplitudes of physics.md §2, from the incident
/// basis to the basis of the specular direction (module docs). The reflected beam has
/// the incident cross-section, so its Mueller matrix is directly a fraction of the
/// beam power (`m00 = R_av`).
#[must_use]
pub fn clearcoat_jones(rs: f64, rp: f64) -> JonesMatrix {
    JonesMatrix::diagonal(C64::new(rs, 0.0), C64::new(rp, 0.0))
}

/// The conversion lives beside the Jones matrices, so `mueller` needs nothing of this
/// module.
impl Mueller {
    /// The Mueller matrix of a Jones matrix (Stokes basis of [`crate::mueller`]), element by element. With
    /// `J = [[a, b], [c, d]]` (`a` = s→s, `b` = p→s, `c` = s→p, `d` = p→p):
    /// `m00 = ½(|a|²+|b|²+|c|²+|d|²)`, `m01 = ½(|a|²−|b|²+|c|²−|d|²)`,
    /// `m10 = ½(|a|²+|b|²−|c|²−|d|²)`, `m11 = ½(|a|²−|b|²−|c|²+|d|²)`,
    /// `m02 = Re(ab* + dc*)`, `m03 = Im(ab* − dc*)`, `m12 = Re(ab* − dc*)`,
    /// `m13 = Im(ab* + dc*)`, `m20 = Re(ac* + db*)`, `m21 = Re(ac* − db*)`,
    /// `m30 = Im(db* − ac*)`, `m31 = −Im(ac* + db*)`, `m22 = Re(da* + bc*)`,
    /// `m33 = Re(da* − bc*)`, `m23 = −Im(da* + bc*)`, `m32 = Im(da* − bc*)`
    /// (Bohren and Huffman's form, as SCATMECH writes it; equal to
    /// `½ tr(σ_i J σ_j J†)`, which the tests check).
    #[must_use]
    #[inline]
    pub fn from_jones(j: &JonesMatrix) -> Self {
        let [[a, b], [c, d]] = j.0;
        let (aa, bb, cc, dd) = (a.norm_sqr(), b.norm_sqr(), c.norm_sqr(), d.norm_sqr());
        let ab = a * b.conj();
        let dc = d * c.conj();
        let ac = a * c.conj();
        let db = d * b.conj();
        let da = d * a.conj();
        let bc = b * c.conj();
        Self(Matrix4::new(
            0.5 * (aa + bb + cc + dd),
            0.5 * (aa - bb + cc - dd),
            ab.re + dc.re,
            ab.im - dc.im,
            0.5 * (aa + bb - cc - dd),
            0.5 * (aa - bb - cc + dd),
            ab.re - dc.re,
            ab.im + dc.im,
            ac.re + db.re,
            ac.re - db.re,
            da.re + bc.re,
            -(da.im + bc.im),
            db.im - ac.im,
            -(ac.im + db.im),
            da.im - bc.im,
            da.re - bc.re,
        ))
    }
}
