//! One block of [`LANES`] exit directions, in four passes over structure-of-arrays
//! buffers (the parent module's docs give the arithmetic and its accuracy): the half
//! vector and the lanes that are zero or go to the scalar path; the density `p2` of the
//! normal; the flake reflectances; the path factor and the BRDF, then absorption, the
//! zero lanes and the scalar lanes.

use flakescatter_optics::Vec3;
use pulp::Simd;

use super::lanes::{V, atan2_first_quadrant, exp_parts, pow2_from_shifted};
use super::setup::{Density, Setup};
use super::{Buffers, LANES, MIN_VECTOR_EXPONENT, NEAR_HORIZON};
use crate::model::{DistributionModel, Incidence};

impl DistributionModel {
    /// All blocks of a batch, appended to the empty `out`. Inlined into the
    /// instruction-set build [`pulp::Arch::dispatch`] chose.
    #[inline(always)]
    pub(super) fn batch_blocks<S: Simd>(
        &self,
        simd: S,
        inc: &Incidence,
        s: &Setup,
        dirs: &[Vec3],
        out: &mut Vec<f64>,
        buf: &mut Buffers,
    ) {
        for d in dirs.chunks(LANES) {
            // Structure of arrays, padded with the zenith (a direction every lane can
            // compute).
            // (Two plain loops: an `Option` per lane cost 7 % of the kernel's time.)
            for (i, r) in d.iter().enumerate() {
                (buf.x[i], buf.y[i], buf.z[i]) = (r.x, r.y, r.z);
            }
            for i in d.len()..LANES {
                (buf.x[i], buf.y[i], buf.z[i]) = (0.0, 0.0, 1.0);
            }
            self.batch_block(simd, inc, s, d, buf);
            out.extend_from_slice(&buf.out[..d.len()]);
        }
    }

    /// One block of [`LANES`] directions in `buf.x`, `buf.y`, `buf.z` (module docs);
    /// `dirs` holds the first of them as given (fewer than [`LANES`] in the last block).
    #[inline(always)]
    fn batch_block<S: Simd>(
        &self,
        simd: S,
        inc: &Incidence,
        s: &Setup,
        dirs: &[Vec3],
        buf: &mut Buffers,
    ) {
        Self::half_vectors(simd, s, buf);
        self.densities(simd, s, buf);
        self.flake_reflectances(inc, s, buf);
        if let Some(columns) = s.columns {
            Self::brdf_lanes(simd, s, columns, buf);
        } else {
            self.brdf_paper(inc, s, dirs, buf);
        }
        self.finish_block(simd, inc, s, dirs, buf);
    }

    /// Pass 1: half vector, cos θ2, ρ, and the lanes that are zero or go scalar.
    #[inline(always)]
    fn half_vectors<S: Simd>(simd: S, s: &Setup, buf: &mut Buffers) {
        let [k1x, k1y, k1z] = s.k1;
        let n = s.n;
        let zero_v = V::splat(simd, 0.0);
        let (x, _) = S::as_simd_f64s(&buf.x);
        let (y, _) = S::as_simd_f64s(&buf.y);
        let (z, _) = S::as_simd_f64s(&buf.z);
        let (hx, _) = S::as_mut_simd_f64s(&mut buf.hx);
        let (hy, _) = S::as_mut_simd_f64s(&mut buf.hy);
        let (hz, _) = S::as_mut_simd_f64s(&mut buf.hz);
        let (k2x, _) = S::as_mut_simd_f64s(&mut buf.k2x);
        let (k2y, _) = S::as_mut_simd_f64s(&mut buf.k2y);
        let (c2, _) = S::as_mut_simd_f64s(&mut buf.c2);
        let (rho, _) = S::as_mut_simd_f64s(&mut buf.rho);
        let (zero, _) = S::as_mut_simd_f64s(&mut buf.zero);
        let (scalar, _) = S::as_mut_simd_f64s(&mut buf.scalar);
        for j in 0..x.len() {
            let (x, y, z) = (V(simd, x[j]), V(simd, y[j]), V(simd, z[j]));
            let q = z * z + s.n2m1;
            let c = q.gt(zero_v).pick(q, zero_v).sqrt() * s.inv_n;
            // `r_xy / n`, kept for pass 4 (two of the kernel's divisions).
            let (xn, yn) = (x / n, y / n);
            let h_x = xn - k1x;
            let h_y = yn - k1y;
            let h_z = c - k1z;
            let r = (h_x * h_x + h_y * h_y).sqrt();
            // A non-finite component makes the sum infinite or NaN (so does an
            // overflowing sum of huge components, which the scalar path then takes).
            let finite = (x + y + z).abs().le(V::splat(simd, f64::MAX));
            let is_zero = z.gt(zero_v).and(h_z.gt(zero_v)).not();
            let to_scalar = finite.not().or(h_z.lt(r * NEAR_HORIZON));
            (hx[j], hy[j], hz[j], c2[j], rho[j]) = (h_x.1, h_y.1, h_z.1, c.1, r.1);
            (k2x[j], k2y[j]) = (xn.1, yn.1);
            zero[j] = is_zero.ones().1;
            scalar[j] = to_scalar.ones().1;
        }
    }

    // Pass 2: the density p2 of the normal, as `s.p2_scale · buf.p2` (the Gaussian's
    // constant factor is applied with the other constants of pass 4).
    #[inline(always)]
    fn densities<S: Simd>(&self, simd: S, s: &Setup, buf: &mut Buffers) {
        let k1z = s.k1[2];
        let n = s.n;
        let zero_v = V::splat(simd, 0.0);
        match s.density {
            Density::Gaussian { k } => {
                {
                    let (rho, _) = S::as_simd_f64s(&buf.rho);
                    let (hz, _) = S::as_simd_f64s(&buf.hz);
                    let (e, _) = S::as_mut_simd_f64s(&mut buf.p2);
                    let (sh, _) = S::as_mut_simd_f64s(&mut buf.shifted);
                    let (scalar, _) = S::as_mut_simd_f64s(&mut buf.scalar);
                    let min = V::splat(simd, MIN_VECTOR_EXPONENT);
                    for j in 0..rho.len() {
                        let theta = atan2_first_quadrant(V(simd, rho[j]), V(simd, hz[j]));
                        let x = theta * k * theta;
                        let ok = x.ge(min);
                        scalar[j] = simd.max_f64s(ok.not().ones().1, scalar[j]);
                        let (er, shifted) = exp_parts(ok.pick(x, zero_v));
                        (e[j], sh[j]) = (er.1, shifted.1);
                    }
                }
                for i in 0..LANES {
                    buf.p2[i] *= pow2_from_shifted(buf.shifted[i]);
                }
            }
            Density::Table => {
                for i in 0..LANES {
                    if buf.zero[i] == 0.0 {
                        // h_z as the scalar path has it, to the bit.
                        let c2e = (s.n2m1 + buf.z[i] * buf.z[i]).max(0.0).sqrt() / n;
                        buf.p2[i] = self.orientation().p2(buf.rho[i].atan2(c2e - k1z));
                        if buf.p2[i] == 0.0 {
                            buf.zero[i] = 1.0;
                        }
                    } else {
                        buf.p2[i] = 0.0;
                    }
                }
            }
        }
    }

    /// Pass 3: flake reflectances, constants for the perfect conductor.
    #[inline(always)]
    fn flake_reflectances(&self, inc: &Incidence, s: &Setup, buf: &mut Buffers) {
        let n = s.n;
        if let Some((a, b, c)) = s.flake {
            buf.big_rs = [a; LANES];
            buf.big_rp = [b; LANES];
            buf.x2 = [c; LANES];
        } else {
            for i in 0..LANES {
                let h = Vec3::new(buf.hx[i], buf.hy[i], buf.hz[i]);
                let gamma = self.obliquity(inc, &h);
                let (rs, rp) = self.options().flake.amplitudes(gamma, n);
                buf.big_rs[i] = rs.norm_sqr();
                buf.big_rp[i] = rp.norm_sqr();
                buf.x2[i] = 2.0 * (rs.re * rp.re + rs.im * rp.im);
            }
        }
    }

    /// Pass 4, every transmission but `paper`: the path factor and the BRDF in
    /// vectors, with the columns' weights `(tsc, tpc)` ([`Setup::columns`]).
    #[inline(always)]
    fn brdf_lanes<S: Simd>(simd: S, s: &Setup, (tsc, tpc): (f64, f64), buf: &mut Buffers) {
        let [k1x, k1y, k1z] = s.k1;
        let n = s.n;
        let one = V::splat(simd, 1.0);
        let zero_v = V::splat(simd, 0.0);
        let [s0x, s0y] = s.s0;
        let [p1x, p1y, p1z] = s.p1;
        let (x, _) = S::as_simd_f64s(&buf.x);
        let (y, _) = S::as_simd_f64s(&buf.y);
        let (z, _) = S::as_simd_f64s(&buf.z);
        let (hx, _) = S::as_simd_f64s(&buf.hx);
        let (hy, _) = S::as_simd_f64s(&buf.hy);
        let (hz, _) = S::as_simd_f64s(&buf.hz);
        let (c2, _) = S::as_simd_f64s(&buf.c2);
        let (k2xs, _) = S::as_simd_f64s(&buf.k2x);
        let (k2ys, _) = S::as_simd_f64s(&buf.k2y);
        let (p2, _) = S::as_simd_f64s(&buf.p2);
        let (big_rs, _) = S::as_simd_f64s(&buf.big_rs);
        let (big_rp, _) = S::as_simd_f64s(&buf.big_rp);
        let (x2, _) = S::as_simd_f64s(&buf.x2);
        let (out, _) = S::as_mut_simd_f64s(&mut buf.out);
        for j in 0..x.len() {
            let (x, y, z) = (V(simd, x[j]), V(simd, y[j]), V(simd, z[j]));
            let (mx, my, mz) = (V(simd, hx[j]), V(simd, hy[j]), V(simd, hz[j]));
            let c2i = V(simd, c2[j]);
            let (big_rs, big_rp, x2) = (V(simd, big_rs[j]), V(simd, big_rp[j]), V(simd, x2[j]));
            // Frame rotations of `jones::RayPath::first_row`, same expressions.
            let rho_out2_raw = x * x + y * y;
            let at_zenith = rho_out2_raw.eq(zero_v);
            let sox = at_zenith.pick(zero_v, zero_v - y);
            let soy = at_zenith.pick(one, x);
            let rho_out2 = at_zenith.pick(one, rho_out2_raw);
            let cx0 = mz * k1y - my * k1z;
            let cy0 = mx * k1z - mz * k1x;
            let cz0 = my * k1x - mx * k1y;
            let c2n0 = cx0 * cx0 + cy0 * cy0 + cz0 * cz0;
            let normal = c2n0.eq(zero_v);
            let cx = normal.pick(one.k(s0x), cx0);
            let cy = normal.pick(one.k(s0y), cy0);
            let cz = normal.pick(zero_v, cz0);
            let c2n = normal.pick(one.k(s.rho_in2), c2n0);
            let (k2x, k2y) = (V(simd, k2xs[j]), V(simd, k2ys[j]));
            let qx = k2y * cz - c2i * cy;
            let qy = c2i * cx - k2x * cz;
            let rc1 = cx * s0x + cy * s0y;
            let rc2 = sox * cx + soy * cy;
            let rd2 = sox * qx + soy * qy;
            let (b00, b01, b10, b11) = if let Some([u1x, u1y, u1z]) = s.unit_flake {
                // `rd1` times ∓1, so that `aa + bb − ab = (a ± b)²` and
                // `gg + dd + ab = (g ∓ d)²` (module docs).
                let rd1 = cx * u1x + cy * u1y + cz * u1z;
                let u = rc2.mul_add(rc1, rd2 * rd1);
                let v = rd2.neg_mul_add(rc1, rc2 * rd1);
                let (b00, b01) = (u * u, v * v);
                (b00, b01, b01, b00)
            } else {
                let rd1 = cx * p1x + cy * p1y + cz * p1z;
                let (a, b, g, d) = (rc2 * rc1, rd2 * rd1, rc2 * rd1, rd2 * rc1);
                // `x2 a b`, which is also `x2 g d` (both are rc1 rc2 rd1 rd2).
                let ab = x2 * a * b;
                let (aa, bb, gg, dd) = (a * a, b * b, g * g, d * d);
                (
                    big_rs * aa + big_rp * bb - ab,
                    big_rs * gg + big_rp * dd + ab,
                    big_rs * dd + big_rp * gg + ab,
                    big_rp * aa + big_rs * bb - ab,
                )
            };
            // Columns: s input (b00, b10), p input (b01, b11); rows s, p.
            let s_row = b00.mul_add(one.k(tsc), b01 * tpc);
            let p_row = b10.mul_add(one.k(tsc), b11 * tpc);
            // f = ½ (k1_z r_z / (k_in,z c2)) K² (u_s² s_row + u_p² p_row) p2/⟨cos θn⟩
            //     / (4n² cos θt c2): with Fresnel, u² = (2n c2)²/e², whose c2²
            // cancels the two c2 of the denominator; lossless, u² = n c2/r_z.
            let es = c2i.mul_add(one.k(n), z);
            let ep = z.mul_add(one.k(n), c2i);
            let (rows, den_extra) = if s.exit_fresnel {
                let (es2, ep2) = (es * es, ep * ep);
                (ep2.mul_add(s_row, es2 * p_row), es2 * ep2)
            } else {
                (s_row + p_row, z * c2i)
            };
            let mut num = z * s.num_k * rows * V(simd, p2[j]);
            let mut den = rho_out2 * (c2n * c2n) * den_extra;
            if s.printed {
                num = num * c2i;
                den = den * z;
            }
            out[j] = (num / den).1;
        }
    }

    /// Pass 4 for `paper`: the product of averages per lane, as the scalar path has it.
    #[inline(always)]
    fn brdf_paper(&self, inc: &Incidence, s: &Setup, dirs: &[Vec3], buf: &mut Buffers) {
        let n = s.n;
        for (i, &r) in dirs.iter().enumerate() {
            if buf.zero[i] != 0.0 || buf.scalar[i] != 0.0 {
                continue;
            }
            let h = Vec3::new(buf.hx[i], buf.hy[i], buf.hz[i]);
            let c2e = (s.n2m1 + r.z * r.z).max(0.0).sqrt() / n;
            let k2 = Vec3::new(r.x / n, r.y / n, c2e);
            let factor = self.path_factor(inc, &h, self.obliquity(inc, &h), &k2, &r);
            let mut f = factor * (s.p2_scale * buf.p2[i]) * self.inv_mean_cos()
                / (4.0 * n * n * inc.cos_t * c2e);
            if s.printed {
                f *= c2e / r.z;
            }
            buf.out[i] = f;
        }
    }

    /// Binder absorption, the zero lanes, and the scalar path for the lanes that take
    /// it (only in a block that has such lanes: most have none).
    #[inline(always)]
    fn finish_block<S: Simd>(
        &self,
        simd: S,
        inc: &Incidence,
        s: &Setup,
        dirs: &[Vec3],
        buf: &mut Buffers,
    ) {
        let n = s.n;
        let zero_v = V::splat(simd, 0.0);
        if let Some(a) = self.absorption() {
            for i in 0..LANES {
                let c2e = (s.n2m1 + buf.z[i] * buf.z[i]).max(0.0).sqrt() / n;
                buf.out[i] *= a.factor(inc.cos_t, c2e);
            }
        }
        // Zero lanes in vectors; the scalar path only in a block that has such lanes
        // (most have none).
        let any_scalar = {
            let (out, _) = S::as_mut_simd_f64s(&mut buf.out);
            let (zero, _) = S::as_simd_f64s(&buf.zero);
            let (scalar, _) = S::as_simd_f64s(&buf.scalar);
            let mut any = zero_v;
            for j in 0..out.len() {
                let is_zero = V(simd, zero[j]).eq(zero_v).not();
                out[j] = is_zero.pick(zero_v, V(simd, out[j])).1;
                any = V(simd, simd.max_f64s(any.1, scalar[j]));
            }
            simd.reduce_max_f64s(any.1) != 0.0
        };
        if any_scalar {
            for (i, r) in dirs.iter().enumerate() {
                if buf.scalar[i] != 0.0 {
                    buf.out[i] = self.brdf(inc, r);
                }
            }
        }
    }
}
