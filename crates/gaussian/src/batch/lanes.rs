//! The kernel's vector type [`V`] (lanes of `f64` of an instruction set, with the
//! arithmetic operators and correctly rounded fused multiply-adds) and its lane mask,
//! and the two branch-free functions of the kernel: the first-quadrant arctangent and
//! the exponential as `2^k e^r` (the parent module's docs give their accuracy and why
//! the builds agree to the bit). Everything here is `#[inline(always)]`, so that it is
//! compiled into the instruction-set build the kernel's dispatch chose.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

use pulp::Simd;

/// `π/2 − FRAC_PI_2`, the part of `π/2` that `f64` does not hold (Cephes `MOREBITS`).
const MOREBITS: f64 = 6.123_233_995_736_766e-17;

/// Cephes `atan` numerator coefficients, highest degree first (in `z = x²`).
const ATAN_P: [f64; 5] = [
    -8.750_608_600_031_904e-1,
    -1.615_753_718_733_365e1,
    -7.500_855_792_314_705e1,
    -1.228_866_684_490_136e2,
    -6.485_021_904_942_025e1,
];
/// Cephes `atan` denominator coefficients below the leading 1, highest degree first.
const ATAN_Q: [f64; 5] = [
    2.485_846_490_142_306e1,
    1.650_270_098_316_988e2,
    4.328_810_604_912_903e2,
    4.853_903_996_359_137e2,
    1.945_506_571_482_614e2,
];

/// `1.5 · 2^52`: adding it rounds a number of magnitude below `2^51` to an integer,
/// which then sits in the low bits of the sum's representation.
const ROUND_SHIFTER: f64 = 6_755_399_441_055_744.0;

/// `ln 2` split so that `k · LN2_HI` is exact for `|k| < 2^21` (fdlibm's split, given
/// by its bits: 6.93147180369123816490e-1 and 1.90821492927058770002e-10).
const LN2_HI: f64 = f64::from_bits(0x3FE6_2E42_FEE0_0000);
const LN2_LO: f64 = f64::from_bits(0x3DEA_39EF_3579_3C76);

/// A vector of `f64` lanes of the instruction set `S` (one lane for the baseline
/// build), with the arithmetic operators; every method is inlined into the build
/// [`pulp::Arch::dispatch`] chose.
#[derive(Debug, Clone, Copy)]
pub(super) struct V<S: Simd>(pub(super) S, pub(super) S::f64s);

/// A lane mask of `S`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Mask<S: Simd>(S, S::m64s);

impl<S: Simd> V<S> {
    #[inline(always)]
    pub(super) fn splat(simd: S, v: f64) -> Self {
        Self(simd, simd.splat_f64s(v))
    }
    #[inline(always)]
    pub(super) fn k(self, v: f64) -> Self {
        Self::splat(self.0, v)
    }
    /// `self · b + c`, rounded once: pulp's `mul_add_f64s` is the correctly rounded
    /// fused multiply-add in every build (an instruction with FMA, software without),
    /// so the builds still agree to the bit (module docs).
    #[inline(always)]
    pub(super) fn mul_add(self, b: Self, c: Self) -> Self {
        Self(self.0, self.0.mul_add_f64s(self.1, b.1, c.1))
    }
    /// `c − self · b`, rounded once (as [`V::mul_add`]).
    #[inline(always)]
    pub(super) fn neg_mul_add(self, b: Self, c: Self) -> Self {
        Self(self.0, self.0.negate_mul_add_f64s(self.1, b.1, c.1))
    }
    /// [`V::mul_add`] with constants `b`, `c`.
    #[inline(always)]
    pub(super) fn mul_add_k(self, b: f64, c: f64) -> Self {
        self.mul_add(self.k(b), self.k(c))
    }
    #[inline(always)]
    pub(super) fn sqrt(self) -> Self {
        Self(self.0, self.0.sqrt_f64s(self.1))
    }
    #[inline(always)]
    pub(super) fn abs(self) -> Self {
        Self(self.0, self.0.abs_f64s(self.1))
    }
    #[inline(always)]
    pub(super) fn lt(self, o: Self) -> Mask<S> {
        Mask(self.0, self.0.less_than_f64s(self.1, o.1))
    }
    #[inline(always)]
    pub(super) fn gt(self, o: Self) -> Mask<S> {
        Mask(self.0, self.0.greater_than_f64s(self.1, o.1))
    }
    #[inline(always)]
    pub(super) fn ge(self, o: Self) -> Mask<S> {
        Mask(self.0, self.0.greater_than_or_equal_f64s(self.1, o.1))
    }
    #[inline(always)]
    pub(super) fn le(self, o: Self) -> Mask<S> {
        Mask(self.0, self.0.less_than_or_equal_f64s(self.1, o.1))
    }
    #[inline(always)]
    pub(super) fn eq(self, o: Self) -> Mask<S> {
        Mask(self.0, self.0.equal_f64s(self.1, o.1))
    }
}

impl<S: Simd> Mask<S> {
    /// `if self { t } else { f }` lane by lane.
    #[inline(always)]
    pub(super) fn pick(self, t: V<S>, f: V<S>) -> V<S> {
        V(self.0, self.0.select_f64s(self.1, t.1, f.1))
    }
    #[inline(always)]
    pub(super) fn or(self, o: Self) -> Self {
        Self(self.0, self.0.or_m64s(self.1, o.1))
    }
    #[inline(always)]
    pub(super) fn and(self, o: Self) -> Self {
        Self(self.0, self.0.and_m64s(self.1, o.1))
    }
    #[inline(always)]
    pub(super) fn not(self) -> Self {
        Self(self.0, self.0.not_m64s(self.1))
    }
    /// 1.0 where set, 0.0 elsewhere.
    #[inline(always)]
    pub(super) fn ones(self) -> V<S> {
        self.pick(V::splat(self.0, 1.0), V::splat(self.0, 0.0))
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $op:ident) => {
        impl<S: Simd> std::ops::$tr for V<S> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                Self(self.0, self.0.$op(self.1, o.1))
            }
        }
        impl<S: Simd> std::ops::$tr<f64> for V<S> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: f64) -> Self {
                Self(self.0, self.0.$op(self.1, self.0.splat_f64s(o)))
            }
        }
    };
}
binop!(Add, add, add_f64s);
binop!(Sub, sub, sub_f64s);
binop!(Mul, mul, mul_f64s);
binop!(Div, div, div_f64s);

/// `atan2(y, x)` for `y ≥ 0`, `x > 0` (finite), branch-free (module docs).
#[inline(always)]
pub(super) fn atan2_first_quadrant<S: Simd>(y: V<S>, x: V<S>) -> V<S> {
    let swap = y.gt(x);
    let (lo, hi) = (swap.pick(x, y), swap.pick(y, x));
    let reduce = lo.gt(hi * 0.66);
    let num = reduce.pick(lo - hi, lo);
    let den = reduce.pick(lo + hi, hi);
    let t = num / den;
    let z = t * t;
    // Estrin's scheme in `z` and `z²` (all terms of each polynomial have one sign, so
    // the order costs no accuracy).
    let z2 = z * z;
    let p = z2.mul_add(
        z2.mul_add(z.k(ATAN_P[0]), z.mul_add_k(ATAN_P[1], ATAN_P[2])),
        z.mul_add_k(ATAN_P[3], ATAN_P[4]),
    );
    let q = z2.mul_add(
        z2.mul_add(z + ATAN_Q[0], z.mul_add_k(ATAN_Q[1], ATAN_Q[2])),
        z.mul_add_k(ATAN_Q[3], ATAN_Q[4]),
    );
    let a = t.mul_add(z * p / q, t);
    let a = reduce.pick(a.k(FRAC_PI_4) + (a + 0.5 * MOREBITS), a);
    swap.pick((a.k(FRAC_PI_2) - a) + MOREBITS, a)
}

/// Coefficients of the degree-11 polynomial for `e^r` on `|r| ≤ ln 2 / 2`, lowest
/// degree first: a Chebyshev fit computed in 50-digit arithmetic and rounded to `f64`
/// (`crates/gaussian/tools/exp_fit.py`, which also measures the rounded polynomial's
/// largest relative error: 1.7e-17).
const EXP_POLY: [f64; 12] = [
    1.0,
    1.0,
    0.500_000_000_000_001_9,
    0.166_666_666_666_666_8,
    0.041_666_666_666_488_1,
    0.008_333_333_333_319_601,
    0.001_388_888_895_231_477_5,
    0.000_198_412_698_900_471_13,
    2.480_148_548_232_849_4e-5,
    2.755_724_091_857_897e-6,
    2.763_263_963_904_103e-7,
    2.511_003_760_596_377_7e-8,
];

/// `e^x = 2^k e^r` for `x ∈ [−708, 0]` (module docs), returned as `(e^r, shifted)`:
/// `shifted` holds `k` in the low bits of its representation ([`pow2_from_shifted`]
/// turns it into `2^k`).
#[inline(always)]
pub(super) fn exp_parts<S: Simd>(x: V<S>) -> (V<S>, V<S>) {
    let shifted = x * std::f64::consts::LOG2_E + ROUND_SHIFTER;
    let k = shifted - ROUND_SHIFTER;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    // Estrin's scheme: pairs `c_2i + c_2i+1 r`, then pairs of those in `r²`, then in
    // `r⁴`, `r⁸`: a dependency chain of a few operations instead of Horner's 22 (every
    // partial sum is positive on `|r| ≤ ln 2/2`, so the order costs no accuracy). No
    // closure for the pairs: it would be compiled outside the instruction-set build.
    let c = &EXP_POLY;
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let b0 = r2.mul_add(r.mul_add_k(c[3], c[2]), r.mul_add_k(c[1], c[0]));
    let b1 = r2.mul_add(r.mul_add_k(c[7], c[6]), r.mul_add_k(c[5], c[4]));
    let b2 = r2.mul_add(r.mul_add_k(c[11], c[10]), r.mul_add_k(c[9], c[8]));
    let e = r8.mul_add(b2, r4.mul_add(b1, b0));
    (e, shifted)
}

/// `2^k` from the `shifted` of [`exp_parts`] (`k ≥ −1022`).
#[inline(always)]
pub(super) fn pow2_from_shifted(shifted: f64) -> f64 {
    let k_bits = shifted.to_bits().wrapping_sub(ROUND_SHIFTER.to_bits());
    f64::from_bits(k_bits.wrapping_add(1023) << 52)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_arctangent_is_within_two_ulp_of_libm() {
        // libm's atan2 is an independent implementation (correctly rounded to within
        // 1 ulp); ratios over twenty decades and both sides of 0.66 and 1.
        let mut worst: f64 = 0.0;
        let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
        for i in 0..200_000 {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            let y = match i % 3 {
                0 => u,
                1 => 10f64.powf(-20.0 * u),
                _ => 0.5 + u,
            };
            let x = 1.0;
            for (a, b) in [(y, x), (x, y)] {
                let got = atan2_first_quadrant(V(pulp::Scalar, a), V(pulp::Scalar, b)).1;
                let want = a.atan2(b);
                worst = worst.max((got - want).abs() / want);
            }
        }
        assert!(worst <= 4.5e-16, "worst relative difference {worst:e}");
        assert_eq!(
            atan2_first_quadrant(V(pulp::Scalar, 0.0), V(pulp::Scalar, 1.0)).1,
            0.0
        );
    }

    #[test]
    fn the_exponential_is_within_two_ulp_of_libm() {
        let mut worst: f64 = 0.0;
        for i in 0..=700_000 {
            let x = -f64::from(i) * 1e-3 - 1e-9 * f64::from(i % 7);
            let (e, shifted) = exp_parts(V(pulp::Scalar, x));
            let got = e.1 * pow2_from_shifted(shifted.1);
            let want = x.exp();
            worst = worst.max((got - want).abs() / want);
        }
        assert!(worst <= 4.5e-16, "worst relative difference {worst:e}");
    }
}
